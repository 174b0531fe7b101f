"""Largest modal coordinates q_max,p (theory section 6, G section 5.2)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .body import FlexibleBody
from .errors import FFRFError
from .situation import AmplitudeOptions
from .units import TMM, factor

# Largest nodal deflection at q_max over the largest body dimension above which analyze warns (theory 6). The FFRF
# keeps the modal kinematics linear (u = S q, and the inertia invariants to second order in q), which holds for
# small deformations only: the paper asks for deflections one to two orders of magnitude below the body's size,
# and Adams checks modal deflections against a characteristic length. 5 % is the lenient end of that (1/20).
SMALL_DEFORMATION = 0.05
FLOOR = 0.1  # of q_max and sigma_allow: a difference below it counts against the floor, not in full (theory 10)
MAX_DEFLECTION = 1e3  # of the body's largest dimension: given amplitudes beyond are refused


@dataclass(frozen=True)
class Amplitudes:
    """q_max per mode, the criterion that governs each, and the deflection measures."""

    q_max: np.ndarray
    governs: tuple[str, ...]
    q_cap: float                 # in body units
    sigma_allow: float           # in body stress units
    stress_utilisation: np.ndarray | None  # sigma_p q_max,p / sigma_allow
    deflection_ratio: np.ndarray | None    # largest nodal deflection at q_max,p / largest dimension
    deflection_bounds: tuple[float, float]  # averaged modal deflection bounds 1/sqrt(3m), 1/sqrt(m) (G20-G22)
    warnings: tuple[str, ...] = field(default=())


def _mode1(body: FlexibleBody, opts: AmplitudeOptions, q_cap: float, sigma_allow: float,
           deflection: np.ndarray | None) -> tuple[float, str, list[str]]:
    """q_max,1 as the smallest of the cap, the stress and the deflection criteria."""
    candidates = {"cap": q_cap}
    warnings = []
    if body.sigma_max is not None and body.sigma_max[0] > 0:
        candidates["stress"] = sigma_allow / body.sigma_max[0]
    else:
        warnings.append("no modal stress data: q_max,1 is not limited by stress; "
                        "it comes from q_cap" + (" and the deflection cap" if opts.deflection_cap else ""))
    if opts.deflection_cap is not None:
        if deflection is None:
            warnings.append("deflection cap given but the body has no nodal modes: cap not applied")
        else:
            candidates["deflection"] = opts.deflection_cap * body.largest_dimension() / deflection[0]
    name = min(candidates, key=candidates.get)
    return candidates[name], name, warnings


def _bound(opts: AmplitudeOptions, criterion: str) -> tuple[str, str]:
    """What bounded q_max (the ``governs`` of mode 1) and the options that lower it."""
    if criterion == "user":
        return "q_max was given per mode (--q-max)", "smaller --q-max values"
    if criterion == "deflection":
        return f"q_max,1 was bounded by the deflection cap {opts.deflection_cap:g}", "a smaller --deflection-cap"
    bound = (f"the q_cap of {opts.q_cap:g} t-mm units" if criterion == "cap"
             else f"the stress (sigma_allow {opts.sigma_allow:g} N/mm^2 / sigma_1)")
    return (f"q_max,1 was bounded by {bound}",
            f"--deflection-cap {SMALL_DEFORMATION:g} (bounds q_max,1 by the deflection), or a smaller --q-cap or "
            "--sigma-allow")


def small_deformation_warnings(ratio: np.ndarray | None, governs: tuple[str, ...], opts: AmplitudeOptions) -> list[str]:
    """A warning when a mode at q_max deflects more than SMALL_DEFORMATION of the body's size (theory 6)."""
    if ratio is None or ratio.max() <= SMALL_DEFORMATION:
        return []
    p = int(np.argmax(ratio))
    bound, fix = _bound(opts, governs[0])
    return [f"large deformation: at q_max mode {p + 1} deflects {ratio[p]:.3g} of the body's largest dimension, "
            f"above {SMALL_DEFORMATION:g} (the FFRF's linear modal kinematics need small deformations); {bound}; "
            f"fix: {fix}"]


def check_size(body: FlexibleBody, q: np.ndarray, option: str) -> None:
    """Given amplitudes deflect the body at most MAX_DEFLECTION times its size (theory 6; beyond, the numbers
    overflow long before they mean anything): the mesh's deflection, else the rms deflection of a
    mass-normalised mode, ``q / sqrt(m)``."""
    nodal = body.nodal_summary()
    deflection = nodal.max_deflection if nodal is not None else 1 / np.sqrt(body.mass)
    with np.errstate(over="ignore"):  # an overflow is a ratio of inf, refused below
        ratio = deflection * np.abs(np.asarray(q, float)) / body.largest_dimension()
    p = int(np.argmax(np.where(np.isnan(ratio), np.inf, ratio)))
    if not ratio[p] <= MAX_DEFLECTION:
        raise FFRFError(f"{option}: mode {p + 1} at {q[p]:.3g} deflects the body by {ratio[p]:.3g} times its largest "
                        f"dimension; expected at most {MAX_DEFLECTION:g} (the FFRF needs small deformations)")


def q_max(body: FlexibleBody, opts: AmplitudeOptions = AmplitudeOptions()) -> Amplitudes:
    """The paper's procedure: q_max,1 = min(q_cap, sigma_allow / sigma_1), q_max,p = q_max,1 lambda_1 / lambda_p."""
    q_cap = opts.q_cap * factor(TMM, body.units, "q")
    sigma_allow = opts.sigma_allow * factor(TMM, body.units, "stress")
    nodal = body.nodal_summary()
    deflection = None if nodal is None else nodal.max_deflection
    if opts.q_max is not None:
        q = np.asarray(opts.q_max, float)
        if q.shape != (body.nf,) or not np.all(np.isfinite(q)) or np.any(q < 0):
            raise FFRFError(f"q_max: expected {body.nf} non-negative numbers (one per mode), got {len(q)}")
        check_size(body, q, "--q-max")
        governs = ("user",) * body.nf
        warnings: list[str] = []
    else:
        q1, name, warnings = _mode1(body, opts, q_cap, sigma_allow, deflection)
        q = q1 * body.eigenvalues[0] / body.eigenvalues
        governs = (name,) + (f"scaled ({name})",) * (body.nf - 1)  # lambda_1/lambda_p x q_max,1
    utilisation = None if body.sigma_max is None else body.sigma_max * q / sigma_allow
    ratio = None if deflection is None else deflection * q / body.largest_dimension()
    bounds = (1 / np.sqrt(3 * body.mass), 1 / np.sqrt(body.mass))
    warnings += small_deformation_warnings(ratio, governs, opts)
    return Amplitudes(q, governs, q_cap, sigma_allow, utilisation, ratio, bounds, tuple(warnings))
