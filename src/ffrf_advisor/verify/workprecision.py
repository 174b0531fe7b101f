"""Work-precision data: error against cost per term set and integrator over tolerances and steps (theory section 10).

Like DiffEqDevTools' work-precision sets: every (term set, integrator:
DOP853 and its exponential form sim.lawson, RK4, the implicit midpoint rule)
pair is run at a range of tolerances (adaptive) or steps (fixed), its
error is the worst of the scene's errors against the reference, its cost
the wall time of one run (sim.timing.timed: the minimum over ``repeats``
serial runs where asked, or over a few where a run is too short to time)
and the right-hand-side evaluations. Failed runs are kept and drawn as failed.
The Pareto front is the set of runs no other run beats in both cost and
error.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..analysis import Analysis
from ..sim.integrate import EXPONENTIAL, rk4_limit
from ..sim.model import build_model
from ..sim.timing import timed
from .measures import worst
from .runner import Reference, TermSet, distinct, run_scene, scene_errors
from .scenes import Scene

RTOLS = (1e-3, 1e-5, 1e-7, 1e-9)
RK4_STEPS = (1.2, 0.9, 0.45, 0.22, 0.11)   # times the RK4 limit 2 sqrt 2 / Omega_max
MIDPOINT_STEPS = (8.0, 4.0, 2.0)            # times the RK4 limit: beyond the explicit limit


@dataclass(frozen=True)
class Point:
    set: str
    integrator: str
    setting: float      # rtol, or the step in body time units
    wall_s: float
    nfev: int
    error: float        # worst relative error; inf when failed
    failed: bool


def work_precision(a: Analysis, scene: Scene, ref: Reference, sets: tuple[TermSet, ...],
                   repeats: int = 1) -> list[Point]:
    """The work-precision points of ``sets`` in ``scene``; sets with the same terms share the runs of the first
    (``runner.distinct``), each under its own name."""
    limit = rk4_limit(a.body.eigenvalues)
    runs = ([(name, r, None) for name in ("dop853", EXPONENTIAL) for r in RTOLS]
            + [("rk4", f * limit, f * limit) for f in RK4_STEPS]
            + [("midpoint", f * limit, f * limit) for f in MIDPOINT_STEPS])
    of_terms = {ts.terms: _points(a, scene, ref, ts, runs, repeats) for ts in distinct(sets)}
    return [replace(p, set=ts.label) for ts in sets for p in of_terms[ts.terms]]


def _points(a: Analysis, scene: Scene, ref: Reference, ts: TermSet, runs, repeats: int) -> list[Point]:
    """The points of one set: each of ``runs`` (integrator, setting, fixed step or None) against the reference."""
    model = build_model(a.body, ts.terms, scene.damping)
    points = []
    for integrator, setting, step in runs:
        rtol = setting if step is None else 1e-8
        run, wall = timed(lambda: run_scene(model, scene, integrator, step, rtol), repeats)
        err = scene_errors(a, run, ref.run)
        used = setting if run.step is None else run.step  # fixed steps divide the sampling interval
        points.append(Point(ts.label, integrator, float(used), wall, run.nfev,
                            worst(err), bool(run.failed or not np.isfinite(worst(err)))))
    return points


def pareto(points: list[Point]) -> list[Point]:
    """The runs that no other run beats in both wall time and error (failed runs excluded), by cost."""
    front, best = [], np.inf
    for p in sorted((p for p in points if not p.failed), key=lambda p: (p.wall_s, p.error)):
        if p.error < best:
            front.append(p)
            best = p.error
    return front
