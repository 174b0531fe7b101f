"""The reference of a scene and its self-check, taken at the price it is worth (theory section 10,
docs/simulate.md).

The reference is the full set at REF_RTOL, integrated by the
exponential scheme (sim.lawson). Its error must stay below
SELF_CHECK times the tolerance, else the scene gives no verdict (an
unconverged reference cannot tell a set's error from its own). The full
set is also run as a term set, at verify's (looser) tolerance: the
difference of the two runs estimates that run's error, and bounds the
reference's own (an adaptive run at a 100x tighter tolerance errs less:
tolerance proportionality). Where that estimate is already within
SELF_CHECK x tolerance by the criterion, the reference has shown its
convergence and no more is run; elsewhere (chaotic motion, amplitudes
far outside small deformations, an explicit run past its stability
limit) the reference is checked by self-convergence against a run at
REF_RTOL / 100.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..amplitudes import SMALL_DEFORMATION
from ..analysis import Analysis
from ..sim.integrate import Run
from .measures import errors, worst

REF_RTOL = 1e-10
SELF_CHECK = 0.1  # the reference's self-convergence error must stay below this share of the tolerance


@dataclass(frozen=True)
class Reference:
    run: Run
    self_error: dict      # its error estimate: against the full set's run, or against the run at REF_RTOL / 100
    wall_s: float
    self_check_nfev: int  # right-hand sides of the run at REF_RTOL / 100 (0: not run)
    self_checked: bool = False  # whether that run was taken (``needs_tight``)


def scene_errors(a: Analysis, run: Run, ref: Run) -> dict:
    """The errors of theory section 10 with the floors of the analysis (q_max, sigma_allow)."""
    return errors(run, ref, a.body.sigma_max, a.amplitudes.q_max, a.amplitudes.sigma_allow)


def estimated(a: Analysis, ref: Reference, full: Run | None) -> Reference:
    """``ref`` with the difference to the full set's run ``full`` (verify's tolerance) as its error estimate; an
    infinite one without that run or where it failed."""
    if full is None or full.failed:
        return replace(ref, self_error={"w": np.inf})
    return replace(ref, self_error=scene_errors(a, full, ref.run))


def needs_tight(ref: Reference, tolerance: float, criterion: str) -> bool:
    """Whether the run at REF_RTOL / 100 is needed: the estimate does not show convergence within SELF_CHECK x
    tolerance."""
    return not worst(ref.self_error, criterion) <= SELF_CHECK * tolerance


def self_checked(a: Analysis, ref: Reference, tight: Run) -> Reference:
    """``ref`` with its self-convergence error against ``tight`` (the run at REF_RTOL / 100)."""
    return replace(ref, self_error=scene_errors(a, ref.run, tight), self_check_nfev=tight.nfev, self_checked=True)


def self_check(a: Analysis, ref: Reference, tolerance: float, criterion: str) -> str | None:
    """Why a scene gives no verdict: its reference's error by ``criterion`` above SELF_CHECK x tolerance (theory 10:
    far below the smallest error that matters); None when it converged."""
    e = worst(ref.self_error, criterion)
    limit = SELF_CHECK * tolerance
    if e <= limit:
        return None
    return (f"reference did not self-converge: difference {e:.3g} between rtol {REF_RTOL:g} and {REF_RTOL / 100:g} "
            f"> tolerance/{1 / SELF_CHECK:g} = {limit:.3g}; likely chaotic motion or an amplitude outside small "
            f"deformations{_deflection_note(a)}")


def _deflection_note(a: Analysis) -> str:
    """The largest modal deflection ratio at q_max (theory 6), when the body has nodal modes."""
    r = a.amplitudes.deflection_ratio
    if r is None:
        return ""
    p = int(np.argmax(r))
    side = "above" if r[p] > SMALL_DEFORMATION else "within"
    return (f" (at q_max mode {p + 1} deflects {r[p]:.2g} of the body's largest dimension, {side} small deformations, "
            f"{SMALL_DEFORMATION:g})")
