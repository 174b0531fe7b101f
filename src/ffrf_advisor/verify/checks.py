"""Options of `verify` checked before any work: one-line errors naming the option."""
from __future__ import annotations

import math
from pathlib import Path

from ..errors import FFRFError
from ..sim.integrate import FIXED, INTEGRATORS
from .measures import CRITERIA
from .scenes import SCENES

# --fail-on: the verdicts that end verify with exit 1 (no verdict: the advice could not be checked)
FAILING = {"never": (), "unsafe": ("unsafe", "no verdict"), "conservative": ("unsafe", "conservative", "no verdict")}


def check_verify_options(scenes, tolerance: float, integrator: str, step: float | None, rtol: float,
                         repeats: int, output: Path | None, criterion: str = "response",
                         fail_on: str = "never") -> None:
    if fail_on not in FAILING:
        raise FFRFError(f"--fail-on {fail_on!r}: expected one of {', '.join(FAILING)}")
    if criterion not in CRITERIA:
        raise FFRFError(f"--criterion {criterion!r}: expected one of {', '.join(CRITERIA)}")
    unknown = [s for s in scenes if s not in SCENES]
    if unknown:
        raise FFRFError(f"--scene {unknown[0]!r}: expected one of {', '.join(SCENES)}")
    if not (math.isfinite(tolerance) and tolerance > 0):
        raise FFRFError(f"--tolerance {tolerance}: expected a positive number")
    if integrator not in INTEGRATORS:
        raise FFRFError(f"--integrator {integrator!r}: expected one of {', '.join(INTEGRATORS)}")
    if integrator in FIXED and step is None:
        raise FFRFError(f"--integrator {integrator}: needs --step")
    if not (math.isfinite(rtol) and 0 < rtol < 1):
        raise FFRFError(f"--rtol {rtol}: expected a number between 0 and 1")
    if not 1 <= repeats <= 100:
        raise FFRFError(f"--repeat {repeats}: expected 1 to 100")
    if output is not None and output.exists() and not output.is_dir():
        raise FFRFError(f"{output}: expected a directory for the figures")
