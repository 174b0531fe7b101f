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


MAX_PERIODS = 1e7  # work budget of one simulation: periods of its highest mode (steps follow from them)


def check_tolerances(rtol: float, atol: float) -> None:
    """An adaptive run's tolerances: rtol in (0, 1), atol finite and positive (else it never ends)."""
    if not (math.isfinite(rtol) and 0 < rtol < 1):
        raise FFRFError(f"--rtol {rtol}: expected a number between 0 and 1")
    if not (math.isfinite(atol) and atol > 0):
        raise FFRFError(f"--atol {atol}: expected a finite positive number")


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
    f_max = float(np.max(body.frequencies_hz)) / seconds if body.nf else 0.0  # Hz
    if t_end * f_max > MAX_PERIODS:
        raise FFRFError(f"--t-end {t_end}: expected at most {MAX_PERIODS:.0e} periods of the highest mode "
                        f"(mode {body.nf}, {f_max:.4g} Hz), i.e. at most {MAX_PERIODS / f_max:.4g} s: every "
                        "integrator resolves each period")
    to_body = (lambda x: None if x is None else x / seconds)  # noqa: E731
    return Setup(seconds, to_body(t_end), to_body(step), to_body(output_step))


def q_max_of(body: FlexibleBody, options: AmplitudeOptions) -> np.ndarray:
    """Every mode at its q_max (theory section 6), in the body's units."""
    return q_max(body, options).q_max
