"""The whole verification of one body: scenes, term sets, work-precision, stability, Campbell (data only).

``ffrf-advisor verify`` calls ``run_study``; ``report.verify_json`` turns
the Study into the JSON of src/ffrf_advisor/schemas/verify.json and
``report.verify_figures`` draws it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..analysis import Analysis
from ..pool import beside
from ..response import frequency_change
from ..situation import Situation
from ..sim.equations import energy
from ..sim.integrate import COMPILED, EXPONENTIAL, compile_beside
from ..sim.linearise import campbell, campbell_speeds
from ..sim.model import build_model
from ..terms import FULL, LEVEL_SETS
from ..units import TIME
from . import stability
from .runner import Verification, distinct, for_scenes, run_scene, stiffened, term_sets, verify
from .scenes import Scene, SceneOptions, default_speed, deformation_axis, make_scenes, stable_axes
from .workprecision import Point, work_precision

CAMPBELL_POINTS = 41  # 40 intervals; a sample on an s_crit is left out (linearise.campbell), not drawn as a spike
CAMPBELL_SETS = ("advised", "I", "II", "III", "IV (full)")


@dataclass(frozen=True)
class Study:
    """The verification and the studies around it (None: not run, ``verify --quick``)."""

    analysis: Analysis
    verification: Verification
    work_precision: list[Point] | None
    stability: dict | None
    campbell: dict | None
    asked: Situation | None = None  # the operating point as asked, before ``for_scenes`` raised the speed


def campbell_data(a: Analysis, speed: float, axis: int | None = None) -> dict:
    """Branches of the Campbell sets (``sim.linearise.campbell``: tracked by mode shape, NaN where the
    linearisation is singular or the set unstable, ``gaps`` saying which) against spin about each axis k up to
    1.2 x the largest of ``speed`` and its finite s_crit without and with geometric stiffening (each axis its own
    range); and each set's largest frequency error against the reference of the scenes, as
    ``runner.frequency_error`` (the full set, with geo_stiff when the body carries G), at ``speed`` (rad per body
    time unit) about ``axis`` (0-based; default the deformation axis, the first scene's)."""
    sig = a.significance
    speeds = [campbell_speeds(k, speed, (sig.s_crit, sig.s_crit_stiffened), CAMPBELL_POINTS, 1.2) for k in range(3)]
    sets = {ts.label: ts.terms for ts in term_sets(a) if ts.label in CAMPBELL_SETS}
    branches = {}  # per (terms, axis): sets with the same terms (the advised set and IV, say) computed once
    for terms in dict.fromkeys(sets.values()):
        model = build_model(a.body, terms)
        for k in range(3):
            branches[terms, k] = campbell(model, np.eye(3)[k], speeds[k])
    by_axis = {k: {label: branches[terms, k].frequencies for label, terms in sets.items()} for k in range(3)}
    gaps = {k: {label: branches[terms, k].gaps.tolist() for label, terms in sets.items()} for k in range(3)}
    axis = deformation_axis(a) if axis is None else axis
    reference = stiffened(a, FULL)
    error = {label: 0.0 if tuple(terms) == reference else
             frequency_change(a.body, terms, reference, np.eye(3)[axis], speed) for label, terms in sets.items()}
    return {"speeds": speeds, "by_axis": by_axis, "gaps": gaps, "sets": sets, "s_crit": sig.s_crit,
            "s_crit_stiffened": sig.s_crit_stiffened, "axis_of_error": axis, "speed": speed,
            "w_op": (a.options.situation.w_op or 0.0) * float(TIME[a.body.units.time]),
            "reference": "full set with geo_stiff" if "geo_stiff" in reference else "full set",
            "reference_terms": reference, "frequency_error": error,
            "reference_label": min((label for label, terms in sets.items() if tuple(terms) == reference),
                                   key=lambda label: label != "IV (full)", default=None)}


def drift_curves(a: Analysis, scene: Scene) -> dict:
    """|E(t) - E0| / |E0| of the canonical sets in ``scene`` (DOP853 at 1e-10: the drift is the model's)."""
    curves = {}
    for label, terms in LEVEL_SETS.items():
        model = build_model(a.body, terms, scene.damping)
        run = run_scene(model, scene, "dop853", rtol=1e-10)
        E = energy(model, run.y)
        curves[label] = (run.t, np.abs(E - E[0]) / abs(E[0]) if E[0] else np.zeros_like(E))
    return curves


def stability_studies(a: Analysis, scene: Scene) -> dict:
    """The numbers of the stability section of the issue/theory 10: each measured beside its prediction."""
    speed = default_speed(a)
    axis = stable_axes(a)[0]  # the major axis: rigid spin about it is stable
    return {
        "rk4_limit_rest": stability.rk4_step_limit(a),
        "rk4_limit_spin": stability.rk4_step_limit(a, speed, axis),
        "spin": {"speed": speed, "axis": axis + 1},
        "euler_growth": stability.euler_growth(a),
        "divergence_onset": stability.divergence_onset(a),
        "implicit": stability.implicit_stability(a),
        "drift_against_step": stability.drift_against_step(a, scene),
    }


def run_study(a: Analysis, scene_names, tolerance: float = 0.01, integrator: str = "dop853",
              step: float | None = None, rtol: float = 1e-8, repeats: int = 1,
              scene_options: SceneOptions = SceneOptions(), criterion: str = "response", quick: bool = False,
              jobs: int = 1, progress=None) -> Study:
    """Everything ``verify`` reports. The scenes and the verdict cover every axis of ``scenes.scene_axes`` (their
    runs on ``jobs`` local processes); work-precision, stability and drift use the first scene, Campbell all
    axes. ``quick``: the scenes and the verdict only. ``progress(label, done, total)`` is told of each finished
    run and study."""
    scenes = make_scenes(scene_names, a, scene_options)
    asked, a = a.options.situation, for_scenes(a, scenes)
    runs = len(scenes) * (1 + len(distinct(term_sets(a))))
    total = runs + (0 if quick else 3)
    told = (lambda label, done, _: progress(label, done, total)) if progress else (lambda *_: None)
    first = scenes[0]
    kernels = {EXPONENTIAL, integrator.removesuffix("-lie")} if quick else set(COMPILED) - {"rhs"}  # rk4-lie: rk4's
    compile_beside(sorted(kernels & set(COMPILED)))
    studies = None if quick else lambda: (stability_studies(a, first), campbell_data(a, first.speed, first.axis))
    # One job: the studies, which time nothing, run beside the references, ended before the first timed run.
    # Never beside a pool: its workers fork, and a fork beside a running thread can inherit a held lock.
    pending = beside(studies) if studies and jobs <= 1 else None
    ver = verify(a, scenes, tolerance, integrator, step, rtol, repeats, criterion, jobs, told, pending)
    points = stab = camp = None
    if not quick:
        points = work_precision(a, first, ver.references[first.label],
                                tuple(ts for ts in term_sets(a) if ts.label != "Lagrangian superset"), repeats)
        told("work-precision", runs + 1, total)
        stab, camp = pending() if pending else studies()
        told("stability studies", runs + 2, total)
        told("Campbell diagram", runs + 3, total)
    return Study(a, ver, points, stab, camp, asked)
