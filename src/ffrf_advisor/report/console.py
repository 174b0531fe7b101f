"""Rich console rendering of a body summary (the `info` command)."""
from __future__ import annotations

import numpy as np
from rich.console import Console
from rich.table import Table

from ..body import FlexibleBody
from ..checks import Check


def _matrix(a: np.ndarray) -> str:
    return "\n".join("  ".join(f"{x:>12.5e}" for x in row) for row in np.atleast_2d(a))


def body_summary(console: Console, body: FlexibleBody, checks: list[Check]) -> None:
    """Mass, CoM, I0, eigenfrequencies and modal stress, and the checks of theory section 4."""
    u = body.units
    console.print(f"[bold]{body.name}[/bold]  units {u}  ({body.provenance.mass_matrix} mass; "
                  f"{body.provenance.source})")
    for note in body.provenance.notes:
        console.print(f"  {note}")
    console.print(f"mass      {body.mass:.6e} {u.mass}")
    console.print(f"CoM       [{', '.join(f'{x:.4e}' for x in body.com)}] {u.length}")
    console.print(f"I0 [{u.mass} {u.length}^2]\n{_matrix(body.I0)}")
    modes = Table(title=f"{body.nf} flexible modes")
    modes.add_column("mode", justify="right")
    modes.add_column(f"f [1/{u.time}]", justify="right")
    modes.add_column(f"lambda [1/{u.time}^2]", justify="right")
    modes.add_column(f"sigma_vM,max at q=1 [{u.stress}]", justify="right")
    for p in range(body.nf):
        sigma = "-" if body.sigma_max is None else f"{body.sigma_max[p]:.4e}"
        modes.add_row(str(p + 1), f"{body.frequencies_hz[p]:.4f}", f"{body.eigenvalues[p]:.6e}", sigma)
    console.print(modes)
    console.print(checks_table(checks))
    failed = [c for c in checks if not c.passed]
    if failed:
        fix = ("the stiffness is stored: the basis can be transformed (theory section 4)"
               if body.fe is not None and body.fe.K is not None
               else "no stiffness matrix: results carry the caveat that these assumptions fail")
        console.print(f"[yellow]warning[/yellow]: {len(failed)} assumption(s) fail: "
                      + "; ".join(c.assumption for c in failed) + f" — {fix}")


def checks_table(checks: list[Check]) -> Table:
    table = Table(title="checks (theory section 4)")
    table.add_column("check")
    table.add_column("value", justify="right")
    table.add_column("tolerance", justify="right")
    table.add_column("result")
    for c in checks:
        op = ">" if c.name == "mass" else "<="
        table.add_row(c.name, f"{c.value:.3e}", f"{op} {c.tolerance:.1e}",
                      "[green]pass[/green]" if c.passed else "[red]FAIL[/red]")
    return table
