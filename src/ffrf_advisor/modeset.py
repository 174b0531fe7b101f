"""Which modes does a scene need? (theory section 12; the derivations in docs/modes.md)

The rigid motion loads the flexible body through inertia: six centrifugal
load cases ``f_kl`` (``w_k w_l``, order 11 22 33 12 13 23, as in theory 9
and 11) and three Euler cases ``dw_k/dt`` (M-orthogonal to the free modes at
q = 0: carried by the rigid motion, never by a mode). Per mode and load
case the share of the static strain energy

    p_k(f) = (phi_k^T f)^2 / lambda_k / (f^T K^+ f),    sum over all modes = 1,

and per kept set S the energy-norm error ``e_S(f) = sqrt(1 - sum_S p_k)``.
A scene excites up to ``f_exc`` (twice the spin frequency, the inverse of
its ramp or pulse time, ``--f-max``); modes up to ``band * f_exc`` answer
dynamically and are kept, an out-of-band mode is kept when it carries more
than the tolerance of a load case the scene applies, and the load cases
whose static error still exceeds the tolerance get their static
deflection ``K^+ f`` as a residual vector.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field, replace

import numpy as np

from .amplitudes import FLOOR, SMALL_DEFORMATION
from .analysis import Analysis
from .predict import MARGIN
from .body import CASES, SYM_PAIRS, FlexibleBody
from .errors import FFRFError
from .significance import f_cf1
from .sim.cost import rhs_cost
from .sim.model import build_model
from .units import TIME

EULER = ("dw1/dt", "dw2/dt", "dw3/dt")  # no load on free modes at q = 0 (theory 12)
BAND = 2.0        # modes up to BAND * f_exc respond dynamically (theory 12: the literature's 1.5-2)
SAME_FREQUENCY = 1e-6  # modes whose frequencies agree this closely (relative) span one eigenspace as far as the
# data tell: FE eigensolvers resolve eigenvalues to 1e-8..1e-12 (the zoo's pairs: 1e-10..1e-12), single precision
# to 1e-7; a mesh's asymmetry splits a pair by more and fixes its orientation
INERTIAL_SCENES = ("spin-up", "torque-pulse", "minor-axis")  # scenes only the rigid motion drives
ANALYZE_SCENES = ("spin-up", "torque-pulse")  # analyze's summary line: bounded from the invariants cache alone


def coefficients(w: np.ndarray) -> np.ndarray:
    """(6,): the weights of the six load cases in the centrifugal load of spin w, ``sum_j c_j f_j``."""
    w = np.asarray(w, float)
    return np.array([w[k] * w[l] * (1.0 if k == l else 2.0) for k, l in SYM_PAIRS])


def euler_loads(body: FlexibleBody) -> np.ndarray:
    """(nf, 3): ``phi_k^T f`` of the Euler cases ``f = -M (e_j x x)`` per unit ``dw_j/dt`` (and ``-J e_j`` on
    nodal rotations, theory 3b): ``-(sum m x~ phi_k)_j``, minus the mean-axis residual, zero for free-surface
    modes in their frame (theory 12: an angular acceleration loads no mode at q = 0)."""
    return -body.integrals.mean_axis_residual().T


def modal_loads_from_invariants(body: FlexibleBody) -> np.ndarray:
    """(nf, 6): ``phi_k^T f_j`` per unit spin^2 from the invariants alone: the cf1 force ``[w I] 0.5 W1^T w``
    (theory 5) is quadratic in w, its six coefficients follow by polarisation."""
    e = np.eye(3)
    diag = [f_cf1(body, e[k]) for k in range(3)]
    cross = [(f_cf1(body, e[k] + e[l]) - diag[k] - diag[l]) / 2 for k, l in SYM_PAIRS[3:]]
    return np.column_stack(diag + cross)


@dataclass(frozen=True)
class InertiaLoads:
    """The six centrifugal load cases of a body at unit spin: modal projections P (nf, 6) and, where known,
    the compliances ``C = F^T K^+ F`` (6, 6; NaN where unknown), the static deflections U (3n, 6) with their
    mass products ``U^T M U``, the nodal von Mises stress of each U (n, 6) and its peak ``sigma`` (6,; NaN
    where unknown); ``source`` says where they came from."""

    P: np.ndarray
    C: np.ndarray
    source: str
    U: np.ndarray | None = None
    UMU: np.ndarray | None = None
    stress: np.ndarray | None = None
    sigma: np.ndarray = field(default_factory=lambda: np.full(6, np.nan))  # peak von Mises per unit spin^2

    @property
    def compliance(self) -> np.ndarray:
        """(6,) ``f_j^T K^+ f_j``."""
        return np.diag(self.C)

    @property
    def bounded(self) -> np.ndarray:
        """(6,) whether the static error of a case can be bounded (its compliance is known)."""
        return np.isfinite(self.compliance) & (self.compliance > 0)


def inertia_loads(body: FlexibleBody) -> InertiaLoads:
    """From nodal FE data with K (or the material to assemble it): exact; else from the invariants, with the
    principal compliances the body file caches (theory 11) and the others unknown."""
    fe = body.fe
    if fe is None or (fe.K is None and fe.material is None) or fe.rotary is not None:
        C, sigma = np.full((6, 6), np.nan), np.full(6, np.nan)
        if body.static_centrifugal is not None:
            C[:3, :3][np.diag_indices(3)] = body.static_centrifugal.compliance
            sigma[:3] = body.static_centrifugal.sigma
        return InertiaLoads(modal_loads_from_invariants(body), C,
                            "invariants (W1); compliances of the principal cases from the file's cache"
                            if body.static_centrifugal is not None else "invariants (W1): no compliance, "
                            "the static error cannot be bounded: the frequency band decides alone", sigma=sigma)
    from .centrifugal import centrifugal_loads, static_deflections
    from .fe.assembly import full_mass, stiffness_matrix
    from .fe.stress import modal_von_mises
    X = fe.mesh.points
    K = fe.K if fe.K is not None else stiffness_matrix(fe.mesh, fe.material)
    F = centrifugal_loads(X, fe.Ms)
    U = static_deflections(X, fe.Ms, K, F)
    n = len(X)
    P = fe.Phi.reshape(3 * n, body.nf).T @ F
    stress = None if fe.material is None else modal_von_mises(fe.mesh, fe.material, U.reshape(n, 3, -1))
    C = F.T @ U
    return InertiaLoads(P, (C + C.T) / 2, "FE nodal sums (K^+ f by one factorisation)", U,
                        U.T @ (full_mass(fe.Ms) @ U), stress,
                        np.full(6, np.nan) if stress is None else stress.max(axis=0))


def participation(loads: InertiaLoads, eigenvalues: np.ndarray) -> np.ndarray:
    """(nf, 6): ``p_k(f_j)``, each mode's share of case j's static strain energy (NaN where unbounded)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return loads.P**2 / np.asarray(eigenvalues)[:, None] / np.where(loads.bounded, loads.compliance, np.nan)


@dataclass(frozen=True)
class SceneDemand:
    """What a scene asks of the modes: the load cases it applies (indices into CASES), the spins it passes
    through and its nominal spin [rad per body time unit], the highest frequency it excites [Hz] and what sets
    it, the modes it starts (vibrating scenes)."""

    label: str
    cases: tuple[int, ...]
    directions: tuple[tuple[float, float, float], ...]
    speed: float
    f_exc: float
    excited_by: str
    started: tuple[int, ...] = ()
    rise_s: float = 0.0  # the spin rises over this time [s] (spin_profile; 0: the scene starts at full spin)
    prescribed: bool = False  # the rotation is prescribed (spin-up): it cannot wander
    weights: tuple[float, ...] = ()  # what its relative errors count for along each spin (_weight)


def scene_demands(a: Analysis, names, tolerance: float, f_max: float | None = None) -> list[SceneDemand]:
    """The demands of the named verification scenes (verify.scenes, theory 10) on ``a``'s body: a case
    applies when its weight is above ``tolerance`` of the largest (a wobble of 1 % brings the cross case
    at 0.02); the minor-axis scene's wobble turns about its spin axis (both cross cases) and it ends about the
    major axis, whose case applies too."""
    from .verify.scenes import SceneOptions, make_scenes, stable_axes
    per_s = float(TIME[a.body.units.time])
    out = []
    for sc in make_scenes(names, a, SceneOptions()):
        w = sc.omega0 if np.any(sc.omega0) else sc.speed * np.eye(3)[sc.axis]
        directions = [w]
        if sc.name == "minor-axis":  # its wobble turns about the spin axis; it ends about the major axis with the
            major = stable_axes(a)[0]   # same angular momentum
            k = sc.axis
            directions.append(w[k] * np.eye(3)[k] + np.linalg.norm(np.delete(w, k)) * np.eye(3)[(k + 2) % 3])
            directions.append(np.eye(3)[major] * np.linalg.norm(a.body.I0 @ w) / a.body.I0[major, major])
        cases = sorted({j for d in directions for j, c in enumerate(np.abs(coefficients(d)))
                        if c > tolerance * np.abs(coefficients(d)).max()})
        pieces = {"2x spin": 2 * sc.speed / (2 * np.pi) * per_s}
        program = sc.loads.program
        if program is not None and program.spin is not None and program.ramp > 0:
            pieces["1 / ramp"] = per_s / program.ramp
        if program is not None and np.isfinite(program.pulse):
            pieces["1 / pulse"] = per_s / program.pulse
        if f_max is not None:
            pieces["--f-max"] = f_max
        by = max(pieces, key=pieces.get)
        started = tuple(int(p) for p in np.flatnonzero(np.asarray(sc.q0) != 0) if sc.vibrating)
        rise = 0.0 if program is None else (program.ramp if program.spin is not None else
                                            program.pulse if np.isfinite(program.pulse) else 0.0)
        out.append(SceneDemand(sc.label, tuple(cases), tuple(tuple(map(float, d)) for d in directions),
                               float(sc.speed), float(pieces[by]), by, started, rise / per_s, sc.prescribed))
    return out


@dataclass(frozen=True)
class ModeChoice:
    """One mode's decision: its largest share of an applied case's static energy and of a case's peak stress
    (NaN where unknown), kept or dropped, the rule that kept it (``rule``: "started", "band", "share", "spun"
    or "partner"; "" when dropped) and the reason in words."""

    mode: int
    f_hz: float
    participation: float
    stress_share: float
    rule: str
    reason: str

    @property
    def keep(self) -> bool:
        return bool(self.rule)

    @property
    def decision(self) -> str:
        """'keep (started)', 'keep (band)', 'keep (share)', 'keep (spun)', 'keep (partner)' or 'drop'."""
        return f"keep ({self.rule})" if self.keep else "drop"


@dataclass(frozen=True)
class CaseError:
    """The kept modes' static error of one applied load case: energy norm and peak von Mises stress (None
    where they cannot be bounded), the weight they count with (``weight``) and whether its static deflection
    joins as a residual vector (then both errors are zero: the static response lies in the basis)."""

    case: str
    energy: float | None
    stress: float | None
    residual: bool
    weight: float = 1.0


@dataclass(frozen=True)
class ModeAdvice:
    """The mode set a set of scenes needs (theory 12): kept modes (0-based), the load cases whose static
    deflections join as residual vectors, per-mode and per-case evidence, the predicted response error of each
    scene without and with the residual vectors, and the cost against all modes."""

    nf: int
    kept: tuple[int, ...]
    residual_cases: tuple[int, ...]
    modes: list[ModeChoice]
    cases: list[CaseError]
    scenes: list[SceneDemand]
    predicted: list[tuple[float | None, float | None]]
    tolerance: float
    band: float
    terms: tuple[str, ...]
    rhs_ratio: float
    step_ratio: float | None
    step_ratio_modes: float
    source: str
    notes: list[str] = field(default_factory=list)
    euler_share: float = 0.0  # largest modal Euler load over the largest centrifugal one (theory 12: 0 at q = 0)

    @property
    def size(self) -> int:
        """Basis vectors of the advised set: kept modes plus residual vectors."""
        return len(self.kept) + len(self.residual_cases)

    def worst(self, residual: bool) -> float | None:
        """The largest predicted scene error with (``residual``) or without the residual vectors; None when a
        scene's error cannot be bounded (no compliance), NaN when a scene spins above a critical speed."""
        values = [p[1] if residual else p[0] for p in self.predicted]
        if any(v is None for v in values):
            return None
        return np.nan if any(np.isnan(values)) else max(values, default=0.0)

    def summary(self) -> str:
        """One line: what carries the scenes within the tolerance, how much cheaper, and the explicit step."""
        res = len(self.residual_cases)
        worst = self.worst(bool(res))
        vectors = f" and {res} residual vector{'s' * (res != 1)}" if res else ""
        if worst is None:
            verdict = "carry the scenes (error not bounded: no compliance; the frequency band decided)"
        elif np.isnan(worst):
            verdict = "cannot be judged for every scene (see the notes)"
        elif worst <= self.tolerance:
            verdict = f"carry the scenes within {self.tolerance:g} (predicted {worst:.2g})"
        else:
            scene = self.scenes[[p[1] if res else p[0] for p in self.predicted].index(worst)].label
            verdict = f"leave a predicted error {worst:.2g} > {self.tolerance:g} in {scene}: verify by simulation"
        text = (f"{len(self.kept)} of {self.nf} modes{vectors} {verdict}; right-hand side cost x"
                f"{1 / self.rhs_ratio:.3g} of all modes'; explicit step x{self.step_ratio_modes:.3g}")
        if res:
            text += (" with a quasi-static correction, " + (f"x{self.step_ratio:.3g}" if self.step_ratio is not None
                                                             else "unknown without FE data") +
                     " with the residual vectors")
        return text


RISE_STEPS = 2000  # segments of the rise in response_factors (the recursion is exact for each segment)


def response_factors(f_hz, rise_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(total, excess) per mode: the largest ``|x|`` and dynamic part ``|x - g|`` of ``x'' + Omega^2 x =
    Omega^2 g(t)``, x(0) = x'(0) = 0, for the load shape of a spin rising as ``spin_profile`` over ``rise_s``,
    ``g = (w / W)^2`` (a step at 0), then held: a mode's response over its static response at full spin
    (docs/modes.md)."""
    om = 2 * np.pi * np.atleast_1d(np.asarray(f_hz, float))
    if rise_s <= 0:
        return np.full_like(om, 2.0), np.ones_like(om)
    return _cached_peaks(tuple(om.tolist()), rise_s, "spin")


def euler_factors(f_hz, rise_s: float) -> tuple[np.ndarray, float]:
    """(total per mode, A): the largest ``|x|`` of ``x'' + Omega^2 x = Omega^2 h(t)``, x(0) = x'(0) = 0, for the
    shape ``h = a (w / W)^2 / A`` of the load the spin's rise puts on the deflection it causes (Euler
    ``-C(q)^T w'`` and Coriolis ``-2 C(q')^T w`` with q following ``(w / W)^2``; docs/modes.md), ``a = w' /
    W``, A its largest value [1/s]; (0, 0) without a rise."""
    om = 2 * np.pi * np.atleast_1d(np.asarray(f_hz, float))
    if rise_s <= 0:
        return np.zeros_like(om), 0.0
    return _cached_peaks(tuple(om.tolist()), rise_s, "euler")[0], float(_euler_load(rise_s).max())


def _euler_load(rise_s: float) -> np.ndarray:
    """``(w / W)^2 w' / W`` at the points of the rise (``euler_factors``' load before scaling) [1/s]."""
    _, w, a = _rise(rise_s)
    return a * w**2


@functools.lru_cache(maxsize=64)
def _cached_peaks(om: tuple[float, ...], rise_s: float, load: str) -> tuple[np.ndarray, np.ndarray]:
    """``_peaks`` of the spin's rise (``load`` "spin": ``(w / W)^2``; "euler": ``_euler_load`` over its maximum)
    for the circular frequencies ``om``, kept: the predictions ask the same scene for every term set."""
    t, w, _ = _rise(rise_s)
    h = w**2 if load == "spin" else _euler_load(rise_s)
    out = _peaks(np.array(om), t, h / h.max())  # (w / W)^2 ends at 1: its maximum
    for x in out:
        x.setflags(write=False)  # shared by the cache
    return out


@functools.lru_cache(maxsize=16)
def _rise(rise_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t, w / W, w' / W) at RISE_STEPS + 1 points of a rise (sim.loads.spin_profile)."""
    from .sim.loads import spin_profile
    t = np.linspace(0.0, rise_s, RISE_STEPS + 1)
    w, a = spin_profile(1.0, rise_s)(t)
    for x in (t, w, a):
        x.setflags(write=False)  # shared by the cache
    return t, w, a


def _peaks(om: np.ndarray, t: np.ndarray, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(largest |x|, largest |x - g|) of ``x'' + om^2 x = om^2 g(t)`` from rest, g linear between the equally
    spaced points t and held at g[-1] after them (a profile's curvature between RISE_STEPS points leaves about
    1e-6 of the response). ``z = y + i y' / om`` with ``y = x - g`` turns by ``exp(-i om dt)`` over each
    segment and jumps by ``-i (change of slope) / om`` at each point, so after the jump at point m

        z_m = exp(-i om dt m) sum_{k <= m} exp(i om dt k) J_k,    J_0 = -g_0 - i slope_0 / om

    (one cumulative sum for every mode at once; exp(i om dt m) as the cumulative product of exp(i om dt), its
    rounding m eps < 1e-12 at RISE_STEPS, and its inverse as its conjugate). |x| is taken at the points (within
    (om dt)^2 / 8 of its peak), |x - g| as the amplitude |z|, which bounds it (held, y keeps that amplitude)."""
    slope = np.append(np.diff(g) / np.diff(t), 0.0)  # held after the last point
    turn = np.empty((len(t), len(om)), complex)
    turn[0] = 1.0
    turn[1:] = np.exp(1j * (t[1] - t[0]) * om)
    np.cumprod(turn, axis=0, out=turn)
    z = np.empty(turn.shape, complex)  # J_k exp(i om dt k), summed, turned back
    z[0] = -g[0] - 1j * slope[0] / om
    np.multiply(-1j * np.diff(slope)[:, None], 1 / om, out=z[1:])
    z *= turn
    np.cumsum(z, axis=0, out=z)
    z *= turn.conj()
    amplitude2 = z.real**2 + z.imag**2
    held = np.sqrt(amplitude2[-1])  # a free oscillation about g[-1] after the last point
    total = np.abs(g[1:, None] + z[1:].real).max(axis=0)
    return np.maximum(total, abs(g[-1]) + held), np.maximum(np.sqrt(amplitude2[:-1].max(axis=0)), held)


def advise_modes(a: Analysis, names=INERTIAL_SCENES, tolerance: float | None = None, f_max: float | None = None,
                 band: float = BAND, loads: InertiaLoads | None = None) -> ModeAdvice:
    """The advised mode set of ``a``'s body for the named scenes (theory 12)."""
    body, tol = a.body, tolerance if tolerance is not None else a.options.situation.tolerance
    loads = loads or inertia_loads(body)
    scenes = scene_demands(a, names, tol, f_max)
    p = participation(loads, body.eigenvalues)
    applied = sorted({j for s in scenes for j in s.cases})
    share = _stress_share(body, loads)
    modes = [_choice(k, body, scenes, p, share, applied, tol, band) for k in range(body.nf)]
    kept, notes = _with_partners(tuple(m.mode for m in modes if m.keep), modes, body.frequencies_hz), []
    floor = FLOOR * a.amplitudes.sigma_allow
    weight = {j: _weight(loads.sigma[j] * max(s.speed for s in scenes if j in s.cases) ** 2, floor)
              for j in applied}
    cases = [_case_error(j, kept, body, loads, p, tol, weight[j]) for j in applied]
    residual = tuple(j for j, c in zip(applied, cases) if c.residual)
    if not kept and not residual:
        kept = _with_partners((0,), modes, body.frequencies_hz)
        notes.append("no mode is needed within the tolerance; mode 1 kept so that the body has one")
        cases = [_case_error(j, kept, body, loads, p, tol, weight[j]) for j in applied]
    scenes = [replace(s, weights=tuple(_weight(_stress_at(loads, s.cases, w), floor) for w in s.directions))
              for s in scenes]
    top = float(body.frequencies_hz[-1])
    beyond = [band * s.f_exc > top for s in scenes]
    notes += [f"{s.label} excites up to {s.f_exc:.4g} Hz; its band ({band:g} x) ends above the file's last mode "
              f"({top:.4g} Hz): no prediction, compute more modes" for s, out in zip(scenes, beyond) if out]
    setting = _Setting.of(body, a.advice.terms)
    kept, predicted = _widened(kept, residual, modes, scenes, loads, setting, tol)
    close = [p[1] for p, out in zip(predicted, beyond) if not out and p[1] is not None and p[1] > tol / MARGIN]
    if close and loads.U is not None and len(residual) < len(CASES):
        missed = 1 - np.nansum(p[list(kept)], axis=0)  # each case's static energy share beyond the kept modes
        others = sorted(set(range(len(CASES))) - set(residual), key=lambda j: -missed[j])
        more = _independent(loads, body.eigenvalues, kept, residual, others)
        if len(more) > len(residual):
            notes.append(f"predicted error {max(close):.2g} within a factor {MARGIN:g} of the tolerance (the margin "
                         f"of the predictions, as for the terms): residual vectors of "
                         f"{', '.join(CASES[j] for j in sorted(set(more) - set(residual)))} too")
            residual = more
            kept, predicted = _widened(kept, residual, modes, scenes, loads, setting, tol)
    if loads.U is not None:
        residual = _independent(loads, body.eigenvalues, kept, (), residual)
    predicted = [(np.nan, np.nan) + p[2:] if out and p[0] is not None else p for p, out in zip(predicted, beyond)]
    notes += [f"{sc.label}: at {sc.speed / float(TIME[body.units.time]):.4g} rad/s the term set has no stable small "
              f"deflection along one of its spins (above a critical speed, a free spin that wanders, or a static "
              f"deflection beyond {SMALL_DEFORMATION:g} of the body's size): the prediction does not apply; verify "
              "by simulation" for sc, p, out in zip(scenes, predicted, beyond)
              if p[0] is not None and np.isnan(p[0]) and not out]
    terms = tuple(a.advice.terms)
    size = len(kept) + len(residual)
    return ModeAdvice(body.nf, kept, residual, modes, cases,
                      scenes, [p[:2] for p in predicted], tol, band, terms,
                      rhs_cost(terms, body.nf) / rhs_cost(terms, size), _step_ratio(body, kept, residual, loads),
                      _step_ratio(body, kept, (), loads), loads.source, notes,
                      float(np.abs(euler_loads(body)).max() / max(np.abs(loads.P).max(), 1e-300)))


def _widened(kept, residual, modes: list, scenes, loads: InertiaLoads, setting: "_Setting", tol: float):
    """(kept, predictions): while a scene's static error at its spin (with the dropped modes' response to the
    load its rise puts on the deflection, ``_rising``) stays above the tolerance in the advised basis, the
    dropped mode carrying most of it joins (the spin softens the body and couples the modes: docs/modes.md);
    ``modes`` is updated with the reason."""
    while True:
        predicted = [_predicted(s, kept, residual, loads, setting) for s in scenes]
        bad = [p for p in predicted if p[2] is not None and p[2] > tol]
        dropped = [k for k in range(setting.model.nf) if k not in kept]
        if not bad or not dropped:
            return kept, predicted
        worst = max(bad, key=lambda p: p[2])
        k = max(dropped, key=lambda k: worst[3][k])
        modes[k] = replace(modes[k], rule="spun", reason=f"keep: spun error {worst[2]:.2g} > {tol:g} "
                           "without it (the spin softens the body, its rise loads the deflection)")
        kept = _with_partners(tuple(sorted((*kept, k))), modes, setting.f_hz)


def _with_partners(kept: tuple, modes: list, f_hz) -> tuple:
    """``kept`` and every dropped mode of the same frequency as a kept one (to SAME_FREQUENCY), which joins as
    ``keep (partner)``: within a degenerate eigenspace the basis is the eigensolver's choice (a ring's cos/sin
    pair), so which of its modes a load meets depends on it, and the advice keeps the eigenspace whole;
    ``modes`` is updated with the reason."""
    f = np.asarray(f_hz, float)
    joined = []
    for k in kept:
        for j in np.flatnonzero(np.abs(f - f[k]) <= SAME_FREQUENCY * f[k]):
            if j not in kept and j not in joined:
                modes[j] = replace(modes[j], rule="partner", reason=f"keep: same frequency as mode {k + 1} "
                                   "(a degenerate pair: its basis is the eigensolver's choice)")
                joined.append(int(j))
    return tuple(sorted((*kept, *joined)))


def _stress_share(body: FlexibleBody, loads: InertiaLoads) -> np.ndarray:
    """(nf, 6): each mode's static von Mises stress at the peak node of case j over the exact peak, ``|q_k|
    sigma_k(node_j) / sigma_j``; NaN without nodal stresses."""
    nf = body.nf
    if loads.stress is None or body.fe is None or body.fe.stress_nodal is None:
        return np.full((nf, 6), np.nan)
    node = loads.stress.argmax(axis=0)
    peak = loads.stress.max(axis=0)
    q = loads.P / body.eigenvalues[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.abs(q) * body.fe.stress_nodal[node].T / peak


def _choice(k: int, body, scenes, p, share, applied, tol: float, band: float) -> ModeChoice:
    f = float(body.frequencies_hz[k])
    pk = max((p[k, j] for j in applied if np.isfinite(p[k, j])), default=np.nan)
    sk = max((share[k, j] for j in applied if np.isfinite(share[k, j])), default=np.nan)
    started = [s.label for s in scenes if k in s.started]
    inside = [s for s in scenes if f <= band * s.f_exc]
    if started:
        rule, reason = "started", f"keep: started by {started[0]}"
    elif inside:
        s = max(inside, key=lambda s: s.f_exc)
        rule, reason = "band", f"keep: in band ({f:.4g} <= {band:g} x {s.f_exc:.4g} Hz, {s.excited_by} of {s.label})"
    elif np.isfinite(pk) and pk > tol:
        rule, reason = "share", f"keep: static energy share {pk:.2g} > {tol:g} of an applied load case"
    else:
        rule, reason = "", ("drop: out of band, " + (f"static energy share {pk:.2g} <= {tol:g}"
                                                     if np.isfinite(pk) else "share unknown (no compliance)"))
    return ModeChoice(k, f, float(pk), float(sk), rule, reason)


DEPENDENT = 1e-6  # share of a residual vector's squared M-norm below which what it adds is no new direction


def _independent(loads: InertiaLoads, lam: np.ndarray, kept, chosen, candidates) -> tuple[int, ...]:
    """``chosen`` and those ``candidates`` (in their order) whose static deflection adds a direction to the kept
    modes and the residual vectors before it: the M-norm^2 of its part beyond them over its own above
    DEPENDENT (a nearly dependent vector only adds an ill-conditioned stiff pseudo-mode). The parts beyond the
    kept modes have the M-products ``U^T M U - Q^T Q``, ``Q = P_S / lambda_S`` (theory 12: ``phi^T M u =
    phi^T f / lambda``)."""
    ix = list(kept)
    Q = loads.P[ix] / lam[ix, None]
    G = loads.UMU - Q.T @ Q
    out = list(chosen)
    for j in candidates:
        new = G[j, j] - (G[j, out] @ np.linalg.solve(G[np.ix_(out, out)], G[out, j]) if out else 0.0)
        if new > DEPENDENT * loads.UMU[j, j]:
            out.append(j)
    return tuple(sorted(out))


def _weight(sigma: float, floor: float) -> float:
    """What a relative error counts for where the response's peak stress is ``sigma``: sigma over the larger
    of it and the floor (a tenth of sigma_allow, as verify's errors: amplitudes.FLOOR); 1 where the stress is
    unknown. A spin that barely stresses the body needs no residual vector for it (docs/modes.md)."""
    if not np.isfinite(sigma) or sigma <= 0:
        return 1.0
    return float(sigma / max(sigma, floor))


def _stress_at(loads: InertiaLoads, cases, w: np.ndarray) -> float:
    """A bound of the peak stress of the applied cases' load at spin w, ``sum_j |c_j(w)| sigma_j``."""
    ix = list(cases)
    return float(np.abs(coefficients(w))[ix] @ loads.sigma[ix])


def _case_error(j: int, kept, body, loads: InertiaLoads, p, tol: float, weight: float) -> CaseError:
    """The kept modes' static errors of case j; a residual vector where one, times the case's weight, exceeds
    the tolerance (FE data give it; the prediction needs only its modal part)."""
    ix = list(kept)
    energy = float(np.sqrt(max(0.0, 1.0 - p[ix, j].sum()))) if loads.bounded[j] else None
    stress = None
    if loads.stress is not None:  # FE data: the residual's stress
        from .fe.stress import modal_von_mises
        q = loads.P[ix, j] / body.eigenvalues[ix]
        n = body.fe.mesh.n_nodes
        rest = loads.U[:, j] - body.fe.Phi[:, :, ix].reshape(3 * n, len(ix)) @ q
        field = rest.reshape(n, 3, 1)
        stress = float(modal_von_mises(body.fe.mesh, body.fe.material, field).max() / loads.stress[:, j].max())
    worst = max((e for e in (energy, stress) if e is not None), default=None)
    return CaseError(CASES[j], energy, stress, worst is not None and worst * weight > tol, weight)


def _predicted(scene: SceneDemand, kept, residual, loads: InertiaLoads, setting: "_Setting") -> tuple:
    """(without, with residual vectors, the static part of the latter, the modes' share of that static error
    (nf,)): the largest predicted relative energy-norm errors of the scene's response over its spin directions
    (``_spun``); None when a needed compliance is unknown."""
    if not scene.cases:
        return 0.0, 0.0, 0.0, np.zeros(setting.model.nf)
    runs = [_spun(np.asarray(w), scene, kept, residual, loads, setting) for w in scene.directions]
    if any(r is None for r in runs):
        return None, None, None, np.zeros(setting.model.nf)
    runs = [(g * r[0], g * r[1], g * r[2], r[3]) for g, r in zip(scene.weights, runs)]
    worst = max(runs, key=lambda r: r[2])
    return max(r[0] for r in runs), max(r[1] for r in runs), worst[2], worst[3]


def _spun(w: np.ndarray, scene: SceneDemand, kept, residual, loads: InertiaLoads, setting: "_Setting"):
    """Predicted errors of the peak response at spin w (docs/modes.md): the static response of the term set at
    w over the file's modes, ``K_s q = f0`` (``Omega^2 - s^2 Kc + s^2 G``, sim.linearise), against its Galerkin
    solution in the kept modes (and in the kept modes plus the residual vectors' modal parts ``P_j / lambda``);
    without residual vectors each dropped component and the part beyond the file's modes are missed at their
    peak response to the scene's rise (``response_factors``); with them, which hold those static parts and
    answer at their own Rayleigh frequency like the reference's, a dropped mode errs by the difference of the
    two peaks (``_remainder_hz``)."""
    ix = list(scene.cases)
    c = coefficients(w)[ix]
    energy = _energy(loads, ix, c)
    if not np.isfinite(energy) or energy <= 0:
        return None
    model, f_hz = setting.model, setting.f_hz
    lam = model.eigenvalues
    static = setting.static_at(w, scene.prescribed)
    if static is None:
        return np.nan, np.nan, np.nan, np.zeros(model.nf)
    Ks, f0, q = static
    if setting.reach is not None and float(np.abs(q) @ setting.reach) > SMALL_DEFORMATION:
        return np.nan, np.nan, np.nan, np.zeros(model.nf)  # beyond small deformations: linear modes do not apply
    rest = _beyond(loads, ix, c, lam, energy)
    drop = np.ones(model.nf, bool)
    drop[list(kept)] = False
    peak = response_factors(f_hz, scene.rise_s)[0]
    beyond, held = (response_factors([f], scene.rise_s)[0][0]
                    for f in _remainder_hz(loads, ix, c, lam, f_hz, rest, drop))
    total = float(q @ (lam * q)) + rest
    rising = lam * (_rising(model, Ks, q, w, scene.rise_s, setting.seconds) * drop) ** 2  # dropped modes' part
    d = q - _galerkin(Ks, f0, np.eye(model.nf)[:, list(kept)])
    without = np.sqrt((np.sum(lam * (d * np.where(drop, peak, 1.0)) ** 2) + rest * beyond**2 + rising.sum()) / total)
    if not set(ix) & set(residual):
        return (float(without), float(without), float(np.sqrt((np.sum(lam * d**2) + rising.sum()) / total)),
                lam * d**2 + rising)
    basis = np.column_stack([np.eye(model.nf)[:, list(kept)], loads.P[:, list(residual)] / lam[:, None]])
    dB = q - _galerkin(Ks, f0, basis)
    moved = np.where(drop, peak - held, 0.0)  # a dropped mode's peak answered at the residual vector's frequency
    bare = np.where(np.isin(ix, residual), 0.0, c)  # the cases without a residual vector miss what lies beyond
    missed = _beyond(loads, ix, bare, lam, _energy(loads, ix, bare)) * beyond**2 if bare.any() else 0.0
    static = np.sum(lam * dB**2) + rising.sum()
    with_res = np.sqrt((static + np.sum(lam * (q * moved) ** 2) + missed) / total)
    return float(without), float(with_res), float(np.sqrt(static / total)), lam * dB**2 + rising


CORIOLIS = 4.0  # -2 C(q')^T w with q = q_s (w / W)^2 along a fixed axis: 4 (w / W)^2 w' C(q_s)^T e (docs/modes.md)


def _rising(model, Ks: np.ndarray, q: np.ndarray, w: np.ndarray, rise_s: float, seconds: float) -> np.ndarray:
    """Each mode's peak response to the load a rising spin puts on the deflection it causes (docs/modes.md):
    while w = W e rises over ``rise_s``, the deflection q_s (w / W)^2 takes the Euler load ``-C(q)^T w'``
    (term coupling) and the Coriolis load ``-2 C(q')^T w`` (cor_coupling), both ``-(w / W)^2 w' C(q_s)^T e``
    in shape (C = Qf^T W3, sim.equations.coupling_matrix), so each mode answers ``K_s^-1`` of their peak times
    its factor for that history (``euler_factors``); zero without a rise or those terms."""
    speed = float(np.linalg.norm(w))
    if rise_s <= 0 or speed == 0:
        return np.zeros(model.nf)
    D, A = euler_factors(model.eigenvalues**0.5 / (2 * np.pi * seconds), rise_s)
    peak = A * speed * seconds  # max (w / W)^2 |w'| in the body's units (A [1/s] x W)
    return D * np.linalg.solve(Ks, peak * rising_load(model, q, w / speed))


def rising_load(model, q: np.ndarray, e: np.ndarray) -> np.ndarray:
    """The modal load of a spin rising about the unit axis e on its deflection q_s = q (w / W)^2, per unit
    ``(w / W)^2 |w'|``: ``-(1 + 4) C(q)^T e`` with both terms, -C^T e with coupling alone, none without them
    (C = Qf^T W3: sim.equations.coupling_matrix; docs/modes.md)."""
    from .sim.equations import coupling_matrix
    factor = float(model.on("coupling")) + CORIOLIS * float(model.on("cor_coupling"))
    return -factor * coupling_matrix(model, q).T @ e


@dataclass(frozen=True)
class _Setting:
    """What the predictions need of the body: the term set's model, the frequencies [Hz] and each mode's
    largest nodal deflection over the largest dimension (None without nodal data)."""

    model: object
    f_hz: np.ndarray
    reach: np.ndarray | None
    seconds: float = 1.0  # per time unit of the body
    statics: dict = field(default_factory=dict, compare=False, repr=False)  # ``static_at`` per spin

    @classmethod
    def of(cls, body: FlexibleBody, terms) -> "_Setting":
        nodal = body.nodal_summary()
        reach = None if nodal is None else nodal.max_deflection / nodal.largest_dimension
        return cls(build_model(body, terms), body.frequencies_hz, reach, float(TIME[body.units.time]))

    def static_at(self, w: np.ndarray, prescribed: bool) -> tuple | None:
        """(K_s, f0, q) of the term set at spin w: its static stiffness, load and deflection (``K_s q = f0``,
        sim.linearise); None where the spin has no stable small deflection: K_s not positive definite, or a free
        spin unstable by the linearisation (theory 10: its axis then wanders and loads cases the scene's nominal
        spin does not; a prescribed spin cannot wander). Kept per spin: the widening asks again for each basis."""
        key = (*map(float, w), prescribed)
        if key not in self.statics:
            self.statics[key] = self._static(w, prescribed)
        return self.statics[key]

    def _static(self, w: np.ndarray, prescribed: bool) -> tuple | None:
        from .sim.linearise import _static_stiffness, unstable
        Ks, f0 = _static_stiffness(self.model, w)
        if np.linalg.eigvalsh((Ks + Ks.T) / 2).min() <= 0:
            return None
        q = np.linalg.solve(Ks, f0)
        s = float(np.linalg.norm(w))
        return None if not prescribed and unstable(self.model, w / s, s, q) else (Ks, f0, q)


def _energy(loads: InertiaLoads, ix, c: np.ndarray) -> float:
    """``f^T K^+ f`` of the load ``sum_j c_j f_j`` over the cases ``ix`` (NaN where a needed compliance is
    unknown; the cross compliances of cases with a zero weight are not needed)."""
    C = loads.C[np.ix_(ix, ix)]
    return float(c @ np.where(c[:, None] * c[None, :] == 0, 0.0, C) @ c)


def _beyond(loads: InertiaLoads, ix, c: np.ndarray, lam: np.ndarray, energy: float) -> float:
    """The static energy of that load beyond the file's modes, ``energy - sum_k (P_k c)^2 / lambda_k``."""
    return max(0.0, energy - float(np.sum((loads.P[:, ix] @ c) ** 2 / lam)))


def _remainder_hz(loads: InertiaLoads, ix, c: np.ndarray, lam: np.ndarray, f_hz: np.ndarray, rest: float,
                  drop: np.ndarray) -> tuple[float, float]:
    """(beyond, residual) [Hz]: the Rayleigh frequencies of the static part beyond the file's modes, ``rest /
    (u^T M u - sum_k (P_k c / lambda_k)^2)``, and of what a residual vector holds, that part plus the dropped
    modes' static parts (docs/modes.md); never below the last mode's; the last mode's where U is unknown."""
    top = float(f_hz[-1])
    if loads.UMU is None:
        return top, top
    Pc = loads.P[:, ix] @ c
    mass = float(c @ loads.UMU[np.ix_(ix, ix)] @ c - np.sum((Pc / lam) ** 2))
    per_hz = top / np.sqrt(lam[-1])  # Hz per sqrt(eigenvalue)
    rayleigh = lambda e, m: float(max(top, np.sqrt(e / m) * per_hz)) if m > 0 and e > 0 else top  # noqa: E731
    return (rayleigh(rest, mass),
            rayleigh(rest + np.sum(Pc[drop] ** 2 / lam[drop]), mass + np.sum((Pc[drop] / lam[drop]) ** 2)))


def _galerkin(K: np.ndarray, f: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``B (B^T K B)^-1 B^T f``: the solution of K q = f in the span of B's columns (zero for no column)."""
    if B.shape[1] == 0:
        return np.zeros(len(f))
    return B @ np.linalg.lstsq(B.T @ K @ B, B.T @ f, rcond=None)[0]


def _step_ratio(body, kept, residual, loads: InertiaLoads) -> float | None:
    """``Omega_max(all) / Omega_max(advised)``: the explicit step grows by this. With residual vectors the
    advised set's top frequency is the largest Ritz value of [Phi_S, U_R], from ``K U = F`` and ``phi^T M U =
    phi^T F / lambda`` (no stiffness matrix needed); None where U is unknown."""
    lam = body.eigenvalues
    if not residual:
        return float(np.sqrt(lam.max() / lam[list(kept)].max()))
    if loads.U is None:
        return None
    import scipy.linalg
    ix, R = list(kept), list(residual)
    PR = loads.P[np.ix_(ix, R)]
    K = np.block([[np.diag(lam[ix]), PR], [PR.T, loads.C[np.ix_(R, R)]]])
    M = np.block([[np.eye(len(ix)), PR / lam[ix, None]], [(PR / lam[ix, None]).T, loads.UMU[np.ix_(R, R)]]])
    top = scipy.linalg.eigh(K, M, eigvals_only=True)[-1]
    return float(np.sqrt(lam.max() / top))


def reduced_body(body: FlexibleBody, advice: ModeAdvice, loads: InertiaLoads, source: str = "BODY") -> FlexibleBody:
    """The advised body: the kept modes and the residual vectors of the advised load cases, brought back to the
    form of theory section 1 with everything per mode recomputed (augment.with_residual_vectors); its
    provenance records what was kept and why."""
    from .augment import with_residual_vectors
    kept = body.with_modes(list(advice.kept))
    note = (f"mode set (theory 12) for {', '.join(s.label for s in advice.scenes)} within {advice.tolerance:g}: "
            f"kept modes {', '.join(str(k + 1) for k in advice.kept)} of {advice.nf}")
    if not advice.residual_cases:
        return replace(kept, provenance=kept.provenance.with_note(note))
    if loads.U is None:
        raise FFRFError(f"{source}: modes/Phi: expected nodal FE data to add residual vectors, got invariants only")
    note += f"; residual vectors of the centrifugal cases {', '.join(CASES[j] for j in advice.residual_cases)}"
    return with_residual_vectors(kept, loads.U[:, list(advice.residual_cases)], note, source)


def advised_body(a: Analysis, source: str = "BODY") -> FlexibleBody:
    """The body reduced to the mode set advised for the default scenes (``modes BODY -o``'s body, theory 12)."""
    loads = inertia_loads(a.body)
    return reduced_body(a.body, advise_modes(a, loads=loads), loads, source)
