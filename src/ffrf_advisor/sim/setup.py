"""Simulation inputs checked and converted: seconds to the body's time unit, q_max initial amplitudes."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..amplitudes import AmplitudeOptions, q_max
from ..body import FlexibleBody
from ..errors import FFRFError
from ..units import TIME
from .integrate import FIXED, INTEGRATORS


@dataclass(frozen=True)
class Setup:
    """Times in the body's time unit; ``per_second`` converts 1/s to 1/(body time unit)."""

    per_second: float
    t_end: float
    step: float | None
    output_step: float | None


def _positive(name: str, value: float | None, required: bool = False) -> None:
    if value is None and not required:
        return
    if value is None or not math.isfinite(value) or value <= 0:
        raise FFRFError(f"{name}: expected a positive number of seconds, got {value}")


def simulation_setup(body: FlexibleBody, t_end: float, step: float | None, output_step: float | None,
                     integrator: str) -> Setup:
    """Validated times (seconds in, body units out); fixed-step methods need a step."""
    if integrator not in INTEGRATORS:
        raise FFRFError(f"--integrator {integrator!r}: expected one of {', '.join(INTEGRATORS)}")
    _positive("--t-end", t_end, required=True)
    _positive("--step", step, required=integrator in FIXED)
    _positive("--output-step", output_step)
    seconds = float(TIME[body.units.time])  # seconds per body time unit
    if step is not None and t_end / step > 1e9:
        raise FFRFError(f"--step {step}: expected at most 1e9 steps to --t-end {t_end}")
    to_body = (lambda x: None if x is None else x / seconds)  # noqa: E731
    return Setup(seconds, to_body(t_end), to_body(step), to_body(output_step))


def q_max_of(body: FlexibleBody, options: AmplitudeOptions) -> np.ndarray:
    """Every mode at its q_max (theory section 6), in the body's units."""
    return q_max(body, options).q_max
