"""Plain-numpy right-hand side of the free-body FFRF equations for any term set (theory section 5).

The reference the compiled kernels (``sim.kernels``) are tested against;
readable rather than fast. The force and acceleration functions take
states with leading batch axes too (the linearisation's difference columns). State ``y = [p, w, q, q']``: unit quaternion
``p`` (scalar first, body to inertial), body angular velocity ``w``, modal
coordinates and velocities. Translation decouples for a free body
(``m a_cm = F``, free-surface modes and CoM origin) and is not integrated.

    [ I_TT   C ] [ w' ]   [ tau - w~ I_TT w - W1 Qf' w - dJ2 w - w~ C q'        ]
    [ C^T    I ] [ q''] = [ f - Omega^2 q - D q' + cf1 + cf2 - 2 C(q')^T w - G(w) q ]

with ``I_TT = I0 + W1 Qf + J2``, ``J2 = Qf^T W2 Qf``, ``C = Qf^T W3``; each
piece is present only when its term is in the set (sim.model for the block
forms). With ``coupling`` the system is solved through the Schur complement
``I_TT - C C^T`` (3 x 3). In prescribed-rotation mode ``w`` and ``w'`` are
given and ``q'' = rhs_f - C^T w'``.
"""
from __future__ import annotations

from functools import cached_property

import numpy as np

from ..body import pair_weights  # G(w) = sum_c weights_c(w) G_c from the six G_kl (theory 9)
from .model import N_ROT, Model


EYE3 = np.eye(3)


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` of 3-vectors on the last axis (np.cross costs ten times as much on vectors this small)."""
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1], a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


def mv(A: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``A x`` for matrices and vectors on the last axes."""
    return np.einsum("...ij,...j->...i", A, x)


def _identity_times(c: np.ndarray) -> np.ndarray:
    return c[..., None, None] * EYE3


def split(y: np.ndarray, nf: int):
    """(p, w, q, q') views of the state vector (or of the last axis of a stack of states)."""
    return y[..., :4], y[..., 4:7], y[..., N_ROT:N_ROT + nf], y[..., N_ROT + nf:N_ROT + 2 * nf]


def quaternion_rate(p: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``dp/dt = 0.5 p * (0, w)`` for body angular velocity w."""
    return 0.5 * np.concatenate(([-p[1:] @ w], p[0] * w + cross(p[1:], w)))


def linear_inertia(m: Model, q: np.ndarray) -> np.ndarray:
    """``W1 Qf = 2 tr(C1) I - C1 - C1^T``, ``C1[k, l] = Ibar[k, l] . q``."""
    C1 = np.einsum("klr,...r->...kl", m.Ibar, q)
    return _identity_times(2 * np.trace(C1, axis1=-2, axis2=-1)) - C1 - np.swapaxes(C1, -1, -2)


def sbar_times(m: Model, r: np.ndarray) -> np.ndarray:
    """``Sbar_ab r`` (..., 3, 3, nf) for every pair (a, b): one BLAS product."""
    return np.tensordot(r, m.Sbar, axes=([-1], [3]))


def sbar_columns(m: Model) -> np.ndarray:
    """``sbar_times`` of every unit vector e_j (nf, 3, 3, nf): Sbar's columns, exactly (no product)."""
    return np.moveaxis(m.Sbar, 3, 0)


def quadratic_inertia(m: Model, q: np.ndarray, r: np.ndarray, pairs: bool = False,
                      Sr: np.ndarray | None = None) -> np.ndarray:
    """``tr(G) I - G`` with the symmetrised ``G[a, b] = 0.5 (q^T Sbar_ab r + r^T Sbar_ab q)``.

    ``q = r`` gives ``J2 = Qf^T W2 Qf``; ``(q', q)`` gives half of ``dJ2/dt``. ``q`` and ``r`` broadcast
    against each other; ``pairs``: every pair of a row of q (n, nf) and a row of r (k, nf), (n, k, 3, 3), as
    ``q[:, None], r[None, :]`` would give, by a second BLAS product instead of a broadcast sum; ``Sr``:
    ``sbar_times(m, r)`` where the caller has it.
    """
    Sr = sbar_times(m, r) if Sr is None else Sr
    G = np.tensordot(q, Sr, axes=([1], [3])) if pairs else np.einsum("...r,...abr->...ab", q, Sr)
    G = 0.5 * (G + np.swapaxes(G, -1, -2))
    return _identity_times(np.trace(G, axis1=-2, axis2=-1)) - G


def coupling_matrix(m: Model, q: np.ndarray) -> np.ndarray:
    """``C = Qf^T W3`` (3 x nf): rows ``W3k[k]^T q`` (one BLAS product over the batch)."""
    return np.tensordot(q, m.W3k, axes=([-1], [1]))


def coupling_columns(m: Model) -> np.ndarray:
    """``coupling_matrix`` of every unit vector e_j (nf, 3, nf): W3's columns, exactly (no product)."""
    return np.moveaxis(m.W3k, 1, 0)


def inertia(m: Model, q: np.ndarray, Sq: np.ndarray | None = None) -> np.ndarray:
    """``I_TT`` of the term set: I0, plus W1 Qf with inertia_lin, plus J2 with inertia_quad (``Sq``:
    ``sbar_times(m, q)`` where the caller has it)."""
    J = np.broadcast_to(m.I0, (*q.shape[:-1], 3, 3)).astype(np.result_type(q, float))  # complex q: complex steps
    if m.on("inertia_lin"):
        J += linear_inertia(m, q)
    if m.on("inertia_quad"):
        J += quadratic_inertia(m, q, q, Sr=Sq)
    return J


class Deformed:
    """The pieces of the terms that depend on the modal coordinates q alone (a state, or a batch of them), each
    computed once, when first used, and shared by the rotational and flexible equations: ``Sq = Sbar q`` (the
    W2 terms: inertia_quad, cor_quad, cf2), ``J = I_TT`` and ``C = Qf^T W3``."""

    def __init__(self, m: Model, q: np.ndarray):
        self.m, self.q = m, q

    @cached_property
    def Sq(self) -> np.ndarray:
        return sbar_times(self.m, self.q)

    @cached_property
    def J(self) -> np.ndarray:
        return inertia(self.m, self.q, self.Sq if self.m.on("inertia_quad") else None)

    @cached_property
    def C(self) -> np.ndarray:
        return coupling_matrix(self.m, self.q)

    def row(self, i: int) -> Deformed:
        """The pieces of state i of a batch: those computed so far, as rows of the batch's."""
        one = Deformed(self.m, self.q[i])
        one.__dict__.update({k: v[i] for k, v in self.__dict__.items() if k in ("Sq", "J", "C")})
        return one


def rotational_force(m: Model, q, qd, w, tau, d: Deformed | None = None) -> np.ndarray:
    """Right side of the rotational equations: torque, gyroscopic and Coriolis terms of the set (``d``: the
    Deformed pieces at q where the caller has them)."""
    d = Deformed(m, q) if d is None else d
    f = tau - cross(w, mv(d.J, w))
    if m.on("cor1"):
        f -= mv(linear_inertia(m, qd), w)
    if m.on("cor_quad"):
        f -= 2 * mv(quadratic_inertia(m, qd, q, Sr=d.Sq), w)
    if m.on("cor_coupling"):
        f -= cross(w, mv(d.C, qd))
    return f


def flexible_force(m: Model, q, qd, w, fext, d: Deformed | None = None) -> np.ndarray:
    """Right side of the flexible equations: loads, stiffness, damping, centrifugal and Coriolis terms (``d``:
    the Deformed pieces at q where the caller has them)."""
    d = Deformed(m, q) if d is None else d
    f = fext - m.eigenvalues * q - m.damping * qd
    ww = np.einsum("...k,...l->...kl", w, w)
    w2 = np.einsum("...k,...k->...", w, w)[..., None]
    if m.on("cf1"):
        f = f + w2 * np.einsum("mmr->r", m.Ibar) - np.einsum("...kl,klr->...r", ww, m.Ibar)
    if m.on("cf2"):
        f = f + w2 * np.einsum("...mmr->...r", d.Sq) - np.einsum("...kl,...lkr->...r", ww, d.Sq)
    if m.on("cor_coupling"):
        f = f - 2 * np.einsum("...ks,...k->...s", coupling_matrix(m, qd), w)
    if m.on("geo_stiff"):
        Gq = np.tensordot(q, m.G, axes=([-1], [2]))  # (..., 6, nf): G_kl q
        f = f - np.einsum("...c,...cr->...r", pair_weights(w), Gq)
    return f


def accelerations(m: Model, q, qd, w, tau, fext, d: Deformed | None = None):
    """(w', q'') of the free body: block solve, Schur complement on the 3 x 3 block with coupling. Every
    argument may carry leading batch axes (states side by side); ``d``: the Deformed pieces at q where the
    caller has them."""
    d = Deformed(m, q) if d is None else d
    fr, ff = rotational_force(m, q, qd, w, tau, d), flexible_force(m, q, qd, w, fext, d)
    if not m.on("coupling"):
        return _solve(d.J, fr), ff
    C = d.C
    wd = _solve(d.J - C @ np.swapaxes(C, -1, -2), fr - mv(C, ff))
    return wd, ff - np.einsum("...ks,...k->...s", C, wd)


def modal_derivatives(m: Model, q: np.ndarray, qd: np.ndarray, w: np.ndarray, a: tuple[np.ndarray, np.ndarray],
                      d: Deformed) -> tuple[np.ndarray, np.ndarray]:
    """Exact derivatives of ``accelerations`` (no loads) at one state along every q_j, then every q'_j: (the
    rows of w' (2 nf, 3), those of q'' (2 nf, nf)), row j the direction j; ``a``: the accelerations (w', q'')
    at the state, ``d``: its Deformed pieces.

    The forces F = (fr, ff) on the right above are polynomials in q and q' and the mass matrix M(q) is linear
    and quadratic in q, so a direction e moves the accelerations ``a = M^-1 F`` by ``M^-1 (dF e - (dM e) a)``:
    per direction the forces' terms with q (q') replaced by e_j in one factor at a time, and one solve with
    the state's M for all of them; dM comes from I_TT's W1 Qf and J2 and from C."""
    nf, eye, (wd, qdd) = m.nf, np.eye(m.nf), a
    cols = sbar_columns(m)  # (nf, 3, 3, nf): Sbar e_j, the change of Sq = Sbar q along q_j
    L = linear_inertia(m, eye) if m.on("inertia_lin") or m.on("cor1") else None  # W1 e_j
    Q = quadratic_inertia(m, eye, q, Sr=d.Sq) if m.on("inertia_quad") or m.on("cor_quad") else None  # J2(e_j, q)
    dJ = np.zeros((nf, 3, 3))  # along q_j
    if m.on("inertia_lin"):
        dJ += L
    if m.on("inertia_quad"):
        dJ += Q + quadratic_inertia(m, q, eye, Sr=cols)
    fr_q, fr_qd = -cross(w, mv(dJ, w)), np.zeros((nf, 3))
    ff_q, ff_qd = stiffness_columns(m, w), -np.diag(m.damping)
    if m.on("cor1"):
        fr_qd -= mv(L, w)
    if m.on("cor_quad"):
        fr_q -= 2 * mv(quadratic_inertia(m, qd, eye, Sr=cols), w)
        fr_qd -= 2 * mv(Q, w)
    Cj = coupling_columns(m)  # (nf, 3, nf): C(e_j)
    if m.on("cor_coupling"):
        fr_q -= cross(w, Cj @ qd)
        fr_qd -= cross(w, d.C.T)
        ff_qd = ff_qd - 2 * np.einsum("k,kjs->js", w, m.W3k)
    r_w, r_f = np.concatenate([fr_q - mv(dJ, wd), fr_qd]), np.concatenate([ff_q, ff_qd])
    if not m.on("coupling"):
        return np.linalg.solve(d.J, r_w.T).T, r_f
    r_w[:nf] -= Cj @ qdd
    r_f[:nf] -= np.einsum("jks,k->js", Cj, wd)
    C = d.C
    dwd = np.linalg.solve(d.J - C @ C.T, (r_w - r_f @ C.T).T).T
    return dwd, r_f - dwd @ C


def stiffness_columns(m: Model, w: np.ndarray) -> np.ndarray:
    """(nf, nf): the change of ``flexible_force`` at spin w along each q_j (row j), exact: it is affine in q,
    ``-Omega^2 q`` and the q terms of cf2 and ``G(w) q`` (with the sign they carry on the right above)."""
    ff_q = -np.diag(m.eigenvalues)
    if m.on("cf2"):
        cols = sbar_columns(m)
        ff_q = ff_q + (w @ w) * np.einsum("jmms->js", cols) - np.einsum("kl,jlks->js", np.outer(w, w), cols)
    if m.on("geo_stiff"):
        ff_q = ff_q - np.einsum("c,crj->jr", pair_weights(w), m.G)
    return ff_q


def _solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.linalg.solve(A, b[..., None])[..., 0]


def rhs(m: Model, t: float, y: np.ndarray, tau=None, fext=None, prescribed=None) -> np.ndarray:
    """``dy/dt``; ``prescribed = (w, w')`` replaces the rotational equations (spin-up scenes)."""
    nf = m.nf
    p, w, q, qd = split(y, nf)
    tau = np.zeros(3) if tau is None else tau
    fext = np.zeros(nf) if fext is None else fext
    if prescribed is None:
        wd, qdd = accelerations(m, q, qd, w, tau, fext)
    else:
        w, wd = (np.asarray(v, float) for v in prescribed)
        qdd = flexible_force(m, q, qd, w, fext)
        if m.on("coupling"):
            qdd = qdd - coupling_matrix(m, q).T @ wd
    return np.concatenate((quaternion_rate(p, w), wd, qd, qdd))


def energy(m: Model, y: np.ndarray) -> float | np.ndarray:
    """Kinetic plus strain energy of the term set's own model (theory section 5); of each state of a stack."""
    _, w, q, qd = split(y, m.nf)
    T = 0.5 * np.einsum("...i,...ij,...j->...", w, inertia(m, q), w) + 0.5 * np.sum(qd * qd, axis=-1)
    if m.on("coupling"):
        T = T + np.einsum("...k,...ks,...s->...", w, coupling_matrix(m, q), qd)
    E = T + 0.5 * np.sum(q * (m.eigenvalues * q), axis=-1)
    return float(E) if np.ndim(E) == 0 else E


def angular_momentum(m: Model, y: np.ndarray) -> float | np.ndarray:
    """``|H| = |I_TT w + C q'|`` (the inertial-frame norm equals the body-frame one); of each state of a stack."""
    _, w, q, qd = split(y, m.nf)
    H = mv(inertia(m, q), w)
    if m.on("coupling"):
        H = H + mv(coupling_matrix(m, q), qd)
    n = np.linalg.norm(H, axis=-1)
    return float(n) if np.ndim(n) == 0 else n
