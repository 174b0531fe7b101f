"""The implicit midpoint rule compiled around the compiled right-hand side (theory section 10).

``Y = y + h f(t + h/2, (y + Y)/2)`` solved by a simplified Newton method
with the matrix ``1 - h/2 J``, J the forward-difference Jacobian of f (one
evaluation per state entry), inverted once by LU with partial pivoting (an
iteration then costs one matrix-vector product: a kept matrix serves
many), kept
from step to step as implicit codes keep theirs (Hairer and Wanner, Solving
ODEs II, IV.8): J is taken again at the start of the next step when a step's
iteration contracted by less than ``THETA_REFRESH`` per iteration, and at
once, the step restarted, when an iteration on a kept J grows, overflows
or runs out of iterations (on a fresh J it runs to ``NEWTON_MAX``). The iteration stops when the last correction is
below ``NEWTON_TOL (1 + |Y|)``; the fixed point, and so the step, is the
same whichever J drove the iteration (to that tolerance). The same
algorithm as the Python reference ``integrate._MidpointStepper`` (the tests
compare the two), without a Python call per evaluation.
"""
from __future__ import annotations

import numpy as np

from .kernels import HUGE, QUATERNION_TOL, bare, jit, rhs_loaded, store_row

NEWTON_TOL = 1e-12
NEWTON_MAX = 20
THETA_REFRESH = 0.1  # a step whose corrections shrank by less than this per iteration: J taken again next step
FD_STEP = 1e-7  # relative forward-difference step of the Jacobian
OK, NOT_FINITE, QUATERNION, NO_NEWTON, DIVERGING = 0, 1, 2, 3, 4


@bare
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


@bare
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


@bare
def _newton_inverse(tm, y, h, f0, model, prog, fext, scratch, M, piv, W, fj, ym):
    """W = (1 - h/2 J)^-T, J the forward-difference Jacobian of f at (tm, y) (f0 = f(tm, y)), by LU with partial
    pivoting in M; stored transposed, so applying it is a sum of contiguous columns (``_apply``)."""
    n = y.shape[0]
    for j in range(n):
        d = FD_STEP * max(1.0, abs(y[j]))
        for i in range(n):
            ym[i] = y[i]
        ym[j] += d
        rhs_loaded(tm, ym, fj, model, prog, fext, scratch)
        for i in range(n):
            M[i, j] = -0.5 * h * (fj[i] - f0[i]) / d
        M[j, j] += 1.0
    _lu(M, piv)
    for j in range(n):
        for i in range(n):
            fj[i] = 0.0
        fj[j] = 1.0
        _lu_solve(M, piv, fj)
        for i in range(n):
            W[j, i] = fj[i]


@bare
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


@bare
def _newton(tm, y, h, Y, f0, model, prog, fext, scratch, W, fj, ym, R, kept):
    """Y from the Euler predictor by the simplified Newton iteration with the inverse W of ``_newton_inverse``:
    (code, iterations, largest ratio of successive corrections). ``kept``: W is from an earlier step, and a
    correction that grows ends the iteration (DIVERGING: the caller takes J again); on a fresh W it goes on to
    NEWTON_MAX."""
    n = y.shape[0]
    for i in range(n):
        Y[i] = y[i] + h * f0[i]
    theta, last = 0.0, np.inf
    for it in range(NEWTON_MAX):
        for i in range(n):
            ym[i] = 0.5 * (y[i] + Y[i])
        rhs_loaded(tm, ym, fj, model, prog, fext, scratch)
        for i in range(n):
            ym[i] = Y[i] - y[i] - h * fj[i]
        _apply(W, ym, R)
        dn, yn = 0.0, 0.0
        for i in range(n):
            Y[i] -= R[i]
            if not np.isfinite(Y[i]):
                return NOT_FINITE, it + 1, theta
            dn += R[i] * R[i]
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


@bare
def _step(t, y, h, Y, fresh, model, prog, fext, scratch, M, piv, W, f0, fj, ym, R):
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
    code, iterations, theta = _newton(tm, y, h, Y, f0, model, prog, fext, scratch, W, fj, ym, R, not fresh)
    nfev += iterations
    if not fresh and code != OK and code != QUATERNION:
        _newton_inverse(tm, y, h, f0, model, prog, fext, scratch, M, piv, W, fj, ym)
        code, iterations, theta = _newton(tm, y, h, Y, f0, model, prog, fext, scratch, W, fj, ym, R, False)
        nfev += n + iterations
    return code, nfev, theta > THETA_REFRESH


@jit
def midpoint_loop(y0, h, nsteps, every, out, model, prog, fext):
    """``nsteps`` midpoint steps of size h from y0; rows of ``out`` every ``every`` steps (row 0: y0).
    Returns (steps done, evaluations, failure code); the failed step's state is the last row written."""
    n = y0.shape[0]
    scratch = (np.empty(3), np.empty(3), np.empty(3))
    M, piv, W = np.empty((n, n)), np.empty(n, dtype=np.int64), np.empty((n, n))
    f0, fj, ym, R = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    y, Y = y0.copy(), np.empty(n)
    out[0] = y
    return _steps(y, Y, h, nsteps, every, out, model, prog, fext, scratch, M, piv, W, f0, fj, ym, R)


@bare
def _steps(y, Y, h, nsteps, every, out, model, prog, fext, scratch, M, piv, W, f0, fj, ym, R):
    """``midpoint_loop``'s steps from y (advanced in place) in its workspace; its return values."""
    n = y.shape[0]
    nfev, fresh = 0, True
    for step in range(nsteps):
        code, evaluations, fresh = _step(step * h, y, h, Y, fresh, model, prog, fext, scratch, M, piv, W, f0, fj,
                                         ym, R)
        nfev += evaluations
        if code != OK:
            return step + 1, nfev, code
        for i in range(n):
            y[i] = Y[i]
        if (step + 1) % every == 0:
            store_row(out, (step + 1) // every, y)
    return nsteps, nfev, OK
