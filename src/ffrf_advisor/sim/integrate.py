"""Integrators for the FFRF equations: fixed-step RK4 (two rotation updates), implicit midpoint, compiled
DOP853 (``dop853``, sim.dop853), compiled DOP853 in Lawson form with the modal oscillators exact
(``exponential``, sim.lawson), and scipy's solve_ivp (``scipy-dop853``, ``rk45``, ...).

Every run returns a ``Run``: the sampled trajectory, right-hand-side
evaluations, steps, wall time and, instead of an exception, a failure flag
with its time and reason (non-finite or overflowing state, quaternion norm
lost, Newton iteration or step control failed). Theory section 10: explicit
RK4 is stable for ``h Omega_max <= 2 sqrt 2`` on undamped modes; implicit
midpoint is A-stable, symplectic, and keeps |p| = 1 exactly (a quadratic
invariant of the kinematics) up to its Newton tolerance.
"""
from __future__ import annotations

import os
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..names import ADAPTIVE, FIXED, INTEGRATORS  # noqa: F401 (defined in names: the CLI's help lists them)
from .loads import Loads
from .model import Model

SCIPY_NAMES = {"dop853": "DOP853", "scipy-dop853": "DOP853", "rk45": "RK45", "radau": "Radau", "bdf": "BDF",
               "lsoda": "LSODA"}
REASONS = {1: "state not finite or overflowing", 2: "quaternion norm lost"}
EXPONENTIAL = "exponential"  # sim.lawson: verify's reference; the command line offers it where names lists it
METHODS = tuple(dict.fromkeys((*INTEGRATORS, EXPONENTIAL)))


def rk4_limit(eigenvalues) -> float:
    """``2 sqrt 2 / Omega_max``: the largest stable explicit RK4 step on undamped modes (theory section 10)."""
    return 2 * np.sqrt(2) / float(np.sqrt(np.abs(np.asarray(eigenvalues)).max()))


@dataclass(frozen=True)
class Run:
    """A simulation: samples t (N,), states y (N, 7 + 2 nf), cost, and how it ended."""

    method: str
    t: np.ndarray
    y: np.ndarray
    nfev: int
    steps: int
    wall_s: float
    failed: bool = False
    t_fail: float | None = None
    reason: str = ""
    step: float | None = None


class OverBudget(Exception):
    """An adaptive integration needed more right-hand sides than its work budget (``work_budget``)."""


EVALUATIONS_PER_PERIOD = 1000  # right-hand sides an adaptive method may spend per period (DOP853 at 1e-12: ~600)
BASE_EVALUATIONS = 100_000


def work_budget(model: Model, y0: np.ndarray, t_end: float) -> int:
    """Right-hand sides an adaptive run may take: EVALUATIONS_PER_PERIOD per period of the fastest motion
    (the highest mode, or the initial spin), plus BASE_EVALUATIONS; past it the run fails, said so."""
    f_fast = max(np.sqrt(np.max(np.abs(model.eigenvalues), initial=0.0)), np.linalg.norm(y0[4:7])) / (2 * np.pi)
    return int(min(BASE_EVALUATIONS + EVALUATIONS_PER_PERIOD * t_end * f_fast, 1e12))


class Rhs:
    """The compiled right-hand side of a model with its loads, callable as f(t, y); counts evaluations and
    raises OverBudget past ``budget`` of them."""

    def __init__(self, model: Model, loads: Loads = Loads(), budget: float = np.inf):
        from . import kernels  # lazy: the compiler loads only when a simulation runs
        self.k, self.model, self.loads, self.nfev, self.budget = kernels, _compiled_model(model), loads, 0, budget
        self.zero3, self.zf = np.zeros(3), np.zeros(model.nf)

    def __call__(self, t: float, y: np.ndarray) -> np.ndarray:
        L = self.loads
        self.nfev += 1
        if self.nfev > self.budget:
            raise OverBudget(f"work budget of {self.budget} right-hand sides spent at t = {t:.6g} (stiff, or "
                             "blowing up)")
        tau = self.zero3 if L.torque is None else np.asarray(L.torque(t), float)
        fext = self.zf if L.modal is None else np.asarray(L.modal(t), float)
        pres = L.prescribed is not None
        w, wd = (np.asarray(v, float) for v in L.prescribed(t)) if pres else (self.zero3, self.zero3)
        out = np.empty_like(y)
        self.k.rhs_into(np.ascontiguousarray(y, dtype=float), out, self.model, tau, fext, pres, w, wd)
        return out


def integrate(model: Model, y0: np.ndarray, t_end: float, method: str = "rk4", step: float | None = None,
              rtol: float = 1e-8, atol: float = 1e-10, output_step: float | None = None,
              loads: Loads = Loads(), progress: Callable[[float], None] | None = None) -> Run:
    """Integrate from t = 0 to ``t_end``; samples every ``output_step`` (default t_end / 1000, or every step)."""
    if method not in METHODS:
        raise ValueError(f"integrator {method!r}: expected one of {', '.join(METHODS)}")
    y0 = np.array(y0, float)
    program = loads.compiled()
    if method in FIXED:
        if step is None or not step > 0:
            raise ValueError(f"integrator {method}: needs a positive --step")
        nsteps = max(1, int(round(t_end / step)))
        every = max(1, int(round((output_step or max(t_end / 1000, step)) / step)))
        nsteps = every * int(np.ceil(nsteps / every))
        if method in ("rk4", "rk4-lie") and loads.none:
            return _rk4_compiled(model, y0, step, nsteps, every, method == "rk4-lie", progress)
        if method == "midpoint" and program is not None:
            return _midpoint_compiled(model, y0, step, nsteps, every, program)
        return _fixed_python(model, y0, step, nsteps, every, method, loads, progress)
    output_step = output_step or t_end / 1000
    if method in ("dop853", EXPONENTIAL) and program is not None:
        return _dop853_compiled(model, y0, t_end, rtol, atol, output_step, program, method)
    if method == EXPONENTIAL:
        raise ValueError(f"integrator {method}: loads with a modal force are for the other integrators")
    return _adaptive(model, y0, t_end, method, rtol, atol, output_step, loads)


def _rk4_compiled(model, y0, h, nsteps, every, lie, progress) -> Run:
    """RK4 entirely in compiled code: in chunks of about 1 % when a progress bar follows (each chunk is a call
    from Python, about 20 us), else in one call."""
    from . import rk4
    address, compiled = compiled_args(model)
    out = np.empty((nsteps // every + 1, len(y0)))
    chunk = every * max(1, (nsteps // every) // 100) if progress else nsteps
    done, code, start, y = 0, 0, time.perf_counter(), y0
    while done < nsteps and code == 0:
        n = min(chunk, nsteps - done)
        part = out[done // every:done // every + n // every + 1]  # its row 0: y, the last chunk's last row
        steps, code = rk4.rk4_loop(address, y, h, n, every, lie, part, compiled)
        rows = steps // every if code else n // every
        done += steps
        y = part[rows]
        if progress:
            progress(done / nsteps)
    wall = time.perf_counter() - start
    rows = (done // every if code else nsteps // every) + 1
    return Run("rk4-lie" if lie else "rk4", np.arange(rows) * every * h, out[:rows], 4 * done, done, wall,
               failed=code != 0, t_fail=done * h if code else None, reason=REASONS.get(code, ""), step=h)


COMPILED = ("rhs", "rk4", "dop853", "midpoint", EXPONENTIAL)


def compile_ahead(names) -> None:
    """Compile, or load from numba's cache, the compiled code ``names`` (of COMPILED) for the argument types the
    runs pass, without running it. The integrators call the right-hand side by its address, so they compile
    without it: separate processes can compile them side by side (the tests' workers do, tests/conftest.py)."""
    from numba import types as t

    from . import dop853, kernels, lawson, midpoint, rk4
    F1, F2, M, i8, f8 = kernels.F1, kernels.F2, kernels.MODEL, t.int64, t.float64
    adaptive = (i8, F1, f8, f8, F1, F1, i8, F2, M, F1, F1)
    ahead = {"rhs": kernels.rhs_address,
             "rk4": lambda: rk4.rk4_loop.compile((i8, F1, f8, i8, i8, t.boolean, F2, M)),
             "dop853": lambda: dop853.integrate_dop853.compile(adaptive),
             EXPONENTIAL: lambda: lawson.integrate_lawson.compile(adaptive),
             "midpoint": lambda: midpoint.midpoint_loop.compile((i8, F1, f8, i8, i8, F2, M, F1, F1))}
    for name in names:
        ahead[name]()


def compile_beside(names) -> None:
    """``compile_ahead(names)``, then the right-hand side: where numba compiles (the first run after installing),
    the right-hand side, the largest piece, in a second process beside this one's ``names``, then loaded from
    numba's cache (the integrators compile without it, ``compile_ahead``); where everything is cached, only
    loads. A helper that fails leaves the right-hand side to this process."""
    import subprocess
    import sys

    from ..pool import ended
    from .kernels import on_compile
    helpers: list = []
    helper = (f"from {__package__.rpartition('.')[0]}.io.guard import die_with_parent; "
              f"die_with_parent({os.getpid()}); from {__name__} import compile_ahead; compile_ahead(('rhs',))")
    try:
        with on_compile(lambda: helpers.append(subprocess.Popen([sys.executable, "-c", helper],
                                                                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                                                stderr=subprocess.DEVNULL))):
            compile_ahead(names)
        for process in helpers:  # at most one: numba's first compile starts it
            ended(process)
    finally:
        for process in helpers:
            process.kill()  # still running only when this process was interrupted
    compile_ahead(("rhs",))


def compiled_args(m: Model) -> tuple[int, tuple]:
    """(the right-hand side's address, the packed model): the first and the model argument of every compiled
    loop (kernels.rhs_address, ``_compiled_model``)."""
    from . import kernels
    return kernels.rhs_address(), _compiled_model(m)


def _compiled_model(m: Model) -> tuple:
    """The model as the compiled loops read it (``kernels.rhs_into``): the Sbar blocks in strips or tall
    (sim.model), with its scratch workspace."""
    from . import kernels
    return (m.flags, m.I0, m.Ibar, *m.kernel_blocks, m.eigenvalues, m.damping, m.G, kernels.workspace(m.nf))


MIDPOINT_FAILURES = {1: REASONS[1], 2: REASONS[2], 3: "Newton iteration did not converge"}


def _midpoint_compiled(model, y0, h, nsteps, every, program) -> Run:
    """The implicit midpoint rule in compiled code (sim.midpoint; ``_MidpointStepper`` is its reference)."""
    from . import midpoint
    out = np.empty((nsteps // every + 1, len(y0)))
    address, compiled = compiled_args(model)
    start = time.perf_counter()
    steps, nfev, code = midpoint.midpoint_loop(address, y0, h, nsteps, every, out, compiled, program,
                                               np.zeros(model.nf))
    wall = time.perf_counter() - start
    rows = (steps - 1 if code else steps) // every + 1
    return Run("midpoint", np.arange(rows) * every * h, out[:rows], nfev, steps, wall, code != 0,
               steps * h if code else None, MIDPOINT_FAILURES.get(code, ""), h)


def _fixed_python(model, y0, h, nsteps, every, method, loads, progress) -> Run:
    """RK4 with loads (Python loop over the compiled right-hand side) or the implicit midpoint rule."""
    f = Rhs(model, loads)
    stepper = _MidpointStepper() if method == "midpoint" else _rk4_step
    rows, y, start = [y0], y0, time.perf_counter()
    for n in range(nsteps):
        t = n * h
        y, reason = stepper(f, t, y, h)
        if reason:
            return Run(method, np.arange(len(rows)) * every * h, np.array(rows), f.nfev, n + 1,
                       time.perf_counter() - start, True, t + h, reason, h)
        if (n + 1) % every == 0:
            rows.append(y)
            if progress:
                progress((n + 1) / nsteps)
    return Run(method, np.arange(len(rows)) * every * h, np.array(rows), f.nfev, nsteps,
               time.perf_counter() - start, step=h)


def _state_failure(y: np.ndarray, p_norm: float) -> str:
    from .kernels import HUGE, QUATERNION_TOL
    if not np.all(np.isfinite(y)) or np.abs(y).max() > HUGE:
        return REASONS[1]
    return REASONS[2] if abs(p_norm - 1) > QUATERNION_TOL else ""


def _rk4_step(f, t, y, h):
    """Classical RK4, quaternion normalised after the step."""
    k1 = f(t, y)
    k2 = f(t + h / 2, y + h / 2 * k1)
    k3 = f(t + h / 2, y + h / 2 * k2)
    k4 = f(t + h, y + h * k3)
    y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    norm = np.linalg.norm(y[:4])
    y[:4] /= norm if norm > 0 else 1.0
    return y, _state_failure(y, norm)


class _MidpointStepper:
    """Implicit midpoint steps ``Y = y + h f(t + h/2, (y + Y)/2)`` by the simplified Newton iteration of
    sim.midpoint, its forward-difference Jacobian kept from step to step by the same rule (its Python
    reference: the same iterates, the same evaluations)."""

    def __init__(self):
        self.inverse, self.fresh = None, True

    def __call__(self, f, t, y, h):
        from .midpoint import THETA_REFRESH
        f0 = f(t + h / 2, y)
        if self.fresh:
            self.inverse = self._inverse(f, t, y, h, f0)
        Y, reason, theta = self._newton(f, t, y, h, f0, kept=not self.fresh)
        if not self.fresh and reason not in ("", REASONS[2]):
            self.inverse = self._inverse(f, t, y, h, f0)
            Y, reason, theta = self._newton(f, t, y, h, f0, kept=False)
        self.fresh = theta > THETA_REFRESH
        return Y, reason

    @staticmethod
    def _inverse(f, t, y, h, f0):
        """``(1 - h/2 J)^-1``, J the forward-difference Jacobian of f at (t + h/2, y)."""
        from .midpoint import FD_STEP
        n = len(y)
        J = np.empty((n, n))
        for j in range(n):
            d = FD_STEP * max(1.0, abs(y[j]))
            yj = y.copy()
            yj[j] += d
            J[:, j] = (f(t + h / 2, yj) - f0) / d
        return np.linalg.inv(np.eye(n) - h / 2 * J)

    def _newton(self, f, t, y, h, f0, kept):
        """(Y, failure reason, largest ratio of successive corrections) from the Euler predictor; ``kept``: a
        growing correction ends the iteration (the inverse is from an earlier step)."""
        from .midpoint import NEWTON_MAX, NEWTON_TOL
        Y, theta, last = y + h * f0, 0.0, np.inf
        for it in range(NEWTON_MAX):
            dY = self.inverse @ (Y - y - h * f(t + h / 2, (y + Y) / 2))
            Y = Y - dY
            if not np.all(np.isfinite(Y)):
                return Y, REASONS[1], theta
            dn = np.linalg.norm(dY)
            if it > 0:
                theta = max(theta, dn / last)
                if kept and dn >= last:
                    return Y, MIDPOINT_FAILURES[3], theta
            last = dn
            if dn <= NEWTON_TOL * (1 + np.linalg.norm(Y)):
                return Y, _state_failure(Y, np.linalg.norm(Y[:4])), theta
        return Y, MIDPOINT_FAILURES[3], theta


def _output_times(t_end: float, output_step: float) -> np.ndarray:
    return np.linspace(0.0, t_end, max(2, int(round(t_end / output_step)) + 1))


DOP853_FAILURES = {1: "required step size is less than spacing between numbers", 2: REASONS[1]}


def _dop853_compiled(model, y0, t_end, rtol, atol, output_step, program, method="dop853") -> Run:
    """DOP853 in compiled code (sim.dop853), or in Lawson form (``exponential``, sim.lawson), sampled on the output
    grid as it goes."""
    from . import dop853, lawson
    kernel = lawson.integrate_lawson if method == EXPONENTIAL else dop853.integrate_dop853
    t = _output_times(t_end, output_step)
    out = np.empty((len(t), len(y0)))
    budget = work_budget(model, y0, t_end)
    atol = np.broadcast_to(np.asarray(atol, float), y0.shape).copy()
    address, compiled = compiled_args(model)
    start = time.perf_counter()
    rows, nfev, steps, code, t_reached = kernel(
        address, y0, float(t_end), float(rtol), atol, t, budget, out, compiled, program, np.zeros(model.nf))
    wall = time.perf_counter() - start
    reason = (f"work budget of {budget} right-hand sides spent at t = {t_reached:.6g} (stiff, or blowing up)"
              if code == dop853.OVER_BUDGET else DOP853_FAILURES.get(code, ""))
    return Run(method, t[:rows], out[:rows], nfev, steps, wall, code != 0, t_reached if code else None, reason)


def _adaptive(model, y0, t_end, method, rtol, atol, output_step, loads) -> Run:
    """scipy's solve_ivp with dense output sampled on the output grid; steps are the accepted ones."""
    from scipy.integrate import solve_ivp  # 0.2 s to import: only when an adaptive run needs it
    f = Rhs(model, loads, work_budget(model, y0, t_end))
    start = time.perf_counter()
    try:
        with np.errstate(all="ignore"):
            sol = solve_ivp(f, (0.0, t_end), y0, method=SCIPY_NAMES[method],
                            dense_output=True, rtol=rtol, atol=atol)
    except OverBudget as e:
        return Run(method, np.zeros(1), y0[None, :], f.nfev, 0, time.perf_counter() - start, True, 0.0, str(e))
    wall = time.perf_counter() - start
    t_last = float(sol.t[-1])
    t = _output_times(t_end, output_step)
    t = t[t <= t_last]
    y = sol.sol(t).T if sol.sol is not None else y0[None, :]
    finite = np.all(np.isfinite(y), axis=1)
    failed = sol.status < 0 or not finite.all()
    reason = (sol.message if sol.status < 0 else REASONS[1]) if failed else ""
    return Run(method, t[finite], y[finite], f.nfev, len(sol.t) - 1, wall, failed,
               t_last if failed else None, reason)
