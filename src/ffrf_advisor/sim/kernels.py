"""Compiled (numba) right-hand side: the equations of sim.equations (theory section 5); the integrators around it
(sim.rk4, sim.dop853, sim.lawson, sim.midpoint) call it by its address.

Python-level loops around numpy cost a few microseconds per small array
operation, which is more than the whole right-hand side of a 10-mode body;
numba (LLVM, the usual JIT compiler of the scientific Python stack, kept on
PyPI with wheels for current numpy) compiles these loops to machine code.
Only the simulator imports this module, so ``analyze`` does not pay for the
compiler. Flags follow terms.IDS: gyro0 cf1 inertia_lin cor1 inertia_quad
cf2 cor_quad coupling cor_coupling geo_stiff. Sbar comes in the compact
strips of sim.model (about 4.5 nf^2 numbers): one pass over a strip of
four rows gives four dot products and the transpose's share, so the W2
and W3 terms read each stored number once per evaluation.
"""
from __future__ import annotations

import functools
from contextlib import contextmanager

import numba as nb
import numpy as np
from numba.core import cgutils, event
from numba.extending import intrinsic

from .model import N_ROT, STRIP, strip_start

CF1, INERTIA_LIN, COR1, INERTIA_QUAD, CF2, COR_QUAD, COUPLING, COR_COUPLING, GEO_STIFF = range(1, 10)
FAIL_NONE, FAIL_NONFINITE, FAIL_QUATERNION = 0, 1, 2
QUATERNION_TOL = 1e-2  # |p| - 1 after one step beyond which the step has failed
HUGE = 1e150           # any state entry beyond this counts as overflow
# FREE[0]: ``prescribed = False`` of rhs_into (a free body) as a value read at run time: numba types a literal
# False as its own type, and compiles a callee once more for each literal argument of a call (a literal False had
# cost a second compilation of the whole right-hand side, about 10 s, before it was called by address).
FREE = np.zeros(1, dtype=np.bool_)
SYM_K = np.array([0, 1, 2, 0, 0, 1])
SYM_L = np.array([0, 1, 2, 1, 2, 2])

# Reassociation and contraction (FMA) let LLVM vectorise the dot products; results change at round-off
# only. No 'nnan'/'ninf': the failure checks rely on isfinite.
FASTMATH = {"reassoc", "contract"}
jit = nb.njit(cache=True, nogil=True, fastmath=FASTMATH)
# Functions that allocate nothing are compiled without numba's reference counting (its runtime, NRT): every
# array view (y[7:7 + nf], K[s]) and every array taken out of a tuple (the model) otherwise costs an atomic
# increment and decrement of the array's owner, which were 43 % of a level-I DOP853 run (perf, 2026-11-26)
# and about 20 % of the full set's. Their arrays are borrowed from a caller that owns them (numpy's, or a
# ``jit`` function's allocations), so nothing needs counting; they must not allocate or return arrays.
bare = nb.njit(cache=True, nogil=True, fastmath=FASTMATH, _nrt=False)
# Small helpers and thin layers are inlined into their callers: numba links every function it calls into a
# compiled function and optimises and emits that code again, so each layer compiles its callees once more (the
# integrators call rhs_into itself by its address: ``call_rhs``). Large ones are not: LLVM's time grows faster than
# a function's size (the midpoint rule's steps with every layer inlined took 25 s to compile against 10 s).
inline = nb.njit(cache=True, nogil=True, fastmath=FASTMATH, inline="always")
_strip_start = inline(strip_start)


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
    """Scratch arrays of one right-hand side (J, M, G, S: 3 x 3; fr, b: 3; P: the block products of q and
    q', 2 x 3 x 3 x nf; C: C(q) and C(q'), 2 x 3 x nf), so that an evaluation allocates nothing."""
    return (np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty(3), np.empty(3),
            np.empty((2, 3, 3, nf)), np.empty((2, 3, nf)))


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
def _dot4_axpy(S, o, w, x, c, r, acc):
    """Four stored rows ``S[o + i w:o + (i + 1) w]`` (i < 4) against x[c:c + w]: returns their four dot products
    and adds ``sum_i row_i x[r + i]`` to acc[c:c + w] (rows past x's end are zero): one read of each entry
    serves a block's product and its transpose's."""
    n = x.shape[0]
    x0, x1, x2, x3 = x[r], x[min(r + 1, n - 1)], x[min(r + 2, n - 1)], x[min(r + 3, n - 1)]
    R0, R1, R2, R3 = S[o:o + w], S[o + w:o + 2 * w], S[o + 2 * w:o + 3 * w], S[o + 3 * w:o + 4 * w]
    xs, a = x[c:c + w], acc[c:c + w]
    s0 = s1 = s2 = s3 = 0.0
    for t in range(w):
        e0, e1, e2, e3, xt = R0[t], R1[t], R2[t], R3[t], xs[t]
        s0 += e0 * xt
        s1 += e1 * xt
        s2 += e2 * xt
        s3 += e3 * xt
        a[t] += e0 * x0 + e1 * x1 + e2 * x2 + e3 * x3
    return s0, s1, s2, s3


@inline
def _symmetric_products(diag, x, P):
    """P[k, k] = Sbar[k, k] x = U x + U^T x from the strips (sim.model.strips) of the upper halves U of the
    symmetric diagonal blocks (theory 3), diagonal halved."""
    n = x.shape[0]
    for k in range(3):
        Pk = P[k, k]
        Pk[:] = 0.0
        o = 0
        for r in range(0, n, STRIP):
            c = _strip_start(r, n, True)
            s = _dot4_axpy(diag[k], o, n - c, x, c, r, Pk)
            for i in range(min(STRIP, n - r)):
                Pk[r + i] += s[i]
            o += STRIP * (n - c)


@inline
def _pair_products(off, y, nv, P):
    """P[v, a, b] = off[k] x_v and P[v, b, a] = off[k]^T x_v for the cyclic (k, a, b), x_0 = q, x_1 = q' (the
    first ``nv``), off[k] in strips (sim.model.strips): with off[k] = Sbar[a, b] the six off-diagonal block
    products (Sbar[b, a] = Sbar[a, b]^T), each strip read from memory once for both vectors."""
    nf = (y.shape[0] - N_ROT) // 2
    for k in range(3):
        a, b = (k + 1) % 3, (k + 2) % 3
        P[:nv, b, a] = 0.0
        for r in range(0, nf, STRIP):
            for v in range(nv):
                x = y[N_ROT + v * nf:N_ROT + (v + 1) * nf]
                s = _dot4_axpy(off[k], r * nf, nf, x, 0, r, P[v, b, a])
                for i in range(min(STRIP, nf - r)):
                    P[v, a, b, r + i] = s[i]


@inline
def _four(x, t):
    """x[t:t + 4], zeros past the end."""
    n = x.shape[0]
    return (x[t], x[t + 1] if t + 1 < n else 0.0, x[t + 2] if t + 2 < n else 0.0, x[t + 3] if t + 3 < n else 0.0)


@inline
def _tall_products(tall, y, nv, P):
    """P[v] = every block product Sbar[a, b] x_v at once for x_0 = q, x_1 = q' (the first ``nv``):
    ``P[v].ravel() = sum_t tall[t] x_v[t]`` (sim.model.tall_blocks), four rows of tall per pass of contiguous
    multiply-adds of length 9 nf, each number read once for both vectors."""
    nf, n = tall.shape
    a0, a1 = P[0].reshape(n), P[1].reshape(n)
    q, qd = y[N_ROT:N_ROT + nf], y[N_ROT + nf:N_ROT + 2 * nf]
    a0[:] = 0.0
    a1[:] = 0.0
    for t in range(0, nf, 4):
        r0, r1, r2, r3 = tall[t], tall[min(t + 1, nf - 1)], tall[min(t + 2, nf - 1)], tall[min(t + 3, nf - 1)]
        p0, p1, p2, p3 = _four(q, t)
        if nv == 1:
            for j in range(n):
                a0[j] += r0[j] * p0 + r1[j] * p1 + r2[j] * p2 + r3[j] * p3
            continue
        d0, d1, d2, d3 = _four(qd, t)
        for j in range(n):
            e0, e1, e2, e3 = r0[j], r1[j], r2[j], r3[j]
            a0[j] += e0 * p0 + e1 * p1 + e2 * p2 + e3 * p3
            a1[j] += e0 * d0 + e1 * d1 + e2 * d2 + e3 * d3


@inline
def _coupling_from_products(P, C):
    """C[k] = W3k[k]^T x = sum_ab eps_kab Sbar[a, b]^T x = sum_ab eps_kab P[b, a] with P[a, b] = Sbar[a, b] x:
    the rows of C(x) = Qf(x)^T W3 (theory 3), free once the block products of x are known."""
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


@bare
def rhs_into(y, out, model, tau, fext, prescribed, wp, wdp):
    """dy/dt of ``y = [p, w, q, q']`` into ``out`` (theory 5); ``model`` = (flags, I0, Ibar, diag, off, tall, lam,
    dmp, G, workspace) as sim.integrate._compiled_model packs it; with ``prescribed`` w = wp and w' = wdp are given."""
    flags, I0, Ibar, diag, off, tall, lam, dmp, G, work = model
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
    w2 = flags[INERTIA_QUAD] or flags[CF2] or flags[COR_QUAD]
    w3 = flags[COUPLING] or flags[COR_COUPLING]
    if (w2 or w3) and tall.shape[0] > 0:
        _tall_products(tall, y, 2 if flags[COR_COUPLING] else 1, P)
    elif w2 or w3:
        if w2:
            _symmetric_products(diag, q, P[0])
        _pair_products(off, y, 2 if flags[COR_COUPLING] else 1, P)
    if flags[INERTIA_QUAD]:
        _add_quadratic_inertia(P[0], q, 0.5, Gq, J)
    if flags[COR_QUAD]:
        _zero3x3(S)
        _add_quadratic_inertia(P[0], qd, 1.0, Gq, S)
        _sub_matvec(S, w, fr)
    if flags[CF2]:
        _add_centrifugal(P[0], w, ff)
    if w3:
        _coupling_from_products(P[0], C[0])
    if flags[COR_COUPLING]:
        _coupling_from_products(P[1], C[1])
        for k in range(3):
            b[k] = 0.0
            for s in range(nf):
                b[k] += C[0, k, s] * qd[s]
        _cross_sub(w, b, fr)
        for s in range(nf):  # -2 W3^T Qf' w = -2 sum_k w_k C(q')[k]
            ff[s] -= 2.0 * (w[0] * C[1, 0, s] + w[1] * C[1, 1, s] + w[2] * C[1, 2, s])
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
        _solve_schur(J, C[0], fr, ff, S, b, wd)
    else:
        _solve3(J, fr, wd)
    if flags[COUPLING]:
        for s in range(nf):
            ff[s] -= C[0, 0, s] * wd[0] + C[0, 1, s] * wd[1] + C[0, 2, s] * wd[2]
    for r in range(nf):
        out[7 + r] = qd[r]
    p = y[0:4]
    out[0] = -0.5 * (p[1] * w[0] + p[2] * w[1] + p[3] * w[2])
    out[1] = 0.5 * (p[0] * w[0] + p[2] * w[2] - p[3] * w[1])
    out[2] = 0.5 * (p[0] * w[1] + p[3] * w[0] - p[1] * w[2])
    out[3] = 0.5 * (p[0] * w[2] + p[1] * w[1] - p[2] * w[0])


@inline
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


class _FirstCompile(event.Listener):
    """Calls ``tell()`` when numba starts compiling for the first time while installed (``on_compile``)."""

    def __init__(self, tell):
        self.tell = tell

    def on_start(self, _):
        if self.tell is not None:
            self.tell, tell = None, self.tell
            tell()

    def on_end(self, _):
        pass


@contextmanager
def on_compile(tell):
    """Within: ``tell()`` once, when numba starts to compile (the first simulation after installing, or after an
    upgrade: about half a minute; later runs load the compiled code from numba's cache, which compiles nothing)."""
    with event.install_listener("numba:compile", _FirstCompile(tell)):
        yield


F1, F2, F3, F4 = (nb.types.Array(nb.types.float64, ndim, "C") for ndim in (1, 2, 3, 4))
# The numba type of the model tuple (sim.integrate._compiled_model): flags, I0, Ibar, diag, off, tall, lam, dmp, G and
# the workspace; and rhs_into's argument types with it, for which ``rhs_address`` compiles it.
MODEL = nb.types.Tuple((nb.types.Array(nb.types.int64, 1, "C"), F2, F3, F2, F2, F2, F1, F1, F3,
                        nb.types.Tuple((F2, F2, F2, F2, F1, F1, F4, F3))))
RHS_ARGS = (F1, F1, MODEL, F1, F1, nb.types.boolean, F1, F1)


@functools.cache
def rhs_address() -> int:
    """The address of ``rhs_into`` compiled (or loaded from the cache) for RHS_ARGS, for ``call_rhs``.

    The integrators call the right-hand side by this address, passed at run time, instead of by name: numba
    links the code of every compiled function a compiled function calls by name into it, and LLVM optimises and
    emits it once more in every caller, layer by layer: rhs_into (10 s to compile) cost 3.5-4 s again in each
    layer of an integrator, 20 s in the midpoint rule's five (numba's compile events, 2026-11-26)."""
    rhs_into.compile(RHS_ARGS)
    result = rhs_into.overloads[RHS_ARGS]
    return result.library.get_pointer_to_function(result.fndesc.llvm_func_name)


@intrinsic
def call_rhs(typingctx, address, y, out, model, tau, fext, prescribed, wp, wdp):
    """``rhs_into(y, out, model, tau, fext, prescribed, wp, wdp)`` through ``address`` (``rhs_address``), in
    numba's own calling convention; errors propagate as from a call by name. Typed only for RHS_ARGS, the types
    the address was compiled for: any other argument type is a typing error, never a call with the wrong layout."""
    if not isinstance(address, nb.types.Integer) or (y, out, model, tau, fext, prescribed, wp, wdp) != RHS_ARGS:
        raise nb.core.errors.TypingError(f"call_rhs: expected an address and {RHS_ARGS}, got {model} and the rest "
                                         "(sim.integrate._compiled_model builds the model)")

    def codegen(context, builder, signature, args):
        function = context.call_conv.get_function_type(nb.types.none, RHS_ARGS).as_pointer()
        status, _ = context.call_conv.call_function(builder, builder.inttoptr(args[0], function), nb.types.none,
                                                    RHS_ARGS, args[1:])
        with cgutils.if_unlikely(builder, status.is_error):
            context.call_conv.return_status_propagate(builder, status)
        return context.get_dummy_value()
    return nb.types.none(address, *RHS_ARGS), codegen


@inline
def rhs_loaded(rhs, t, y, out, model, prog, fext, scratch):
    """rhs_into (at the address ``rhs``) at time t with the loads of the packed LoadProgram ``prog`` (sim.loads)
    and constant modal forces ``fext``; ``scratch``: three 3-vectors."""
    tau, w, wd = scratch
    loads_at(t, prog, tau, w, wd)
    call_rhs(rhs, y, out, model, tau, fext, prog[8] != 0.0, w, wd)


@inline
def store_row(out, row, y):
    """out[row] = y, entry by entry (an array assignment needs numba's runtime, which ``bare`` code lacks, and
    compiles string code for its shape error: about 3 s in a fresh process)."""
    for i in range(y.shape[0]):
        out[row, i] = y[i]
