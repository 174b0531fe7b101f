"""One advisor run: body -> q_max -> significance -> advice (theory sections 6-8)."""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .amplitudes import Amplitudes, q_max
from .body import FlexibleBody
from .checks import Check, check_warnings, density_warnings, run_checks, source_warnings
from .errors import FFRFError
from .guidelines import Advice, advise
from .significance import Significance, significance
from .situation import Options, check_options


@dataclass(frozen=True)
class Analysis:
    body: FlexibleBody
    options: Options
    amplitudes: Amplitudes
    significance: Significance
    advice: Advice
    checks: tuple[Check, ...] = ()


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
    advice = replace(advice, warnings=source_warnings(body) + check_warnings(list(checks)) + density_warnings(body)
                     + advice.warnings)
    return Analysis(body, options, amp, sig, advice, checks)
