"""Sweeps of verifications (bodies x speeds x scenes): serially, on local processes, or on a Dask cluster.

Each task reads its body, analyses it at its speed and verifies the advice;
it returns a plain dict (picklable, the same wherever it ran). Only
accuracies are compared across a sweep; wall times of a distributed run
mean nothing, and the work-precision timings are always taken serially on
one machine (``verify``), which the output says.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ..analysis import analyze
from ..situation import Options, Situation
from ..io import read_body
from ..pool import mapper
from .measures import CRITERIA, worst
from .runner import for_scenes, judge, verify
from .scenes import SceneOptions, make_scenes

SCHEDULER_ENV = "DASK_SCHEDULER_ADDRESS"


@dataclass(frozen=True)
class Task:
    """One row: a body file, a spin speed (rad/s; 0: at rest, torque pulse only), its share of s_crit, scenes."""

    body: str
    speed: float
    fraction: float
    scenes: tuple[str, ...]
    tolerance: float = 0.01
    criterion: str = "response"


def run_task(task: Task) -> dict:
    """Verify the advice for one body and speed; the row of docs/verification.md."""
    body = read_body(task.body)
    a = analyze(body, Options(situation=Situation(w_op=task.speed)))
    opts = SceneOptions(speed=task.speed if task.speed > 0 else None)
    scenes = make_scenes(task.scenes, a, opts)
    a = for_scenes(a, scenes)
    v = verify(a, scenes, task.tolerance, repeats=1, criterion=task.criterion)
    sets, worst_of = {}, {}
    for r in v.results:
        sets.setdefault(r.set.label, {})[r.scene] = {k: (None if not np.isfinite(e) else float(e))
                                                     for k, e in r.errors.items()}  # null: infinite or NaN
        worst_of[r.set.label] = max(worst_of.get(r.set.label, 0.0), worst(r.errors, task.criterion))
    other = {c: judge(a, v.results, v.references, task.tolerance, c) for c in CRITERIA if c != task.criterion}
    return {"body": body.name, "speed_rad_s": task.speed, "fraction_of_s_crit": task.fraction,
            "scenes": list(task.scenes), "advice_speed_rad_s": a.options.situation.w_op,
            "advice_excitation": a.options.situation.excitation,
            "advised_level": a.advice.level, "advised_terms": list(a.advice.terms), "criterion": task.criterion,
            "cheapest": v.verdict.cheapest, "verdict": v.verdict.verdict, "text": v.verdict.text,
            "broken": [list(b) for b in v.verdict.broken],
            "unjudged": [list(u) for u in v.verdict.unjudged],
            "other_criteria": {c: {"verdict": j.verdict, "cheapest": j.cheapest} for c, j in other.items()},
            "worst_error": {k: (None if not np.isfinite(x) else float(x)) for k, x in worst_of.items()},
            "errors": sets}


def run_sweep(tasks: list[Task], jobs: int = 1, scheduler: str | None = None, row=run_task) -> list[dict]:
    """Rows (``row(task)``, a picklable function) in task order: on the Dask cluster at ``scheduler`` (or
    $DASK_SCHEDULER_ADDRESS), else on ``jobs`` local processes, else serially."""
    scheduler = scheduler or os.environ.get(SCHEDULER_ENV)
    if scheduler:
        from distributed import Client  # optional extra: pip install 'ffrf-advisor[distributed]'
        with Client(scheduler) as client:
            return client.gather(client.map(row, tasks, pure=False))
    with mapper(jobs, tasks=len(tasks)) as map_:
        return list(map_(row, tasks))
