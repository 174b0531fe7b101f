"""Fixed-step RK4 of a free body in compiled code, classical or with the rotation advanced on the group (RKMK4),
around the compiled right-hand side (sim.kernels, called by its address; theory section 10)."""
from __future__ import annotations

import numpy as np

from .kernels import (FAIL_NONE, FAIL_NONFINITE, FAIL_QUATERNION, FREE, HUGE, QUATERNION_TOL, bare, call_rhs, inline,
                      jit, store_row)
from .model import N_ROT


@inline
def _rotate_by(p, theta, out):
    """out[0:4] = p[0:4] * exp(theta): the body turned by the rotation vector theta (body frame); out may be p."""
    angle = np.sqrt(theta[0] ** 2 + theta[1] ** 2 + theta[2] ** 2)
    e0 = np.cos(0.5 * angle)
    f = 0.5 if angle < 1e-8 else np.sin(0.5 * angle) / angle
    e1, e2, e3 = f * theta[0], f * theta[1], f * theta[2]
    p0, p1, p2, p3 = p[0], p[1], p[2], p[3]
    out[0] = p0 * e0 - p1 * e1 - p2 * e2 - p3 * e3
    out[1] = p0 * e1 + p1 * e0 + p2 * e3 - p3 * e2
    out[2] = p0 * e2 - p1 * e3 + p2 * e0 + p3 * e1
    out[3] = p0 * e3 + p1 * e2 - p2 * e1 + p3 * e0


@inline
def _dexpinv(theta, w, out):
    """Theta' = w + 1/2 theta x w + 1/12 theta x (theta x w): p = p_n exp(theta), p' = p (0, w) / 2 (RKMK4)."""
    c0 = theta[1] * w[2] - theta[2] * w[1]
    c1 = theta[2] * w[0] - theta[0] * w[2]
    c2 = theta[0] * w[1] - theta[1] * w[0]
    out[0] = w[0] + 0.5 * c0 + (theta[1] * c2 - theta[2] * c1) / 12.0
    out[1] = w[1] + 0.5 * c1 + (theta[2] * c0 - theta[0] * c2) / 12.0
    out[2] = w[2] + 0.5 * c2 + (theta[0] * c1 - theta[1] * c0) / 12.0


@inline
def _check(bad, p_norm):
    """Failure code of a step: ``bad`` (a state entry not finite or beyond HUGE), or a quaternion norm that left 1."""
    if bad:
        return FAIL_NONFINITE
    if abs(p_norm - 1.0) > QUATERNION_TOL:
        return FAIL_QUATERNION
    return FAIL_NONE


@jit
def rk4_loop(rhs, y0, h, nsteps, every, lie, out, model):
    """Fixed-step RK4 of a free body (no loads); rows of ``out`` every ``every`` steps (row 0: y0); ``rhs``:
    rhs_into's address (``rhs_address``).

    ``lie`` False: classical RK4 on the quaternion, normalised after each
    step. True: RKMK4, the quaternion advanced by ``p_n exp(Theta)`` with the
    stage rotation vectors mapped through dexp^-1, so |p| = 1 to round-off.
    Stage 1 is evaluated at y itself (Theta = 0, dexp^-1 = 1); the steps
    (``_rk4_steps``) allocate nothing. Returns (steps done, failure code).
    """
    n = y0.shape[0]
    y = y0.copy()
    store_row(out, 0, y)
    return _rk4_steps(rhs, y, h, nsteps, every, lie, out, model, np.zeros(3), np.zeros((n - N_ROT) // 2), np.empty(n),
                      np.empty((4, n)), np.zeros((4, 3)), np.zeros(3))


@bare
def _rk4_steps(rhs, y, h, nsteps, every, lie, out, model, zero3, zf, ys, k, th, theta):
    """``rk4_loop``'s steps from y (advanced in place) in its workspace (ys, k, th, theta)."""
    n = y.shape[0]
    for step in range(nsteps):
        call_rhs(rhs, y, k[0], model, zero3, zf, FREE[0], zero3, zero3)
        for j in range(3):
            th[0, j] = y[4 + j]
        for i in range(1, 4):
            c = h if i == 3 else 0.5 * h
            for j in range(n):
                ys[j] = y[j] + c * k[i - 1, j]
            if lie:
                for j in range(3):
                    theta[j] = c * th[i - 1, j]
                _rotate_by(y, theta, ys)
            call_rhs(rhs, ys, k[i], model, zero3, zf, FREE[0], zero3, zero3)
            if lie:
                _dexpinv(theta, ys[4:7], th[i])
        bad = False
        for j in range(4, n):
            v = y[j] + h / 6.0 * (k[0, j] + 2.0 * k[1, j] + 2.0 * k[2, j] + k[3, j])
            bad |= not abs(v) <= HUGE  # NaN compares false
            y[j] = v
        if lie:
            for j in range(3):
                theta[j] = h / 6.0 * (th[0, j] + 2.0 * th[1, j] + 2.0 * th[2, j] + th[3, j])
            _rotate_by(y, theta, y)
        else:
            for j in range(4):
                y[j] += h / 6.0 * (k[0, j] + 2.0 * k[1, j] + 2.0 * k[2, j] + k[3, j])
        norm = np.sqrt(y[0] ** 2 + y[1] ** 2 + y[2] ** 2 + y[3] ** 2)
        bad |= not norm <= HUGE
        if not lie and norm > 0.0:  # |p| = 0 is a quaternion failure, as in integrate._rk4_step
            for j in range(4):
                y[j] /= norm
        code = _check(bad, norm)
        if code != FAIL_NONE:
            return step + 1, code
        if (step + 1) % every == 0:
            store_row(out, (step + 1) // every, y)
    return nsteps, FAIL_NONE
