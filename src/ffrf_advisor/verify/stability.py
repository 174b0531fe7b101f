"""Stability where methods fail: explicit step limits, the softening divergence, drift, implicit steps (theory 9, 10).

Each study returns the number measured by simulation beside the number
predicted by theory, so that a figure or a test can hold one against the
other.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..analysis import Analysis
from ..sim.integrate import Rhs, integrate, rk4_limit
from ..sim.loads import LoadProgram, Loads
from ..sim.linearise import linearise, static_deflection
from ..sim.model import build_model, initial_state
from ..sim.output import summary
from ..terms import FULL, LEVEL_SETS

BISECTIONS = 10  # 3e-4 of the bracket: far below the 5 % the onset is checked to
GROWTH = 1e3  # a perturbation that grows by this factor means the run is unstable


@dataclass(frozen=True)
class Limit:
    measured: float
    predicted: float

    @property
    def ratio(self) -> float:
        return self.measured / self.predicted


def rk4_boundary(mu: complex) -> float:
    """Largest h with |R(h mu)| <= 1 for RK4's R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24 (bisection along the ray)."""
    R = lambda z: abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24)  # noqa: E731
    lo, hi = 0.0, 4.0 / abs(mu)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if R(mid * mu) <= 1 + 1e-12 else (lo, mid)
    return lo


def _bisect(stable, lo: float, hi: float, times: int = BISECTIONS) -> float:
    for _ in range(times):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo


def rk4_step_limit(a: Analysis, speed: float = 0.0, axis: int = 0) -> Limit:
    """Largest stable RK4 step by bisection, free spin at ``speed`` about ``axis`` with the highest mode kicked,
    against the prediction from the eigenvalues of the linearisation there (2 sqrt 2 / Omega_max at rest)."""
    model = build_model(a.body, FULL)
    lin = linearise(model, np.eye(3)[axis], speed)
    oscillating = lin.eigenvalues[np.abs(lin.eigenvalues) > 1e-9 * np.abs(lin.eigenvalues).max()]
    predicted = min(rk4_boundary(mu) for mu in oscillating)
    kick = np.zeros(a.body.nf)
    kick[-1] = 1e-3 * float(a.amplitudes.q_max[-1]) or 1e-6
    y0 = initial_state(model, speed * np.eye(3)[axis], lin.q + kick)

    def stable(h):
        run = integrate(model, y0, 400 * h, "rk4", h, output_step=400 * h)
        return not run.failed and np.abs(run.y[-1, 7:7 + a.body.nf] - lin.q).max() <= 2 * np.abs(kick).max()

    return Limit(_bisect(stable, 0.3 * predicted, 3.0 * predicted), predicted)


def euler_growth(a: Analysis, step_fraction: float = 0.1, steps: int = 50) -> Limit:
    """Explicit Euler on the highest mode at rest: measured growth per step against sqrt(1 + (h Omega)^2) > 1."""
    model = build_model(a.body, LEVEL_SETS["I"])
    om = float(np.sqrt(np.abs(a.body.eigenvalues).max()))
    h = step_fraction * rk4_limit(a.body.eigenvalues)
    f = Rhs(model)
    y = initial_state(model, (0, 0, 0), np.eye(a.body.nf)[-1])
    energy0 = 0.5 * om**2
    for _ in range(steps):
        y = y + h * f(0.0, y)
    q, qd = y[7 + a.body.nf - 1], y[7 + 2 * a.body.nf - 1]
    growth = np.sqrt((0.5 * qd**2 + 0.5 * om**2 * q**2) / energy0) ** (1 / steps)
    return Limit(float(growth), float(np.sqrt(1 + (h * om) ** 2)))


@dataclass(frozen=True)
class Onset:
    """Speed at which prescribed steady spin turns unstable (by simulation), s_crit, and the set without cf2."""

    axis: int             # 1-based principal axis
    measured: float
    s_crit: float
    bounded_without_cf2: bool
    bounded_with_geo_stiff: bool | None = None  # {gyro0, cf1, cf2, geo_stiff} at 1.5 s_crit; None without G


def _grows(a: Analysis, terms, axis: int, s: float, periods: float = 10.0) -> bool:
    """Steady prescribed spin s: does a small modal kick around the static deflection grow by GROWTH?"""
    model = build_model(a.body, terms)
    w = s * np.eye(3)[axis]
    q_s = static_deflection(model, w)
    kick = 1e-6 * max(float(np.abs(a.amplitudes.q_max).max()), 1e-12) * np.ones(a.body.nf)
    T = periods / float(a.body.frequencies_hz[0])
    run = integrate(model, initial_state(model, w, q_s + kick), T, "dop853", rtol=1e-7, atol=1e-3 * np.abs(kick).max(),
                    output_step=T / 200, loads=Loads.of(LoadProgram(spin=w)))
    dev = np.abs(run.y[:, 7:7 + a.body.nf] - q_s).max()
    return run.failed or dev > GROWTH * np.abs(kick).max()


def divergence_onset(a: Analysis, axis: int | None = None) -> Onset | None:
    """Bisection on the prescribed spin speed where {gyro0, cf1, cf2} turns unstable, against s_crit (theory 9);
    whether {gyro0, cf1} stays bounded at 1.5 s_crit, and {gyro0, cf1, cf2, geo_stiff} when the body carries
    its geometric stiffness (the stiffened run). None when the body has no finite s_crit."""
    s_crit = a.significance.s_crit
    if s_crit is None or not np.isfinite(s_crit).any():
        return None
    k = int(np.argmin(s_crit)) if axis is None else axis
    sc = float(s_crit[k])
    with_cf2 = ("gyro0", "cf1", "cf2")
    measured = _bisect(lambda s: not _grows(a, with_cf2, k, s), 0.5 * sc, 1.7 * sc, times=7)  # to 1 %
    stiffened = None if a.body.geometric is None else not _grows(a, (*with_cf2, "geo_stiff"), k, 1.5 * sc)
    return Onset(k + 1, measured, sc, not _grows(a, ("gyro0", "cf1"), k, 1.5 * sc), stiffened)


def drift_against_step(a: Analysis, scene, steps_fraction=(0.8, 0.4, 0.2, 0.1)) -> dict:
    """Energy drift of the full set and of level II in a scene against the RK4 step: the full set's drift
    falls with the step (integrator error), level II's does not (its work balance is incomplete)."""
    from .runner import run_scene
    limit = rk4_limit(a.body.eigenvalues)
    out = {}
    for label, terms in (("IV (full)", FULL), ("II", LEVEL_SETS["II"])):
        model = build_model(a.body, terms, scene.damping)
        rows = []
        for f in steps_fraction:
            run = run_scene(model, scene, "rk4", f * limit)
            s = summary(model, run, "")
            rows.append({"step": float(run.step), "energy_drift": s["energy_drift"], "H_drift": s["H_drift"]})
        out[label] = rows
    return out


@dataclass(frozen=True)
class ImplicitRun:
    step: float           # body time units
    step_over_limit: float
    bounded: bool         # the highest mode, far beyond the explicit limit, keeps its amplitude
    phase_error: float    # measured max |q1 - cos(Omega_1 t)| of the first mode
    predicted: float      # 2 |sin(dphi / 2)|, dphi = (Omega_1 - (2/h) atan(h Omega_1 / 2)) T


def implicit_stability(a: Analysis, factor: float = 5.0, periods: float = 3.0) -> ImplicitRun:
    """Implicit midpoint at ``factor`` times the RK4 limit at rest, first and highest mode kicked: the highest
    stays bounded, and the first mode's phase error matches the midpoint rule's frequency error."""
    model = build_model(a.body, LEVEL_SETS["I"])
    om = np.sqrt(np.abs(a.body.eigenvalues))
    h = factor * rk4_limit(a.body.eigenvalues)
    n = max(1, int(round(periods * 2 * np.pi / float(om[0]) / h)))
    q0 = np.zeros(a.body.nf)
    q0[[0, -1]] = 1.0
    run = integrate(model, initial_state(model, (0, 0, 0), q0), n * h, "midpoint", h, output_step=h)
    if run.failed:
        return ImplicitRun(h, factor, False, np.inf, np.nan)
    q1, q_top = run.y[:, 7], run.y[:, 7 + a.body.nf - 1]
    dphi = (om[0] - 2 / h * np.arctan(h * om[0] / 2)) * run.t[-1]
    return ImplicitRun(h, factor, bool(np.abs(q_top).max() <= 1 + 1e-6),
                       float(np.abs(q1 - np.cos(om[0] * run.t)).max()),
                       float(2 * abs(np.sin(min(abs(dphi), np.pi) / 2))))
