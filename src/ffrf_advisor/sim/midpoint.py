"""The implicit midpoint rule compiled around the compiled right-hand side (theory section 10).

``Y = y + h f(t + h/2, (y + Y)/2)`` solved by a simplified Newton method
with the matrix ``1 - h/2 J``, J the forward-difference Jacobian of f (one
evaluation per state entry), from the Euler predictor. The q rows of f
are q' itself, so their equations are linear and Newton's first
correction solves them exactly: from then on ``Y_q = y_q + h/2 (y_q' +
Y_q')`` and ``dq = h/2 dq'``. So Newton runs on ``(p, w, q')`` alone, 7 +
nf unknowns instead of 7 + 2 nf, with the Schur complement of the q rows
``S = 1 - h/2 J_rr - h^2/4 J_rq`` (r: the other rows and columns; the
column of q_l added to that of q_l'); the first correction also carries
the predictor's q residual ``r_q`` (right-hand side ``r_r + h/2 J_rq r_q``,
``dq = r_q + h/2 dq'``). The iterates are those of Newton's method on the
full state, and a product with S^-1 costs a third of one with the full
inverse. S is inverted once by LU with partial pivoting (an iteration
then costs one matrix-vector product: a kept matrix serves many), kept
from step to step as implicit codes keep theirs (Hairer and Wanner,
Solving ODEs II, IV.8): J is taken again at the start of the next step
when a step's iteration contracted by less than ``THETA_REFRESH`` per
iteration, and at once, the step restarted, when an iteration on a kept J
grows, overflows or runs out of iterations (on a fresh J it runs to
``NEWTON_MAX``). The iteration stops when the last correction is below
``NEWTON_TOL (1 + |Y|)``; the fixed point, and so the step, is the same
whichever J drove the iteration (to that tolerance). The iterates of the
Python reference ``integrate._MidpointStepper``, Newton on the full state
with the full inverse (the tests compare the two: the same evaluations,
the states to round-off), without a Python call per evaluation.
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
def _full(k, nf):
    """The state index of entry k of the reduced unknowns (p, w, q'): q' follows w past the nf q entries."""
    return k if k < 7 else k + nf


@bare
def _newton_inverse(rhs, tm, y, h, f0, model, prog, fext, scratch, M, piv, W, Jq, fj, ym):
    """W = S^-T, S the simplified-Newton matrix 1 - h/2 J on (p, w, q') with q eliminated (module docstring), J
    the forward-difference Jacobian of f at (tm, y) (f0 = f(tm, y)), and Jq = J_rq (its q columns); LU with
    partial pivoting in M; stored transposed, so applying it is a sum of contiguous columns (``_apply``)."""
    n, m = y.shape[0], M.shape[0]
    nf = n - m
    for i in range(m):
        for j in range(m):
            M[i, j] = 0.0
        M[i, i] = 1.0
    for j in range(n):
        d = FD_STEP * max(1.0, abs(y[j]))
        for i in range(n):
            ym[i] = y[i]
        ym[j] += d
        rhs_loaded(rhs, tm, ym, fj, model, prog, fext, scratch)
        q_column = 7 <= j < 7 + nf  # joins the column of its q' (reduced index j): dq = h/2 dq'
        c = j if j < 7 + nf else j - nf
        scale = -0.25 * h * h / d if q_column else -0.5 * h / d
        for i in range(m):
            fi = _full(i, nf)
            M[i, c] += scale * (fj[fi] - f0[fi])
            if q_column:
                Jq[i, j - 7] = (fj[fi] - f0[fi]) / d
    _lu(M, piv)
    for j in range(m):
        for i in range(m):
            fj[i] = 0.0
        fj[j] = 1.0
        _lu_solve(M, piv, fj[:m])
        for i in range(m):
            W[j, i] = fj[i]


@bare
def _apply(W, r, x):
    """x = W^T r (W from ``_newton_inverse``: x = S^-1 r)."""
    n = r.shape[0]
    for i in range(n):
        x[i] = 0.0
    for j in range(n):
        rj = r[j]
        Wj = W[j]
        for i in range(n):
            x[i] += Wj[i] * rj


@bare
def _newton(rhs, tm, y, h, Y, f0, model, prog, fext, scratch, W, Jq, fj, ym, R, kept):
    """Y from the Euler predictor by the simplified Newton iteration on (p, w, q') with the inverse W and Jq of
    ``_newton_inverse`` (module docstring):
    (code, iterations, largest ratio of successive corrections). ``kept``: W is from an earlier step, and a
    correction that grows ends the iteration (DIVERGING: the caller takes J again); on a fresh W it goes on to
    NEWTON_MAX."""
    n, m = y.shape[0], W.shape[0]
    nf = n - m
    for i in range(n):
        Y[i] = y[i] + h * f0[i]
    theta, last = 0.0, np.inf
    r, rq = ym[:m], ym[m:]
    for it in range(NEWTON_MAX):
        for i in range(n):
            ym[i] = 0.5 * (y[i] + Y[i])
        rhs_loaded(rhs, tm, ym, fj, model, prog, fext, scratch)
        for i in range(7):
            r[i] = Y[i] - y[i] - h * fj[i]
        for i in range(7, m):
            r[i] = Y[i + nf] - y[i + nf] - h * fj[i + nf]
        if it == 0:  # the predictor's q rows: r_q = Y_q - y_q - h q'_mid, solved with the rest
            for l in range(nf):
                rq[l] = Y[7 + l] - y[7 + l] - h * fj[7 + l]
                for i in range(m):
                    r[i] += 0.5 * h * Jq[i, l] * rq[l]
        _apply(W, r, R)
        dn, yn = 0.0, 0.0
        for i in range(7):
            Y[i] -= R[i]
            dn += R[i] * R[i]
            yn += Y[i] * Y[i]
        for l in range(nf):
            v = 7 + nf + l
            Y[v] -= R[7 + l]
            Y[7 + l] = y[7 + l] + 0.5 * h * (y[v] + Y[v])
            dq = 0.5 * h * R[7 + l] + (rq[l] if it == 0 else 0.0)
            dn += R[7 + l] * R[7 + l] + dq * dq
            yn += Y[v] * Y[v] + Y[7 + l] * Y[7 + l]
        if not np.isfinite(yn):  # a non-finite entry, or only an overflowing sum
            for i in range(n):
                if not np.isfinite(Y[i]):
                    return NOT_FINITE, it + 1, theta
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
def _step(rhs, t, y, h, Y, fresh, model, prog, fext, scratch, M, piv, W, Jq, f0, fj, ym, R):
    """One midpoint step from y into Y, J taken at its start when ``fresh`` (else M is kept from an earlier
    step, and taken here only if the iteration on it fails): (failure code, evaluations, whether the next step
    takes J again). Flags reach the callees as runtime values (``fresh``, False where the retry passes it):
    numba would compile a callee once more for a literal True or False."""
    n = y.shape[0]
    tm = t + 0.5 * h
    rhs_loaded(rhs, tm, y, f0, model, prog, fext, scratch)
    nfev = 1
    if fresh:
        _newton_inverse(rhs, tm, y, h, f0, model, prog, fext, scratch, M, piv, W, Jq, fj, ym)
        nfev += n
    code, iterations, theta = _newton(rhs, tm, y, h, Y, f0, model, prog, fext, scratch, W, Jq, fj, ym, R, not fresh)
    nfev += iterations
    if not fresh and code != OK and code != QUATERNION:
        _newton_inverse(rhs, tm, y, h, f0, model, prog, fext, scratch, M, piv, W, Jq, fj, ym)
        code, iterations, theta = _newton(rhs, tm, y, h, Y, f0, model, prog, fext, scratch, W, Jq, fj, ym, R, fresh)
        nfev += n + iterations
    return code, nfev, theta > THETA_REFRESH


@jit
def midpoint_loop(rhs, y0, h, nsteps, every, out, model, prog, fext):
    """``nsteps`` midpoint steps of size h from y0; rows of ``out`` every ``every`` steps (row 0: y0); ``rhs``: the
    right-hand side's address (kernels.rhs_address). Returns (steps done, evaluations, failure code); the failed
    step's state is the last row written."""
    n = y0.shape[0]
    scratch = (np.empty(3), np.empty(3), np.empty(3))
    m = (n + 7) // 2
    M, piv, W = np.empty((m, m)), np.empty(m, dtype=np.int64), np.empty((m, m))
    Jq = np.empty((m, (n - 7) // 2))
    f0, fj, ym, R = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    y, Y = y0.copy(), np.empty(n)
    store_row(out, 0, y)
    return _steps(rhs, y, Y, h, nsteps, every, out, model, prog, fext, scratch, M, piv, W, Jq, f0, fj, ym, R)


@bare
def _steps(rhs, y, Y, h, nsteps, every, out, model, prog, fext, scratch, M, piv, W, Jq, f0, fj, ym, R):
    """``midpoint_loop``'s steps from y (advanced in place) in its workspace; its return values."""
    n = y.shape[0]
    nfev, fresh = 0, nsteps > 0  # True where a step is taken, as a runtime value (see _step)
    for step in range(nsteps):
        code, evaluations, fresh = _step(rhs, step * h, y, h, Y, fresh, model, prog, fext, scratch, M, piv, W, Jq, f0,
                                         fj, ym, R)
        nfev += evaluations
        if code != OK:
            return step + 1, nfev, code
        for i in range(n):
            y[i] = Y[i]
        if (step + 1) % every == 0:
            store_row(out, (step + 1) // every, y)
    return nsteps, nfev, OK
