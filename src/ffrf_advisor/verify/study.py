"""The whole verification of one body: scenes, term sets, work-precision, stability, Campbell, figures.

``ffrf-advisor verify`` calls ``run_study``; ``report.verify_json`` turns
the Study into the JSON of src/ffrf_advisor/schemas/verify.json.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..analysis import Analysis
from ..report import verify_figures as fig
from ..sim.equations import energy
from ..sim.linearise import campbell, linearise
from ..sim.model import build_model
from ..terms import FULL, LEVEL_SETS
from . import stability
from .runner import Verification, for_scenes, run_scene, term_sets, verify
from .scenes import Scene, SceneOptions, default_speed, make_scenes, stable_axes
from .workprecision import Point, pareto, work_precision

CAMPBELL_POINTS = 26  # 25 intervals: no sample falls exactly on s_crit (= top / 1.2)
CAMPBELL_SETS = ("advised", "I", "III", "IV (full)")


@dataclass(frozen=True)
class Study:
    """The verification and the studies around it (None: not run, ``verify --quick``)."""

    analysis: Analysis
    verification: Verification
    work_precision: list[Point] | None
    stability: dict | None
    campbell: dict | None
    figures: tuple[str, ...]


def campbell_data(a: Analysis, speed: float) -> dict:
    """Frequencies of the Campbell sets against spin about each axis up to 1.2 x max(s_crit, speed) (capped at
    1.2 x the largest finite s_crit), and each set's largest frequency error against the full set at ``speed``."""
    s_crit = a.significance.s_crit
    finite = s_crit[np.isfinite(s_crit)] if s_crit is not None else np.array([])
    top = 1.2 * max(finite.max() if finite.size else 0.0, speed, 1e-9)
    speeds = [np.linspace(0.0, top, CAMPBELL_POINTS) for _ in range(3)]
    sets = {ts.label: ts.terms for ts in term_sets(a) if ts.label in CAMPBELL_SETS}
    by_axis = {k: {label: campbell(build_model(a.body, terms), np.eye(3)[k], speeds[k])[0]
                   for label, terms in sets.items()} for k in range(3)}
    axis = stable_axes(a)[0]  # the major axis: rigid spin about it is stable
    full = linearise(build_model(a.body, FULL), np.eye(3)[axis], speed).frequencies
    error = {}
    for label, terms in sets.items():
        f = linearise(build_model(a.body, terms), np.eye(3)[axis], speed).frequencies
        n = min(len(f), len(full))
        error[label] = float(np.max(np.abs(f[:n] - full[:n]) / full[:n])) if n else None
    return {"speeds": speeds, "by_axis": by_axis, "s_crit": s_crit, "axis_of_error": axis, "speed": speed,
            "frequency_error": error}


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
              step: float | None = None, rtol: float = 1e-8, repeats: int = 3, directory: Path | None = None,
              scene_options: SceneOptions = SceneOptions(), criterion: str = "response", quick: bool = False,
              jobs: int = 1, progress=None) -> Study:
    """Everything ``verify`` reports; figures go to ``directory`` when given. The scenes and the verdict cover every
    axis of ``scenes.scene_axes`` (their runs on ``jobs`` local processes); work-precision, stability and drift
    use the first scene, Campbell all axes. ``quick``: the scenes and the verdict only (and their trajectory
    figures). ``progress(label, total)`` is told of each finished run, study and the figures."""
    scenes = make_scenes(scene_names, a, scene_options)
    a = for_scenes(a, scenes)
    total = len(scenes) * (1 + len(term_sets(a))) + (0 if quick else 3) + (directory is not None)
    told = (lambda label, _: progress(label, total)) if progress else (lambda label, _: None)
    ver = verify(a, scenes, tolerance, integrator, step, rtol, repeats, criterion, jobs, told)
    first = scenes[0]
    points = stab = camp = None
    if not quick:
        points = work_precision(a, first, ver.references[first.label],
                                tuple(ts for ts in term_sets(a) if ts.label != "Lagrangian superset"), repeats)
        told("work-precision", total)
        stab = stability_studies(a, first)
        told("stability studies", total)
        camp = campbell_data(a, default_speed(a))
        told("Campbell diagram", total)
    figures = () if directory is None else write_figures(a, ver, points, camp, stab, first, Path(directory))
    if directory is not None:
        told("figures", total)
    return Study(a, ver, points, stab, camp, figures)


def write_figures(a: Analysis, ver: Verification, points, camp: dict | None, stab: dict | None, scene: Scene,
                  directory: Path) -> tuple[str, ...]:
    """trajectories_<scene>_axis<k>, and unless the studies were left out (quick) work_precision, drift,
    stability and campbell, each as PNG and SVG."""
    directory.mkdir(parents=True, exist_ok=True)
    unit = a.body.units.time
    paths = []
    for sc in ver.scenes:
        model_runs = {r.set.label: r.run for r in ver.results if r.scene == sc.label}
        paths += fig.save(fig.trajectories(ver.references[sc.label].run, model_runs, a.body.sigma_max, unit,
                                           a.body.units.stress, f"{a.body.name}: {sc.label}"),
                          directory, f"trajectories_{sc.name}_axis{sc.axis + 1}")
    if points is None:
        return tuple(str(p) for p in paths)
    paths += fig.save(fig.work_precision_chart(points, pareto(points),
                                               f"{a.body.name}: {scene.label}, work-precision (timings serial)"),
                      directory, "work_precision")
    paths += fig.save(fig.drift_chart(drift_curves(a, scene), unit, f"{a.body.name}: {scene.label}, energy drift"),
                      directory, "drift")
    paths += fig.save(fig.stability_chart(stab, unit, f"{a.body.name}: stability where methods fail"), directory,
                      "stability")
    paths += fig.save(fig.campbell_chart(camp["speeds"], camp["by_axis"], camp["s_crit"], unit, unit), directory,
                      "campbell")
    return tuple(str(p) for p in paths)
