"""A Nastran SOL 103 run's redundant numbers and its rigid modes (issue 49): the mode ids of the eigenvector and
eigenvalue (LAMA) tables, the eigenvalues both carry, and the rigid modes told by their shape, their count
against the run's SPC and SUPORT cards (io.rigid_modes, every reader's shape test).
"""
from __future__ import annotations

import numpy as np

from ..consistency import check_frequencies, check_mode_numbers
from ..errors import BodyFileError
from ..fe.modal import N_RIGID
from .nastran_modes import NastranModes
from .rigid_modes import rigid_modes_of

OP2_DIGITS = 7  # the OP2 holds eigenvalues in float32 (24-bit mantissa: 7 significant digits)


def check_tables(path, ev, table) -> None:
    """Mode ids of the eigenvectors (and of the LAMA table, if there is one) count 1, 2, 3 ...; the eigenvalues
    of the vectors' headers and the LAMA table, and the LAMA's RADIANS / 2 pi and CYCLES, agree to float32
    (compared as f = sqrt(|lambda|) / 2 pi: a rigid mode's round-off has either sign)."""
    check_mode_numbers(path, "eigenvector mode ids", np.asarray(ev.modes).ravel(), first=1)
    if table is None:
        return
    check_mode_numbers(path, "eigenvalue table (LAMA) mode ids", np.asarray(table.mode).ravel(), first=1)
    lama = np.abs(np.asarray(table.eigenvalues, float))
    check_frequencies(path, ("eigenvalue table (LAMA)", "the eigenvectors' headers"),
                      np.sqrt(lama) / (2 * np.pi), np.abs(np.asarray(ev.eigns, float)), OP2_DIGITS)
    for column, f in (("RADIANS", np.asarray(table.radians, float) / (2 * np.pi)),
                      ("CYCLES", np.asarray(table.cycles, float))):  # Nastran's of sqrt(|lambda|), as its own files
        check_frequencies(path, (f"eigenvalue table (LAMA) {column}", "its EIGENVALUE column"), f, lama, OP2_DIGITS)


def constraints(m) -> tuple[int | None, str]:
    """The rigid-mode count the model's constraints give and their description: six without SPC (SPC, SPC1,
    SPCADD or a grid's PS), the DOFs of its SUPORT / SUPORT1 cards with them, None (not known) with SPC alone."""
    spc = bool(m.spcs or m.spcadds or any(getattr(g, "ps", "") for g in m.nodes.values()))
    suport = [*m.suport, *m.suport1.values()]
    dofs = sum(len(str(c)) for card in suport for c in card.Cs)
    if not spc:
        return N_RIGID, "no SPC, SPC1, SPCADD nor grid PS in the model: a free run"
    if suport:
        return dofs, f"SPC with SUPORT on {dofs} DOFs"
    return None, "SPC in the model"


def rigid(path, run: NastranModes) -> tuple[np.ndarray, list[str]]:
    """Which modes of ``run`` are rigid and notes naming them (``rigid_modes_of`` with its constraints)."""
    return rigid_modes_of(path, run.points, run.T, run.eigenvalues, run.rigid_expected, run.constraints)
