"""What a run costs without running it again: the compiled right-hand side's seconds per evaluation, measured in a
short compiled loop (the minimum of a few repeats), and the repeats a run's own wall time needs.

A verification times every term set from one run each: its cost is its evaluations times its set's seconds per
evaluation (``evaluation_seconds``), which is free of the timer's noise; a second and third run of the same set
only to take the minimum of their wall times were half of `verify`'s evaluations.
"""
from __future__ import annotations

import time

import numpy as np

from .kernels import FREE, call_rhs, jit
from .model import Model

LOOP_SECONDS = 1e-3   # each timed loop lasts about this long: far above perf_counter's resolution (about 1e-7 s)
LOOP_REPEATS = 5      # loops timed; the minimum counts (the least disturbed by other processes)
SHORT_RUN = 1e-4      # a run shorter than this (s) is timed again (``timed``): its call and the scheduler set its time
SHORT_REPEATS = 5


@jit
def _evaluations(rhs, y, out, n, model, zero3, zf):
    """``n`` calls of the right-hand side at the address ``rhs`` (kernels.rhs_address) at the state ``y``."""
    for _ in range(n):
        call_rhs(rhs, y, out, model, zero3, zf, FREE[0], zero3, zero3)


def evaluation_seconds(model: Model, y: np.ndarray) -> float:
    """Seconds of one right-hand side of ``model`` at the state ``y``: the minimum over LOOP_REPEATS compiled loops
    of about LOOP_SECONDS each (their length set by a first loop of 20 calls)."""
    from .integrate import compiled_args
    address, compiled = compiled_args(model)
    y = np.ascontiguousarray(y, dtype=float)
    out, zero3, zf = np.empty_like(y), np.zeros(3), np.zeros(model.nf)

    def loop(n: int) -> float:
        t0 = time.perf_counter()
        _evaluations(address, y, out, n, compiled, zero3, zf)
        return (time.perf_counter() - t0) / n
    n = max(20, int(LOOP_SECONDS / max(loop(20), 1e-9)))
    return min(loop(n) for _ in range(LOOP_REPEATS))


def timed(run, repeats: int = 1):
    """(the first of ``repeats`` calls of ``run()``, the minimum of their ``wall_s``); a run shorter than SHORT_RUN
    is taken up to SHORT_REPEATS times in all (there the process's scheduling, not the work, sets the time)."""
    first = run()
    walls = [first.wall_s]
    while len(walls) < repeats or (walls[-1] < SHORT_RUN and len(walls) < SHORT_REPEATS):
        walls.append(run().wall_s)
    return first, min(walls)
