"""What the benchmarks time with: the wall time of a process, and minima over repeats of several timings
taken in turn within each repeat (serially): this machine's speed drifts by tens of per cent over minutes,
so timings taken in separate blocks would put the drift into their ratios.

The benchmarks run as scripts (``python benchmarks/NAME.py``), so this folder is on their path.
"""
from __future__ import annotations

import os
import subprocess
import time
from collections.abc import Callable


def installed_env(cache: str) -> dict[str, str]:
    """This environment as an installation's: bytecode written to and read from ``cache`` (a scratch
    PYTHONPYCACHEPREFIX; warm it with one run), even where PYTHONDONTWRITEBYTECODE is set here."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    return {**env, "PYTHONPYCACHEPREFIX": cache}


def wall(cmd: list[str], **run) -> float:
    """Seconds of one run of the process ``cmd`` (its output captured; ``run``: subprocess.run's env, cwd)."""
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True, **run)
    return time.perf_counter() - t0


def seconds(fn: Callable[[], object]) -> float:
    """Seconds of one call of ``fn`` (a timing for ``interleaved``)."""
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def interleaved(timings: dict[str, Callable[[], float]], repeat: int) -> dict[str, float]:
    """The minimum over ``repeat`` rounds of each timing (a function returning seconds), every timing taken once
    per round, in turn."""
    best = dict.fromkeys(timings, float("inf"))
    for _ in range(repeat):
        for name, fn in timings.items():
            best[name] = min(best[name], fn())
    return best
