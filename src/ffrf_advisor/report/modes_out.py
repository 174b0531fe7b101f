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
        "step_ratio_quasi_static": adv.step_ratio_modes, "euler_share": adv.euler_share,
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
    console.print(f"loads: {adv.source}; the Euler cases {', '.join(EULER)} load the modes by at most "
                  f"{adv.euler_share:.1g} of the largest centrifugal case (none at q = 0: carried by the rigid "
                  "motion)", highlight=False)
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


def _worst(runs) -> float:
    return max((max(r.errors.values()) for r in runs), default=0.0)


def proof_json(proof) -> dict:
    """``modes --verify``: the verdict, each basis' size and worst error at the tightest tolerance, every run."""
    from ..modeset_proof import RTOLS
    return {"verdict": proof.verdict, "text": proof.text, "terms": list(proof.terms), "rtols": list(RTOLS),
            "bases": [{"basis": name, "size": size, "worst_error": json_number(_worst(proof.at(name)))
                       if name != "reference" else 0.0} for name, size in proof.sizes.items()],
            "runs": [{"basis": r.basis, "size": r.size, "scene": r.scene, "rtol": r.rtol,
                      "errors": {k: json_number(v) for k, v in r.errors.items()}, "evaluations": r.nfev,
                      "cost": r.cost} for r in proof.runs],
            "rk4_cost": [{"basis": b, "scene": s, "cost": c} for (b, s), c in proof.rk4_cost.items()]}


def proof_report(console: Console, proof) -> None:
    """One row per basis: size, worst error over the scenes at the tightest tolerance, its adaptive
    evaluations and its RK4 cost at its stable step against the reference's; the verdict below."""
    from ..modeset_proof import RTOLS
    scenes = sorted({r.scene for r in proof.runs})
    ref_rk4 = sum(proof.rk4_cost[("reference", s)] for s in scenes)
    rows = []
    for name, size in proof.sizes.items():
        runs = proof.at(name)
        rows.append((name, str(size), "-" if name == "reference" else f"{_worst(runs):.2g}",
                     "-" if name == "reference" else str(sum(r.nfev for r in runs)),
                     f"{sum(proof.rk4_cost[(name, s)] for s in scenes) / ref_rk4:.3g}"))
    fitted_table(console, f"mode sets by simulation (DOP853 rtol {RTOLS[-1]:g}, against the reference; "
                          f"{len(scenes)} scenes)",
                 ("basis", "size", "worst error", "evaluations", "RK4 cost / reference"), rows, left=("basis",))
    console.print(f"verdict: {proof.verdict}: {proof.text}", highlight=False)


def proof_figure(proof, directory, title: str) -> list:
    """The work-precision chart of the mode sets: worst error over the scenes against their summed cost
    (multiply-adds), one line per basis through its tolerances; written as PNG and SVG."""
    from ..modeset_proof import RTOLS
    from .verify_figures import plt, save
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for name in proof.sizes:
        if name == "reference":
            continue
        points = [(sum(r.cost for r in proof.at(name, t)), _worst(proof.at(name, t))) for t in RTOLS]
        ax.loglog(*zip(*points), marker="o", label=f"{name} ({proof.sizes[name]})")
    ax.axhline(proof.tolerance, color="grey", linestyle=":", label=f"tolerance {proof.tolerance:g}")
    ax.set_xlabel("cost [multiply-adds of the right-hand sides]")
    ax.set_ylabel("worst relative error over the scenes")
    ax.set_title(title)
    ax.legend(fontsize=8)
    return save(fig, directory, "mode_sets_work_precision")
