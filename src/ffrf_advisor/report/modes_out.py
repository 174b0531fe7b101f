"""The mode-set advice (modeset, theory 12) as JSON (schema ``modes``) and as console text."""
from __future__ import annotations

from rich.console import Console

from ..modeset import CASES, EULER, ModeAdvice
from .console import fitted_table, shown
from .json_out import json_number

SCHEMA_VERSION = 1


def _num(x, fmt: str = ".3g") -> str:
    return "n/a" if x is None or x != x else format(x, fmt)


def modes_json(adv: ModeAdvice, body: str, source: str, written: str | None = None) -> dict:
    """``modes --json``: the advised set (1-based modes, residual load cases), per mode, case and scene."""
    return {
        "schema_version": SCHEMA_VERSION, "body": body, "file": source, "tolerance": adv.tolerance,
        "band": adv.band, "loads_source": adv.source, "terms": list(adv.terms),
        "kept": [k + 1 for k in adv.kept], "residual_cases": [CASES[j] for j in adv.residual_cases],
        "size": adv.size, "modes_total": adv.nf, "summary": adv.summary(),
        "rhs_ratio": adv.rhs_ratio, "step_ratio": json_number(adv.step_ratio),
        "step_ratio_quasi_static": adv.step_ratio_modes,
        "modes": [{"mode": m.mode + 1, "f_hz": m.f_hz, "energy_share": json_number(m.participation),
                   "stress_share": json_number(m.stress_share), "keep": m.keep, "reason": m.reason}
                  for m in adv.modes],
        "cases": [{"case": c.case, "energy_error": json_number(c.energy), "stress_error": json_number(c.stress),
                   "residual_vector": c.residual} for c in adv.cases],
        "scenes": [{"scene": s.label, "cases": [CASES[j] for j in s.cases], "f_exc_hz": s.f_exc,
                    "excited_by": s.excited_by, "predicted_error": json_number(p[0]),
                    "predicted_error_with_residual_vectors": json_number(p[1])}
                   for s, p in zip(adv.scenes, adv.predicted)],
        "notes": list(adv.notes), "written": written,
    }


def mode_set_json(adv: ModeAdvice) -> dict:
    """analyze's ``mode_set``: the advised set for analyze's scenes in brief."""
    return {"summary": adv.summary(), "scenes": [s.label for s in adv.scenes], "kept": [k + 1 for k in adv.kept],
            "residual_cases": [CASES[j] for j in adv.residual_cases], "modes_total": adv.nf}


def modes_report(console: Console, adv: ModeAdvice, name: str) -> None:
    """The advice on top, then the scenes, the modes, the load cases (theory 12)."""
    console.print(f"[bold]{shown(name)}[/bold]: {adv.summary()}", highlight=False)
    console.print(f"loads: {adv.source}; the Euler cases {', '.join(EULER)} put no load on free modes at q = 0 "
                  "(carried by the rigid motion)", highlight=False)
    for note in adv.notes:
        console.print(f"note: {note}", highlight=False)
    fitted_table(console, f"scenes: what they excite and the predicted response error (band {adv.band:g} x f_exc)",
                 ("scene", "cases", "f_exc [Hz]", "set by", "error", "with residual vectors"),
                 [(s.label, " ".join(CASES[j] for j in s.cases) or "-", f"{s.f_exc:.4g}", s.excited_by,
                   _num(p[0], ".2g"), _num(p[1], ".2g")) for s, p in zip(adv.scenes, adv.predicted)],
                 left=("scene", "cases", "set by"))
    fitted_table(console, "modes: static energy and peak-stress share of the applied load cases",
                 ("mode", "f [Hz]", "energy share", "stress share", "decision"),
                 [(str(m.mode + 1), f"{m.f_hz:.4g}", _num(m.participation, ".2g"), _num(m.stress_share, ".2g"),
                   m.decision) for m in adv.modes], left=("decision",))
    fitted_table(console, f"load cases: static error of the kept modes (tolerance {adv.tolerance:g})",
                 ("case", "energy error", "stress error", "residual vector"),
                 [(c.case, _num(c.energy, ".2g"), _num(c.stress, ".2g"), "yes" if c.residual else "no")
                  for c in adv.cases])
