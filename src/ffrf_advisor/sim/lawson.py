"""DOP853 in generalized Lawson form: the modal oscillators integrated exactly (docs/simulate.md, exponential
integrator; Hochbruck and Ostermann, Exponential integrators, Acta Numerica 19, 2010, section 2.5; Krogstad's
generalized integrating factor methods, J. Comput. Phys. 203, 2005).

The equations split as ``y' = L y + N(t, y)``: L is the modal linear
part, per mode ``q' = q'``, ``q'' = -lam q - dmp q'`` (theory 5; zero on
p and w), and N = f - L y the rest (spin, loads, couplings). A step from
t starts from the static deflection of the modes under N there,
``s = -L^+ N(t, y)`` (``q_s = N_q'' / lam`` for lam > 0, else 0), and
carries ``z = y - s`` in the frame ``v(tau) = exp(-tau L) z(t + tau)``:
``v' = exp(-tau L) (N(t + tau, y) - N(t, y)_L)``, where ``N_L`` is the part
of N that L absorbs (the q' rows of modes with lam > 0). DOP853's stages,
error estimate and dense output are taken on v (sim.dop853's tableau and
step control, step for step), each stage's state carried to the y frame
by ``s + exp(c h L) v``, its forcing back by ``exp(-c h L)``; the step's
end and the samples likewise with ``exp(h L)`` and ``exp(theta h L)``, the
error estimate carried by ``exp(h L)`` before its norm. ``exp(tau L)`` is
a 2 x 2 block per mode in closed form (``propagators``). The scheme is
exact, whatever the step, for free vibration (N = 0) and for the static
response to a constant N: its steps follow the change of N, not the
highest mode. ``sim.lawson_reference`` is the same scheme in numpy, which
the tests compare this one against.
"""
from __future__ import annotations

import numpy as np

from .dop853 import (A, B, C, D, E3, E5, EXPONENT, MAX_FACTOR, MIN_FACTOR, NOT_FINITE, OK, OVER_BUDGET, SAFETY,
                     STAGES, TOO_SMALL, _combine, _combined_norm, _rms, _sample)
from .kernels import HUGE, bare, inline, jit, rhs_loaded as _f, store_row
from .model import N_ROT

DAMPED_SPAN = 5.0  # a step lets no mode decay by more than e^5 (``step_cap``)


@inline
def propagators(lam, dmp, tau, E):
    """E[r] = (e00, e01, e10, e11) of ``exp(tau [[0, 1], [-lam_r, -dmp_r]])``: with m = -dmp/2 and
    d = m^2 - lam, ``e^(m tau) (c I + s (M - m I))``, c = cos, s = sin(k tau) / k for d = -k^2 < 0 (cosh, sinh for
    d > 0; 1, tau for d = 0)."""
    for r in range(lam.shape[0]):
        m = -0.5 * dmp[r]
        d = m * m - lam[r]
        if d < 0.0:
            k = np.sqrt(-d)
            c, s = np.cos(k * tau), np.sin(k * tau) / k
        elif d > 0.0:
            k = np.sqrt(d)
            c, s = np.cosh(k * tau), np.sinh(k * tau) / k
        else:
            c, s = 1.0, tau
        e = np.exp(m * tau) if m != 0.0 else 1.0
        E[r, 0] = e * (c - m * s)
        E[r, 1] = e * s
        E[r, 2] = -e * lam[r] * s
        E[r, 3] = e * (c + m * s)


@jit
def step_cap(lam, dmp):
    """The longest step: DAMPED_SPAN over the fastest decay rate of exp(tau L) (|m| + k of ``propagators`` where
    d > 0, else |m|). exp(-tau L), which carries the forcing into the v frame, grows at that rate: the cap keeps
    its round-off within e^5 eps (and its numbers finite) on the damped modes; inf without damping."""
    rate = 0.0
    for r in range(lam.shape[0]):
        m = 0.5 * dmp[r]
        d = m * m - lam[r]
        rate = max(rate, m + np.sqrt(d) if d > 0.0 else m)
    return DAMPED_SPAN / rate if rate > 0.0 else np.inf


@inline
def _inverse(E, Ei):
    """Ei = E^-1 block by block (the propagator of -tau)."""
    for r in range(E.shape[0]):
        det = E[r, 0] * E[r, 3] - E[r, 1] * E[r, 2]
        Ei[r, 0] = E[r, 3] / det
        Ei[r, 1] = -E[r, 1] / det
        Ei[r, 2] = -E[r, 2] / det
        Ei[r, 3] = E[r, 0] / det


@inline
def _carry(E, x, out):
    """out = exp(tau L) x (E: its blocks); p and w unchanged; out may be x."""
    nf = E.shape[0]
    for i in range(N_ROT):
        out[i] = x[i]
    for r in range(nf):
        q, v = x[N_ROT + r], x[N_ROT + nf + r]
        out[N_ROT + r] = E[r, 0] * q + E[r, 1] * v
        out[N_ROT + nf + r] = E[r, 2] * q + E[r, 3] * v


@inline
def _nonlinear(lam, dmp, y, f):
    """f - L y in place (f = f(t, y)): the q rows are q' exactly, so zero; the q' rows gain lam q + dmp q'."""
    nf = lam.shape[0]
    for r in range(nf):
        f[N_ROT + r] = 0.0
        f[N_ROT + nf + r] += lam[r] * y[N_ROT + r] + dmp[r] * y[N_ROT + nf + r]


@inline
def _g(rhs, t, Ep, Em, V, Y, G, shift, model, prog, fext, scratch):
    """G = exp(-c h L) (N(t, Y) - N_L), Y = s + exp(c h L) V (Ep, Em: the propagators of +-c h; ``shift``: rows s and
    N_L of the step); Y: workspace, left holding the y-frame state."""
    n = V.shape[0]
    lam, dmp = model[6], model[7]
    _carry(Ep, V, Y)
    for i in range(n):
        Y[i] += shift[0, i]
    _f(rhs, t, Y, G, model, prog, fext, scratch)
    _nonlinear(lam, dmp, Y, G)
    for i in range(n):
        G[i] -= shift[1, i]
    _carry(Em, G, G)


@inline
def _shift(lam, N, y, shift, z):
    """The step's static deflection s (shift[0]) and absorbed forcing N_L (shift[1]) from N = N(t, y); z = y - s
    (module docstring)."""
    n, nf = y.shape[0], lam.shape[0]
    for i in range(n):
        shift[0, i] = 0.0
        shift[1, i] = 0.0
    for r in range(nf):
        if lam[r] > 0.0:
            shift[1, N_ROT + nf + r] = N[N_ROT + nf + r]
            shift[0, N_ROT + r] = N[N_ROT + nf + r] / lam[r]
    for i in range(n):
        z[i] = y[i] - shift[0, i]


@inline
def _initial_step(rhs, z0, g0, t_end, rtol, atol, shift, model, prog, fext, scratch, Ep, Em, y1, Y, g1):
    """scipy's ``select_initial_step`` for order 7 on the v frame from z0 (one more evaluation)."""
    n = z0.shape[0]
    scale = atol + np.abs(z0) * rtol
    d0, d1 = _rms(z0, scale), _rms(g0, scale)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, t_end)
    for i in range(n):
        y1[i] = z0[i] + h0 * g0[i]
    propagators(model[6], model[7], h0, Ep)
    _inverse(Ep, Em)
    _g(rhs, h0, Ep, Em, y1, Y, g1, shift, model, prog, fext, scratch)
    for i in range(n):
        y1[i] = g1[i] - g0[i]
    d2 = _rms(y1, scale) / h0
    h1 = max(1e-6, h0 * 1e-3) if d1 <= 1e-15 and d2 <= 1e-15 else (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    return min(100.0 * h0, h1, t_end)


@jit
def integrate_lawson(rhs, y0, t_end, rtol, atol, t_out, budget, out, model, prog, fext):
    """As sim.dop853.integrate_dop853, in generalized Lawson form (module docstring); the same returns."""
    n, nf = y0.shape[0], model[6].shape[0]
    scratch = (np.empty(3), np.empty(3), np.empty(3))
    K, DK, Ep, Em = np.empty((16, n)), np.empty((4, n)), np.empty((16, nf, 4)), np.empty((16, nf, 4))
    work, shift, z = np.empty((7, n)), np.empty((2, n)), np.empty(n)
    y = y0.copy()
    _f(rhs, 0.0, y, work[4], model, prog, fext, scratch)
    _nonlinear(model[6], model[7], y, work[4])
    _shift(model[6], work[4], y, shift, z)
    for i in range(n):
        K[0, i] = work[4, i] - shift[1, i]
    cap = step_cap(model[6], model[7])
    h = _initial_step(rhs, z, K[0], min(t_end, cap), rtol, atol, shift, model, prog, fext, scratch, Ep[0], Em[0],
                      work[0], work[1], work[2])
    store_row(out, 0, y)
    return _steps(rhs, y, z, h, cap, t_end, rtol, atol, t_out, budget, out, model, prog, fext, scratch, K, DK, Ep, Em,
                  work, shift, np.empty(7), np.empty((nf, 4)))


@inline
def _stage(rhs, t, z, h, K, s, Ep, Em, shift, model, prog, fext, scratch, V, Y):
    """K[s] = G of stage s from the tableau's row s and the stages before it."""
    n = z.shape[0]
    _combine(A[s], K, V)
    for i in range(n):
        V[i] = z[i] + h * V[i]
    _g(rhs, t + C[s] * h, Ep[s], Em[s], V, Y, K[s], shift, model, prog, fext, scratch)


@inline
def _error_norm(K, h, scale, Eh, a5, a3):
    """Hairer's combined estimate (sim.dop853._error_norm) of the v-frame estimates carried to y by exp(h L)."""
    _combine(E5, K, a5)
    _combine(E3, K, a3)
    _carry(Eh, a5, a5)
    _carry(Eh, a3, a3)
    return _combined_norm(h, scale, a5, a3)


@inline
def _stage_propagators(lam, dmp, h, first, last, Ep, Em):
    """The propagators of +-C[s] h for the stages first..last - 1 (a stage at the same node as the one before
    copies them: C[STAGES] = C[STAGES - 1] = 1)."""
    for s in range(first, last):
        if C[s] == C[s - 1] and s > first:
            for r in range(lam.shape[0]):
                for j in range(4):
                    Ep[s, r, j] = Ep[s - 1, r, j]
                    Em[s, r, j] = Em[s - 1, r, j]
        else:
            propagators(lam, dmp, C[s] * h, Ep[s])
            _inverse(Ep[s], Em[s])


@bare
def _steps(rhs, y, z, h, cap, t_end, rtol, atol, t_out, budget, out, model, prog, fext, scratch, K, DK, Ep, Em, work,
           shift, F, Es):
    """``integrate_lawson``'s steps from t = 0 (y, z = y - s and K[0] = N(0, y) - N_L given, h the initial step, cap
    the longest: ``step_cap``); its returns. work: rows V, Y, v_new (the step's end in the v frame), y_new, N at
    y_new, and the error estimates."""
    n = y.shape[0]
    lam, dmp = model[6], model[7]
    V, Y, v_new, y_new, N_new, a5, a3 = work[0], work[1], work[2], work[3], work[4], work[5], work[6]
    t = 0.0
    nfev, steps, row = 2, 0, 1
    while t < t_end:
        min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
        h = max(h, min_step)
        rejected = False
        while True:
            if h < min_step:
                return row, nfev, steps, TOO_SMALL, t
            t_new = min(t + min(h, cap), t_end)
            h = t_new - t
            _stage_propagators(lam, dmp, h, 1, STAGES + 1, Ep, Em)
            for s in range(1, STAGES):
                _stage(rhs, t, z, h, K, s, Ep, Em, shift, model, prog, fext, scratch, V, Y)
            _combine(B, K, v_new)
            for i in range(n):
                v_new[i] = z[i] + h * v_new[i]
            _carry(Ep[STAGES], v_new, y_new)
            for i in range(n):
                y_new[i] += shift[0, i]
            _f(rhs, t_new, y_new, N_new, model, prog, fext, scratch)
            _nonlinear(lam, dmp, y_new, N_new)
            for i in range(n):
                V[i] = N_new[i] - shift[1, i]
            _carry(Em[STAGES], V, K[STAGES])
            nfev += STAGES
            if nfev > budget:
                return row, nfev, steps, OVER_BUDGET, t
            for i in range(n):
                V[i] = atol[i] + max(abs(y[i]), abs(y_new[i])) * rtol
            err = _error_norm(K, h, V, Ep[STAGES], a5, a3)
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
            _stage_propagators(lam, dmp, h_step, STAGES + 1, 16, Ep, Em)
            for s in range(STAGES + 1, 16):
                _stage(rhs, t_old, z, h_step, K, s, Ep, Em, shift, model, prog, fext, scratch, V, Y)
            nfev += 3
            for r in range(4):
                _combine(D[r], K, DK[r])
            while row < t_out.shape[0] and t_out[row] <= t_new:
                _sample(t_old, h_step, z, v_new, K, DK, t_out[row], V, F)
                propagators(lam, dmp, t_out[row] - t_old, Es)
                _carry(Es, V, V)
                for i in range(n):
                    out[row, i] = V[i] + shift[0, i]
                row += 1
        for i in range(n):
            y[i] = y_new[i]
            if not np.isfinite(y[i]) or abs(y[i]) > HUGE:
                return row, nfev, steps, NOT_FINITE, t_new
        _shift(lam, N_new, y, shift, z)
        for i in range(n):
            K[0, i] = N_new[i] - shift[1, i]
        t = t_new
    return row, nfev, steps, OK, t
