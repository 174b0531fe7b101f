"""Compiled (numba) right-hand side and fixed-step RK4 loops: the equations of sim.equations (theory section 5).

Python-level loops around numpy cost a few microseconds per small array
operation, which is more than the whole right-hand side of a 10-mode body;
numba (LLVM, the usual JIT compiler of the scientific Python stack, kept on
PyPI with wheels for current numpy) compiles these loops to machine code.
Only the simulator imports this module, so ``analyze`` does not pay for the
compiler. Flags follow terms.IDS: gyro0 cf1 inertia_lin cor1 inertia_quad
cf2 cor_quad coupling cor_coupling geo_stiff.
"""
from __future__ import annotations

import numba as nb
import numpy as np

CF1, INERTIA_LIN, COR1, INERTIA_QUAD, CF2, COR_QUAD, COUPLING, COR_COUPLING, GEO_STIFF = range(1, 10)
FAIL_NONE, FAIL_NONFINITE, FAIL_QUATERNION = 0, 1, 2
QUATERNION_TOL = 1e-2  # |p| - 1 after one step beyond which the step has failed
HUGE = 1e150           # any state entry beyond this counts as overflow
SYM_K = np.array([0, 1, 2, 0, 0, 1])
SYM_L = np.array([0, 1, 2, 1, 2, 2])

# Reassociation and contraction (FMA) let LLVM vectorise the dot products; results change at round-off
# only. No 'nnan'/'ninf': the failure checks rely on isfinite.
FASTMATH = {"reassoc", "contract"}
jit = nb.njit(cache=True, nogil=True, fastmath=FASTMATH)
inline = nb.njit(cache=True, nogil=True, fastmath=FASTMATH, inline="always")  # small helpers, inlined


@inline
def _solve3(A, b, x):
    """x = A^-1 b for a 3 x 3 matrix (adjugate; the matrices here are symmetric positive definite)."""
    c00 = A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1]
    c01 = A[1, 2] * A[2, 0] - A[1, 0] * A[2, 2]
    c02 = A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0]
    det = A[0, 0] * c00 + A[0, 1] * c01 + A[0, 2] * c02
    c10 = A[0, 2] * A[2, 1] - A[0, 1] * A[2, 2]
    c11 = A[0, 0] * A[2, 2] - A[0, 2] * A[2, 0]
    c12 = A[0, 1] * A[2, 0] - A[0, 0] * A[2, 1]
    c20 = A[0, 1] * A[1, 2] - A[0, 2] * A[1, 1]
    c21 = A[0, 2] * A[1, 0] - A[0, 0] * A[1, 2]
    c22 = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
    x[0] = (c00 * b[0] + c10 * b[1] + c20 * b[2]) / det
    x[1] = (c01 * b[0] + c11 * b[1] + c21 * b[2]) / det
    x[2] = (c02 * b[0] + c12 * b[1] + c22 * b[2]) / det


@inline
def _cross_sub(a, b, out):
    """out -= a x b."""
    out[0] -= a[1] * b[2] - a[2] * b[1]
    out[1] -= a[2] * b[0] - a[0] * b[2]
    out[2] -= a[0] * b[1] - a[1] * b[0]


@jit
def workspace(nf):
    """Scratch arrays of one right-hand side (J, M, G, S: 3 x 3; fr, b: 3; P: 3 x 3 x nf; C: 3 x nf),
    so that an evaluation allocates nothing."""
    return (np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty(3), np.empty(3),
            np.empty((3, 3, nf)), np.empty((3, nf)))


@inline
def _add_linear_inertia(Ibar, x, C1, J):
    """J += 2 tr(C1) I - C1 - C1^T with C1[k, l] = Ibar[k, l] . x: the W1 Qf of theory section 3."""
    nf = x.shape[0]
    for k in range(3):
        for l in range(3):
            s = 0.0
            for r in range(nf):
                s += Ibar[k, l, r] * x[r]
            C1[k, l] = s
    tr = C1[0, 0] + C1[1, 1] + C1[2, 2]
    for k in range(3):
        J[k, k] += 2.0 * tr
        for l in range(3):
            J[k, l] -= C1[k, l] + C1[l, k]


@inline
def _add_quadratic_inertia(P, x, scale, G, J):
    """J += scale (tr(G) I - G) with G[a, b] = x . (P[a, b] + P[b, a]), P[a, b] = Sbar[a, b] q."""
    for a in range(3):
        for b in range(3):
            s = 0.0
            for r in range(x.shape[0]):
                s += x[r] * (P[a, b, r] + P[b, a, r])
            G[a, b] = s
    tr = G[0, 0] + G[1, 1] + G[2, 2]
    for a in range(3):
        J[a, a] += scale * tr
        for b in range(3):
            J[a, b] -= scale * G[a, b]


@inline
def _zero3x3(A):
    for k in range(3):
        for l in range(3):
            A[k, l] = 0.0


@inline
def _sub_matvec(A, w, out):
    """out -= A w (3 x 3)."""
    for k in range(3):
        for l in range(3):
            out[k] -= A[k, l] * w[l]


@inline
def _add_centrifugal(B, w, ff):
    """ff[r] += |w|^2 sum_m B[m, m, r] - sum_kl w_k w_l B[k, l, r] (cf1: B = Ibar; cf2: B[k, l] = Sbar[k, l] q)."""
    ww = w[0] * w[0] + w[1] * w[1] + w[2] * w[2]
    for r in range(ff.shape[0]):
        s = ww * (B[0, 0, r] + B[1, 1, r] + B[2, 2, r])
        for k in range(3):
            for l in range(3):
                s -= w[k] * w[l] * B[k, l, r]
        ff[r] += s


@inline
def _block_products(Sbar, q, P):
    """P[a, b] = Sbar[a, b] q (3, 3, nf): the nine block products all W2 terms use."""
    nf = q.shape[0]
    for a in range(3):
        for b in range(3):
            for r in range(nf):
                s = 0.0
                for t in range(nf):
                    s += Sbar[a, b, r, t] * q[t]
                P[a, b, r] = s


@inline
def _coupling(W3k, q, C):
    """C = Qf^T W3: C[k] = W3k[k]^T q (3 x nf)."""
    nf = q.shape[0]
    for k in range(3):
        for s in range(nf):
            C[k, s] = 0.0
    for k in range(3):
        for r in range(nf):
            qr = q[r]
            for s in range(nf):
                C[k, s] += W3k[k, r, s] * qr


@inline
def _coupling_from_products(P, C):
    """C[k] = sum_ab eps_kab Sbar[a, b]^T q = sum_ab eps_kab P[b, a], free once P is known."""
    for s in range(C.shape[1]):
        C[0, s] = P[2, 1, s] - P[1, 2, s]
        C[1, s] = P[0, 2, s] - P[2, 0, s]
        C[2, s] = P[1, 0, s] - P[0, 1, s]


@inline
def _geometric_stiffness(G, w, q, ff):
    """ff -= G(w) q with G(w) = sum_kl w_k w_l G_kl, the six symmetric pairs stored once."""
    nf = q.shape[0]
    for i in range(6):
        k, l = SYM_K[i], SYM_L[i]
        c = w[k] * w[l] * (1.0 if k == l else 2.0)
        for r in range(nf):
            s = 0.0
            for t in range(nf):
                s += G[i, r, t] * q[t]
            ff[r] -= c * s


@inline
def _solve_schur(J, C, fr, ff, S, b, wd):
    """w' from (I_TT - C C^T) w' = fr - C ff (the Schur complement on the 3 x 3 block)."""
    nf = ff.shape[0]
    for k in range(3):
        b[k] = fr[k]
        for s in range(nf):
            b[k] -= C[k, s] * ff[s]
        for l in range(3):
            acc = J[k, l]
            for s in range(nf):
                acc -= C[k, s] * C[l, s]
            S[k, l] = acc
    _solve3(S, b, wd)


@jit
def rhs_into(y, out, flags, I0, Ibar, Sbar, W3k, lam, dmp, G, tau, fext, prescribed, wp, wdp, work):
    """dy/dt of ``y = [p, w, q, q']`` into ``out``; with ``prescribed`` w = wp and w' = wdp are given."""
    nf = lam.shape[0]
    q = y[7:7 + nf]
    qd = y[7 + nf:7 + 2 * nf]
    w = wp if prescribed else y[4:7]
    J, M, Gq, S, fr, b, P, C = work
    for k in range(3):
        fr[k] = tau[k]
        for l in range(3):
            J[k, l] = I0[k, l]
    ff = out[7 + nf:7 + 2 * nf]
    for r in range(nf):
        ff[r] = fext[r] - lam[r] * q[r] - dmp[r] * qd[r]
    if flags[INERTIA_LIN]:
        _add_linear_inertia(Ibar, q, M, J)
    if flags[COR1]:
        _zero3x3(S)
        _add_linear_inertia(Ibar, qd, M, S)
        _sub_matvec(S, w, fr)
    if flags[CF1]:
        _add_centrifugal(Ibar, w, ff)
    if flags[INERTIA_QUAD] or flags[CF2] or flags[COR_QUAD]:
        _block_products(Sbar, q, P)
        if flags[INERTIA_QUAD]:
            _add_quadratic_inertia(P, q, 0.5, Gq, J)
        if flags[COR_QUAD]:
            _zero3x3(S)
            _add_quadratic_inertia(P, qd, 1.0, Gq, S)
            _sub_matvec(S, w, fr)
        if flags[CF2]:
            _add_centrifugal(P, w, ff)
    if (flags[COUPLING] or flags[COR_COUPLING]) and (flags[INERTIA_QUAD] or flags[CF2] or flags[COR_QUAD]):
        _coupling_from_products(P, C)
    elif flags[COUPLING] or flags[COR_COUPLING]:
        _coupling(W3k, q, C)
    if flags[COR_COUPLING]:
        for k in range(3):
            b[k] = 0.0
            for s in range(nf):
                b[k] += C[k, s] * qd[s]
        _cross_sub(w, b, fr)
        for k in range(3):
            for r in range(nf):
                c = 2.0 * w[k] * qd[r]
                for s in range(nf):
                    ff[s] -= c * W3k[k, r, s]
    if flags[GEO_STIFF]:
        _geometric_stiffness(G, w, q, ff)
    for k in range(3):  # gyroscopic term with the set's I_TT
        b[k] = J[k, 0] * w[0] + J[k, 1] * w[1] + J[k, 2] * w[2]
    _cross_sub(w, b, fr)
    wd = out[4:7]
    if prescribed:
        for k in range(3):
            wd[k] = wdp[k]
    elif flags[COUPLING]:
        _solve_schur(J, C, fr, ff, S, b, wd)
    else:
        _solve3(J, fr, wd)
    if flags[COUPLING]:
        for s in range(nf):
            ff[s] -= C[0, s] * wd[0] + C[1, s] * wd[1] + C[2, s] * wd[2]
    for r in range(nf):
        out[7 + r] = qd[r]
    p = y[0:4]
    out[0] = -0.5 * (p[1] * w[0] + p[2] * w[1] + p[3] * w[2])
    out[1] = 0.5 * (p[0] * w[0] + p[2] * w[2] - p[3] * w[1])
    out[2] = 0.5 * (p[0] * w[1] + p[3] * w[0] - p[1] * w[2])
    out[3] = 0.5 * (p[0] * w[2] + p[1] * w[1] - p[2] * w[0])


@jit
def loads_at(t, prog, tau, w, wd):
    """Torque and prescribed (w, w') at t from ``prog`` = [tau0 (3), pulse, W (3), ramp, prescribed flag]:
    tau = tau0 sin^2(pi t / pulse) for t < pulse (pulse = inf: tau0), w = W profile(t / ramp) (theory 10)."""
    pulse, ramp = prog[3], prog[7]
    f = 1.0 if pulse == np.inf else (np.sin(np.pi * t / pulse) ** 2 if t < pulse else 0.0)
    if ramp > 0.0 and t < ramp:
        g = (t - ramp / (2.0 * np.pi) * np.sin(2.0 * np.pi * t / ramp)) / ramp
        gd = (1.0 - np.cos(2.0 * np.pi * t / ramp)) / ramp
    else:
        g, gd = 1.0, 0.0
    for k in range(3):
        tau[k] = prog[k] * f
        w[k] = prog[4 + k] * g
        wd[k] = prog[4 + k] * gd


@jit
def rhs_loaded(t, y, out, model, prog, fext, scratch):
    """``rhs_into`` at time t with the loads of the packed LoadProgram ``prog`` (sim.loads) and constant modal
    forces ``fext``; ``model`` = (flags, I0, Ibar, Sbar, W3k, lam, dmp, G, workspace), ``scratch``: three 3-vectors."""
    flags, I0, Ibar, Sbar, W3k, lam, dmp, G, work = model
    tau, w, wd = scratch
    loads_at(t, prog, tau, w, wd)
    rhs_into(y, out, flags, I0, Ibar, Sbar, W3k, lam, dmp, G, tau, fext, prog[8] != 0.0, w, wd, work)


@jit
def _qmul(a, b, out):
    """out = a * b (quaternions, scalar first)."""
    out[0] = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3]
    out[1] = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2]
    out[2] = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1]
    out[3] = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]


@jit
def _rotate_by(p, theta, out):
    """out = p * exp(theta): the body turned by the rotation vector theta (body frame)."""
    angle = np.sqrt(theta[0] ** 2 + theta[1] ** 2 + theta[2] ** 2)
    e = np.empty(4)
    e[0] = np.cos(0.5 * angle)
    f = 0.5 if angle < 1e-8 else np.sin(0.5 * angle) / angle
    e[1], e[2], e[3] = f * theta[0], f * theta[1], f * theta[2]
    _qmul(p, e, out)


@jit
def _dexpinv(theta, w, out):
    """Theta' = w + 1/2 theta x w + 1/12 theta x (theta x w): p = p_n exp(theta), p' = p (0, w) / 2 (RKMK4)."""
    c = np.cross(theta, w)
    cc = np.cross(theta, c)
    for k in range(3):
        out[k] = w[k] + 0.5 * c[k] + cc[k] / 12.0


@jit
def _check(y, p_norm):
    """Failure code of a step: non-finite or overflowing state, or a quaternion norm that left 1."""
    for v in y:
        if not np.isfinite(v) or abs(v) > HUGE:
            return FAIL_NONFINITE
    if abs(p_norm - 1.0) > QUATERNION_TOL:
        return FAIL_QUATERNION
    return FAIL_NONE


@jit
def rk4_loop(y0, h, nsteps, every, lie, out, flags, I0, Ibar, Sbar, W3k, lam, dmp, G):
    """Fixed-step RK4 of a free body (no loads); rows of ``out`` every ``every`` steps (row 0: y0).

    ``lie`` False: classical RK4 on the quaternion, normalised after each
    step. True: RKMK4, the quaternion advanced by ``p_n exp(Theta)`` with the
    stage rotation vectors mapped through dexp^-1, so |p| = 1 to round-off.
    Returns (steps done, failure code).
    """
    n = y0.shape[0]
    zero3, zf = np.zeros(3), np.zeros(lam.shape[0])
    work = workspace(lam.shape[0])
    y = y0.copy()
    ys = np.empty(n)
    k = np.empty((4, n))
    th = np.zeros((4, 3))
    theta = np.zeros(3)
    a = (0.0, 0.5, 0.5, 1.0)
    out[0] = y
    for step in range(nsteps):
        for i in range(4):
            for j in range(n):
                ys[j] = y[j] if i == 0 else y[j] + a[i] * h * k[i - 1, j]
            if lie:
                for j in range(3):
                    theta[j] = 0.0 if i == 0 else a[i] * h * th[i - 1, j]
                _rotate_by(y[0:4], theta, ys[0:4])
            rhs_into(ys, k[i], flags, I0, Ibar, Sbar, W3k, lam, dmp, G, zero3, zf, False, zero3, zero3, work)
            if lie:
                _dexpinv(theta, ys[4:7], th[i])
        for j in range(4, n):
            y[j] += h / 6.0 * (k[0, j] + 2.0 * k[1, j] + 2.0 * k[2, j] + k[3, j])
        if lie:
            for j in range(3):
                theta[j] = h / 6.0 * (th[0, j] + 2.0 * th[1, j] + 2.0 * th[2, j] + th[3, j])
            _rotate_by(y[0:4].copy(), theta, y[0:4])
            norm = np.sqrt(y[0] ** 2 + y[1] ** 2 + y[2] ** 2 + y[3] ** 2)
        else:
            for j in range(4):
                y[j] += h / 6.0 * (k[0, j] + 2.0 * k[1, j] + 2.0 * k[2, j] + k[3, j])
            norm = np.sqrt(y[0] ** 2 + y[1] ** 2 + y[2] ** 2 + y[3] ** 2)
            for j in range(4):
                y[j] /= norm
        code = _check(y, norm)
        if code != FAIL_NONE:
            return step + 1, code
        if (step + 1) % every == 0:
            out[(step + 1) // every] = y
    return nsteps, FAIL_NONE
