"""The implicit midpoint rule compiled around the compiled right-hand side (theory section 10).

``Y = y + h f(t + h/2, (y + Y)/2)`` for ``y = (p, w, q, q')``. Its q rows are
linear, ``Q = q + h (q' + Q')/2`` (the right-hand side's q rows are q'
exactly), so Q follows from Q' and Newton works on the other unknowns
``Z = (p, w, q')``, 7 + nf of them instead of 7 + 2 nf: with ``J`` the
forward-difference Jacobian of f (one evaluation per state entry) the
simplified Newton matrix is ``1 - h/2 J_ZZ - h^2/4 J_Zq`` (``d(q + Q)/2 /
dQ' = h/4``), inverted once by LU with partial pivoting (an iteration
then costs one right-hand side and one matrix-vector product of that
size, a third of the full system's at 16 modes). The matrix is kept from
step to step as implicit codes keep theirs (Hairer and Wanner, Solving ODEs
II, IV.8): J is taken again at the start of the next step when a step's
iteration contracted by less than ``THETA_REFRESH`` per iteration, and at
once, the step restarted, when an iteration on a kept J grows, overflows
or runs out of iterations (on a fresh J it runs to ``NEWTON_MAX``). The
iteration stops when the last correction of Y (Q's included) is below
``NEWTON_TOL (1 + |Y|)``; the fixed point, and so the step, is the same
whichever J drove the iteration (to that tolerance). The same algorithm as
the Python reference ``integrate._MidpointStepper`` (the tests compare the
two), without a Python call per evaluation.
"""
from __future__ import annotations

import numpy as np

from .kernels import HUGE, QUATERNION_TOL, jit, rhs_loaded

NEWTON_TOL = 1e-12
NEWTON_MAX = 20
THETA_REFRESH = 0.1  # a step whose corrections shrank by less than this per iteration: J taken again next step
FD_STEP = 1e-7  # relative forward-difference step of the Jacobian
OK, NOT_FINITE, QUATERNION, NO_NEWTON, DIVERGING = 0, 1, 2, 3, 4


@jit
def _lu(A, piv):
    """A = P L U in place (Doolittle, partial pivoting); piv[i]: the row swapped with row i."""
    n = A.shape[0]
    for k in range(n):
        p = k
        for i in range(k + 1, n):
            if abs(A[i, k]) > abs(A[p, k]):
                p = i
        piv[k] = p
        if p != k:
            for j in range(n):
                A[k, j], A[p, j] = A[p, j], A[k, j]
        for i in range(k + 1, n):
            A[i, k] /= A[k, k]
            for j in range(k + 1, n):
                A[i, j] -= A[i, k] * A[k, j]


@jit
def _lu_solve(LU, piv, b):
    """x = A^-1 b in place, A = P L U from ``_lu`` (each row's sum in a local accumulator, so the compiler
    vectorises it)."""
    n = b.shape[0]
    for k in range(n):
        p = piv[k]
        b[k], b[p] = b[p], b[k]
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= LU[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= LU[i, j] * b[j]
        b[i] = s / LU[i, i]


@jit
def _reduced(a, nf):
    """The state index of unknown ``a`` of Z = (p, w, q'): p and w as they are, q'_r at 7 + nf + r."""
    return a if a < 7 else a + nf


@jit
def _newton_inverse(tm, y, h, f0, model, prog, fext, scratch, M, piv, W, fj, ym):
    """W = (1 - h/2 J_ZZ - h^2/4 J_Zq)^-T (module docstring), J the forward-difference Jacobian of f at (tm, y)
    (f0 = f(tm, y)), by LU with partial pivoting in M; stored transposed, so applying it is a sum of contiguous
    columns (``_apply``). Column j of J enters column b of the matrix: p, w and q'_r as themselves (weight h/2),
    q_r into q'_r's (weight h^2/4, first)."""
    n, m = y.shape[0], M.shape[0]
    nf = n - m
    for a in range(m):
        for b in range(m):
            M[a, b] = 0.0
    for j in range(n):
        d = FD_STEP * max(1.0, abs(y[j]))
        for i in range(n):
            ym[i] = y[i]
        ym[j] += d
        rhs_loaded(tm, ym, fj, model, prog, fext, scratch)
        b, c = (j, 0.5 * h) if j < 7 else ((j, 0.25 * h * h) if j < 7 + nf else (j - nf, 0.5 * h))
        for a in range(m):
            i = _reduced(a, nf)
            M[a, b] -= c * (fj[i] - f0[i]) / d
    for a in range(m):
        M[a, a] += 1.0
    _lu(M, piv)
    for j in range(m):
        for i in range(m):
            fj[i] = 0.0
        fj[j] = 1.0
        _lu_solve(M, piv, fj[:m])
        for i in range(m):
            W[j, i] = fj[i]


@jit
def _apply(W, r, x):
    """x = W^T r (W from ``_newton_inverse``: x = (1 - h/2 J)^-1 r)."""
    n = r.shape[0]
    for i in range(n):
        x[i] = 0.0
    for j in range(n):
        rj = r[j]
        Wj = W[j]
        for i in range(n):
            x[i] += Wj[i] * rj


@jit
def _follow_q(y, h, Y, nf):
    """Q = q + h (q' + Q')/2: the q rows of the midpoint rule, exact."""
    for r in range(nf):
        Y[7 + r] = y[7 + r] + 0.5 * h * (y[7 + nf + r] + Y[7 + nf + r])


@jit
def _newton(tm, y, h, Y, f0, model, prog, fext, scratch, W, fj, ym, R, Rz, kept):
    """Y from the Euler predictor (Q following Q') by the simplified Newton iteration on Z = (p, w, q') with the
    inverse W of ``_newton_inverse``: (code, iterations, largest ratio of successive corrections). ``kept``: W is
    from an earlier step, and a correction that grows ends the iteration (DIVERGING: the caller takes J again);
    on a fresh W it goes on to NEWTON_MAX."""
    n, m = y.shape[0], W.shape[0]
    nf = n - m
    for i in range(n):
        Y[i] = y[i] + h * f0[i]
    _follow_q(y, h, Y, nf)
    theta, last = 0.0, np.inf
    for it in range(NEWTON_MAX):
        for i in range(n):
            ym[i] = 0.5 * (y[i] + Y[i])
        rhs_loaded(tm, ym, fj, model, prog, fext, scratch)
        for i in range(7):
            Rz[i] = Y[i] - y[i] - h * fj[i]
        for a in range(7, m):
            Rz[a] = Y[a + nf] - y[a + nf] - h * fj[a + nf]
        _apply(W, Rz, R)
        dz, dv = 0.0, 0.0
        for i in range(7):
            Y[i] -= R[i]
            dz += R[i] * R[i]
        for a in range(7, m):
            Y[a + nf] -= R[a]
            dv += R[a] * R[a]
        dn = dz + (1.0 + 0.25 * h * h) * dv  # Q moves by h/2 of Q'
        _follow_q(y, h, Y, nf)
        yn = 0.0
        for i in range(n):
            if not np.isfinite(Y[i]):
                return NOT_FINITE, it + 1, theta
            yn += Y[i] * Y[i]
        dn = np.sqrt(dn)
        if it > 0:
            theta = max(theta, dn / last)
            if kept and dn >= last:
                return DIVERGING, it + 1, theta
        last = dn
        if dn <= NEWTON_TOL * (1.0 + np.sqrt(yn)):
            for i in range(n):
                if abs(Y[i]) > HUGE:
                    return NOT_FINITE, it + 1, theta
            norm = np.sqrt(Y[0] ** 2 + Y[1] ** 2 + Y[2] ** 2 + Y[3] ** 2)
            return (QUATERNION if abs(norm - 1.0) > QUATERNION_TOL else OK), it + 1, theta
    return NO_NEWTON, NEWTON_MAX, theta


@jit
def _step(t, y, h, Y, fresh, model, prog, fext, scratch, M, piv, W, f0, fj, ym, R, Rz):
    """One midpoint step from y into Y, J taken at its start when ``fresh`` (else M is kept from an earlier
    step, and taken here only if the iteration on it fails): (failure code, evaluations, whether the next step
    takes J again)."""
    n = y.shape[0]
    tm = t + 0.5 * h
    rhs_loaded(tm, y, f0, model, prog, fext, scratch)
    nfev = 1
    if fresh:
        _newton_inverse(tm, y, h, f0, model, prog, fext, scratch, M, piv, W, fj, ym)
        nfev += n
    code, iterations, theta = _newton(tm, y, h, Y, f0, model, prog, fext, scratch, W, fj, ym, R, Rz, not fresh)
    nfev += iterations
    if not fresh and code != OK and code != QUATERNION:
        _newton_inverse(tm, y, h, f0, model, prog, fext, scratch, M, piv, W, fj, ym)
        code, iterations, theta = _newton(tm, y, h, Y, f0, model, prog, fext, scratch, W, fj, ym, R, Rz, False)
        nfev += n + iterations
    return code, nfev, theta > THETA_REFRESH


@jit
def midpoint_loop(y0, h, nsteps, every, out, model, prog, fext):
    """``nsteps`` midpoint steps of size h from y0; rows of ``out`` every ``every`` steps (row 0: y0).
    Returns (steps done, evaluations, failure code); the failed step's state is the last row written."""
    n = y0.shape[0]
    m = n - (n - 7) // 2  # the unknowns (p, w, q')
    scratch = (np.empty(3), np.empty(3), np.empty(3))
    M, piv, W = np.empty((m, m)), np.empty(m, dtype=np.int64), np.empty((m, m))
    f0, fj, ym, R, Rz = np.empty(n), np.empty(n), np.empty(n), np.empty(m), np.empty(m)
    y, Y = y0.copy(), np.empty(n)
    out[0] = y
    nfev, fresh = 0, True
    for step in range(nsteps):
        code, evaluations, fresh = _step(step * h, y, h, Y, fresh, model, prog, fext, scratch, M, piv, W, f0, fj,
                                         ym, R, Rz)
        nfev += evaluations
        if code != OK:
            return step + 1, nfev, code
        for i in range(n):
            y[i] = Y[i]
        if (step + 1) % every == 0:
            out[(step + 1) // every] = y
    return nsteps, nfev, OK
