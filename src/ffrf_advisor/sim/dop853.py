"""DOP853 compiled around the compiled right-hand side: no Python call per evaluation (theory section 10).

The method is Dormand and Prince's explicit Runge-Kutta pair of order 8
with the error estimator of Hairer's DOP853 (orders 5 and 3 combined) and
its dense output of order 7, step for step as scipy's ``solve_ivp(method=
"DOP853")`` does it (initial step, error norm, step factors 0.2-10 with
safety 0.9, no growth right after a rejection); the Butcher tableau is
scipy's own (``scipy.integrate._ivp.dop853_coefficients``), not retyped.
The differences are where the work goes: every stage calls
``kernels.rhs_into`` inside the loop (by its address, kernels.call_rhs),
the state is sampled on the output grid as the steps pass (three more
stages only for steps that hold a sample), and no step's interpolant is
kept, so memory is the samples'.

Loads are the parametric shapes of ``sim.loads.LoadProgram`` (a sin^2
torque pulse, a prescribed spin ramp), evaluated in the loop by
``kernels.rhs_loaded``.
"""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import scipy

from .kernels import HUGE, bare, inline, jit, rhs_loaded as _f, store_row


def _scipy_tableau():
    """scipy's ``scipy/integrate/_ivp/dop853_coefficients.py``, loaded from its file: importing it by name
    would first run ``scipy.integrate``'s ``__init__`` (about 0.3 s of quadrature, BVP and ODE modules that
    nothing here uses). The file only imports numpy."""
    path = Path(scipy.__file__).parent / "integrate" / "_ivp" / "dop853_coefficients.py"
    spec = importlib.util.spec_from_file_location("_ffrf_dop853_tableau", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


tableau = _scipy_tableau()

STAGES = tableau.N_STAGES                      # 12 stages of the step ...
A = np.ascontiguousarray(tableau.A)            # ... 16 with the dense output's extra three
B = np.ascontiguousarray(tableau.B)
C = np.ascontiguousarray(tableau.C)
E3 = np.ascontiguousarray(tableau.E3)
E5 = np.ascontiguousarray(tableau.E5)
D = np.ascontiguousarray(tableau.D)            # (4, 16): the interpolant's higher coefficients
SAFETY, MIN_FACTOR, MAX_FACTOR = 0.9, 0.2, 10.0
EXPONENT = -1.0 / 8.0                          # error estimator of order 7

OK, TOO_SMALL, NOT_FINITE, OVER_BUDGET = 0, 1, 2, 3


@inline
def _rms(x, scale):
    s = 0.0
    for i in range(x.shape[0]):
        s += (x[i] / scale[i]) ** 2
    return np.sqrt(s / x.shape[0])


@inline
def _initial_step(rhs, t0, y0, f0, t_end, rtol, atol, model, prog, fext, scratch, y1, f1):
    """scipy's ``select_initial_step`` for order 7 (one more evaluation)."""
    n = y0.shape[0]
    scale = atol + np.abs(y0) * rtol
    d0, d1 = _rms(y0, scale), _rms(f0, scale)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, t_end - t0)
    for i in range(n):
        y1[i] = y0[i] + h0 * f0[i]
    _f(rhs, t0 + h0, y1, f1, model, prog, fext, scratch)
    for i in range(n):
        y1[i] = f1[i] - f0[i]
    d2 = _rms(y1, scale) / h0
    h1 = max(1e-6, h0 * 1e-3) if d1 <= 1e-15 and d2 <= 1e-15 else (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    return min(100.0 * h0, h1, t_end - t0)


@bare
def _combine(coefficients, K, acc):
    """acc = sum_j coefficients[j] K[j], term by term in j (a contiguous multiply-add per stage, so the compiler
    vectorises over the state; the sum's order is the tableau's). The first nonzero term sets acc (no zeroing
    pass: 3 % of a level-I run); a zero coefficient adds nothing to finite stages and is skipped (29 % of the
    tableau's products; a non-finite stage fails the step anyway), so a row of A reads only the stages before
    its own (A is strictly lower triangular; the later rows of K are not yet set)."""
    n = acc.shape[0]
    first = True
    for j in range(coefficients.shape[0]):
        c = coefficients[j]
        if c == 0.0:
            continue
        if first:
            for i in range(n):
                acc[i] = c * K[j, i]
            first = False
        else:
            for i in range(n):
                acc[i] += c * K[j, i]
    if first:
        for i in range(n):
            acc[i] = 0.0


@inline
def _stage(rhs, t, y, h, K, s, model, prog, fext, scratch, ys):
    """K[s] from the tableau's row s and the stages before it (inlined into the steps' loops over s)."""
    n = y.shape[0]
    _combine(A[s], K, ys)
    for i in range(n):
        ys[i] = y[i] + h * ys[i]
    _f(rhs, t + C[s] * h, ys, K[s], model, prog, fext, scratch)


@inline
def _error_norm(K, h, scale, a5, a3):
    """Hairer's combined estimate of the stages K (a5, a3: workspace for the two embedded estimates)."""
    _combine(E5, K, a5)
    _combine(E3, K, a3)
    return _combined_norm(h, scale, a5, a3)


@inline
def _combined_norm(h, scale, a5, a3):
    """|h| e5^2 / sqrt((e5^2 + 0.01 e3^2) n) of the estimates a5, a3, e5 and e3 in the scale's norm."""
    n = scale.shape[0]
    e5, e3 = 0.0, 0.0
    for i in range(n):
        e5 += (a5[i] / scale[i]) ** 2
        e3 += (a3[i] / scale[i]) ** 2
    if e5 == 0.0 and e3 == 0.0:
        return 0.0
    return abs(h) * e5 / np.sqrt((e5 + 0.01 * e3) * n)


@inline
def _sample(t_old, h, y_old, y_new, K, DK, t_out, y_out, F):
    """The order-7 interpolant of the step at t_out (K holds the 16 stages, DK[r] = sum_s D[r, s] K[s]; F:
    workspace of 7)."""
    n = y_old.shape[0]
    x = (t_out - t_old) / h
    for i in range(n):
        dy = y_new[i] - y_old[i]
        F[0] = dy
        F[1] = h * K[0, i] - dy
        F[2] = 2.0 * dy - h * (K[STAGES, i] + K[0, i])
        for r in range(4):
            F[3 + r] = h * DK[r, i]
        v = 0.0
        for r in range(6, -1, -1):  # scipy's Horner scheme in x and 1 - x, from F[6] down
            v += F[r]
            v *= x if (6 - r) % 2 == 0 else 1.0 - x
        y_out[i] = y_old[i] + v


@jit
def integrate_dop853(rhs, y0, t_end, rtol, atol, t_out, budget, out, model, prog, fext):
    """Integrate from 0 to t_end; row j of ``out`` is the state at t_out[j] (increasing, t_out[0] = 0); ``rhs``:
    the right-hand side's address (kernels.rhs_address).

    Returns (rows written, evaluations, accepted steps, failure code, time reached).
    """
    n = y0.shape[0]
    scratch = (np.empty(3), np.empty(3), np.empty(3))
    K, DK = np.empty((16, n)), np.empty((4, n))
    ys, y_new, tmp, a5, a3, F = np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(7)
    y = y0.copy()
    _f(rhs, 0.0, y, K[0], model, prog, fext, scratch)
    h = _initial_step(rhs, 0.0, y, K[0], t_end, rtol, atol, model, prog, fext, scratch, ys, tmp)
    store_row(out, 0, y)
    return _steps(rhs, y, h, t_end, rtol, atol, t_out, budget, out, model, prog, fext, scratch, K, DK, ys, y_new,
                  tmp, a5, a3, F)


@bare
def _steps(rhs, y, h, t_end, rtol, atol, t_out, budget, out, model, prog, fext, scratch, K, DK, ys, y_new, tmp, a5, a3,
           F):
    """``integrate_dop853``'s steps from t = 0 (y and K[0] = f(0, y) given, h the initial step) in its
    workspace; its return values."""
    n = y.shape[0]
    t = 0.0
    nfev, steps, row = 2, 0, 1
    while t < t_end:
        min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
        h = max(h, min_step)
        rejected = False
        while True:
            if h < min_step:
                return row, nfev, steps, TOO_SMALL, t
            t_new = min(t + h, t_end)
            h = t_new - t
            for s in range(1, STAGES):
                _stage(rhs, t, y, h, K, s, model, prog, fext, scratch, ys)
            _combine(B, K, y_new)
            for i in range(n):
                y_new[i] = y[i] + h * y_new[i]
            _f(rhs, t_new, y_new, K[STAGES], model, prog, fext, scratch)
            nfev += STAGES
            if nfev > budget:
                return row, nfev, steps, OVER_BUDGET, t
            for i in range(n):
                tmp[i] = atol[i] + max(abs(y[i]), abs(y_new[i])) * rtol
            err = _error_norm(K, h, tmp, a5, a3)
            if err < 1.0:  # NaN is not: a non-finite step is rejected until the step is too small
                factor = MAX_FACTOR if err == 0.0 else min(MAX_FACTOR, SAFETY * err ** EXPONENT)
                h *= min(1.0, factor) if rejected else factor
                break
            factor = SAFETY * err ** EXPONENT
            h *= factor if factor > MIN_FACTOR else MIN_FACTOR  # NaN: the smallest factor
            rejected = True
        t_old, h_step = t, t_new - t
        steps += 1
        if row < t_out.shape[0] and t_out[row] <= t_new:
            for s in range(STAGES + 1, 16):
                _stage(rhs, t_old, y, h_step, K, s, model, prog, fext, scratch, ys)
            nfev += 3
            for r in range(4):
                _combine(D[r], K, DK[r])
            while row < t_out.shape[0] and t_out[row] <= t_new:
                _sample(t_old, h_step, y, y_new, K, DK, t_out[row], out[row], F)
                row += 1
        for i in range(n):
            y[i] = y_new[i]
            if not np.isfinite(y[i]) or abs(y[i]) > HUGE:
                return row, nfev, steps, NOT_FINITE, t_new
            K[0, i] = K[STAGES, i]
        t = t_new
    return row, nfev, steps, OK, t
