"""One advisor run: body -> q_max -> significance -> advice (theory sections 6-8)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from .amplitudes import AmplitudeOptions, Amplitudes, q_max
from .body import FlexibleBody
from .checks import Check, check_warnings, density_warnings, run_checks
from .errors import FFRFError
from .guidelines import RULE_SETS, Advice, Situation, advise, check_thresholds
from .predict import EXCITATIONS
from .significance import Significance, significance
from .units import MAX_SPEED


@dataclass(frozen=True)
class Options:
    amplitudes: AmplitudeOptions = field(default_factory=AmplitudeOptions)
    situation: Situation = field(default_factory=Situation)
    n_ratio: int | None = None


@dataclass(frozen=True)
class Analysis:
    body: FlexibleBody
    options: Options
    amplitudes: Amplitudes
    significance: Significance
    advice: Advice
    checks: tuple[Check, ...] = ()


def _number(name: str, value, positive: bool) -> None:
    """``value`` must be a finite number, positive (or non-negative): one line naming the option otherwise."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and (value > 0 if positive else value >= 0)
    if not ok:
        raise FFRFError(f"{name} {value!r}: expected a finite {'positive' if positive else 'non-negative'} number")




def check_options(options: Options) -> None:
    """Every analysis option finite and in range (theory section 8): NaN or inf would switch rules off."""
    amp, sit = options.amplitudes, options.situation
    _number("--sigma-allow", amp.sigma_allow, True)
    _number("--q-cap", amp.q_cap, True)
    if amp.deflection_cap is not None:
        _number("--deflection-cap", amp.deflection_cap, True)
    if sit.w_op is not None:
        _number("--speed", sit.w_op, False)
        if sit.w_op > MAX_SPEED:
            raise FFRFError(f"--speed {sit.w_op:g} rad/s: expected at most {MAX_SPEED:g} rad/s "
                            f"({MAX_SPEED / (2 * math.pi):.3g} Hz, far above any structure's modes)")
    if sit.f_sys is not None:
        _number("--f-sys", sit.f_sys, True)
    n = options.n_ratio
    if n is not None and (isinstance(n, bool) or not isinstance(n, int) or n < 1):
        raise FFRFError(f"--n-ratio {options.n_ratio!r}: expected a whole number >= 1")
    _number("--tolerance", sit.tolerance, True)
    if sit.rules not in RULE_SETS:
        raise FFRFError(f"--rules {sit.rules!r}: expected one of {', '.join(RULE_SETS)}")
    if sit.excitation not in EXCITATIONS:
        raise FFRFError(f"--excitation {sit.excitation!r}: expected one of {', '.join(EXCITATIONS)}")
    check_thresholds(sit.thresholds, "--threshold")


def analyze(body: FlexibleBody, options: Options = Options()) -> Analysis:
    """q_max, significance and advice of ``body`` with checked ``options`` (theory sections 6-8). An overflow or
    an invalid operation is an error naming the body and the options, never a NaN in a result."""
    check_options(options)
    try:
        with np.errstate(over="raise", invalid="raise"):
            amp = q_max(body, options.amplitudes)
            sig = significance(body, amp.q_max, options.n_ratio)
            checks = tuple(run_checks(body))
            advice = advise(body, amp, sig, options.situation)
    except FloatingPointError as e:
        raise FFRFError(f"{body.name}: analysis: expected numbers of physical size in the body and the options "
                        f"(--speed, --q-max, --sigma-allow, --q-cap), got {e}") from None
    advice = replace(advice, warnings=check_warnings(list(checks)) + density_warnings(body) + advice.warnings)
    return Analysis(body, options, amp, sig, advice, checks)
