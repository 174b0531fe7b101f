"""One advisor run: body -> q_max -> significance -> advice (theory sections 6-8)."""
from __future__ import annotations

from dataclasses import dataclass, field

from .amplitudes import AmplitudeOptions, Amplitudes, q_max
from .body import FlexibleBody
from .guidelines import Advice, Situation, advise
from .significance import Significance, significance


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


def analyze(body: FlexibleBody, options: Options = Options()) -> Analysis:
    amp = q_max(body, options.amplitudes)
    sig = significance(body, amp.q_max, options.n_ratio)
    return Analysis(body, options, amp, sig, advise(body, amp, sig, options.situation))
