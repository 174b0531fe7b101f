"""Simulation inputs checked and converted: seconds to the body's time unit, q_max initial amplitudes."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..amplitudes import AmplitudeOptions, check_size, q_max
from ..body import FlexibleBody
from ..errors import FFRFError
from ..units import MAX_SPEED, TIME
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
        raise FFRFError(f"{name}: expected a positive number of seconds, got {'nothing' if value is None else value}")


MAX_PERIODS = 1e7  # work budget of one simulation: periods of its highest mode (steps follow from them)


MIN_RTOL = 100 * np.finfo(float).eps  # scipy's floor: below it the steps resolve round-off


def check_tolerances(rtol: float, atol: float) -> None:
    """An adaptive run's tolerances: rtol in [MIN_RTOL, 1), atol finite and positive (else it never ends)."""
    if not (math.isfinite(rtol) and MIN_RTOL <= rtol < 1):
        raise FFRFError(f"--rtol {rtol}: expected a number from {MIN_RTOL:.2g} (100 machine epsilons) below 1")
    if not (math.isfinite(atol) and atol > 0):
        raise FFRFError(f"--atol {atol}: expected a finite positive number")


MAX_SAMPLES = 10**7  # of a trajectory (--output-step): 10^7 rows of 7 + 2 nf numbers


def check_initial_state(body: FlexibleBody, omega0, q0, qd0) -> None:
    """An initial spin of at most MAX_SPEED rad/s and modal coordinates (and velocities over their
    frequencies) of at most MAX_DEFLECTION times the body's size (theory 6): beyond, the numbers overflow or
    the adaptive steps shrink without end."""
    with np.errstate(over="ignore"):  # an overflow is inf, refused below
        speed = float(np.linalg.norm(omega0)) if omega0 is not None and len(omega0) else 0.0
    if not speed <= MAX_SPEED:
        raise FFRFError(f"--omega0: expected at most {MAX_SPEED:g} rad/s, got {speed:.3g}")
    for name, q, scale in (("--q0", q0, 1.0), ("--qd0", qd0, np.sqrt(body.eigenvalues))):
        if q is not None and len(q) == body.nf:
            check_size(body, np.asarray(q, float) / scale, name)


def simulation_setup(body: FlexibleBody, t_end: float, step: float | None, output_step: float | None,
                     integrator: str) -> Setup:
    """Validated times (seconds in, body units out); fixed-step methods need a step."""
    if integrator not in INTEGRATORS:
        raise FFRFError(f"--integrator {integrator!r}: expected one of {', '.join(INTEGRATORS)}")
    _positive("--t-end", t_end, required=True)
    if step is None and integrator in FIXED:
        raise FFRFError(f"--integrator {integrator}: a fixed-step method; expected --step in seconds, e.g. 1e-5")
    _positive("--step", step)
    _positive("--output-step", output_step)
    seconds = float(TIME[body.units.time])  # seconds per body time unit
    if step is not None and t_end / step > 1e9:
        raise FFRFError(f"--step {step}: expected at most 1e9 steps to --t-end {t_end}")
    if output_step is not None and t_end / output_step > MAX_SAMPLES:
        raise FFRFError(f"--output-step {output_step}: expected at most {MAX_SAMPLES:.0e} samples to --t-end {t_end}")
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
