"""FE modal data -> inertia shape integrals -> I0, W1, W2, W3 (theory section 3).

All integrals are nodal sums with the scalar mass matrix Ms: exact for
fields of the FE space when Ms is consistent, the lumped-mass (Adams-style)
approximation when Ms is diagonal.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from .units import Units, factor

if TYPE_CHECKING:  # imported by the nodal sums that use it: a cached body's analysis needs no scipy
    import scipy.sparse as sp

# Levi-Civita symbol eps[k, l, m]
EPS = np.zeros((3, 3, 3))
for _k, _l, _m in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
    EPS[_k, _l, _m], EPS[_k, _m, _l] = 1.0, -1.0

CHUNK_BYTES = 8 * 2**20  # nodal rows of Ms @ Phi held at once


def _sym(a: np.ndarray) -> np.ndarray:
    return 0.5 * (a + a.T)


def frozen_array(a):
    """A read-only float copy of a (None stays None): immutable body data. An array that is already read-only
    float data of its own (as the readers return them) is taken as it is: a body file's modes are not copied."""
    if a is None:
        return None
    if isinstance(a, np.ndarray) and a.dtype == np.float64 and a.flags.owndata and not a.flags.writeable:
        return a
    a = np.array(a, dtype=float)
    a.flags.writeable = False
    return a


@dataclass(frozen=True)
class RotaryIntegrals:
    """Sums over nodes that carry rotary inertia J_p (3x3) and mode rotations Phi*_p (3 x nf) (theory 3b).

    J           sum J_p                        (3, 3)   adds to I0 (Adams I7)
    mean_axis   sum J_p Phi*_p                 (3, nf)  adds to the rotational mean-axis residual (Adams I4)
    modal_mass  sum Phi*_p^T J_p Phi*_p        (nf, nf) adds to the modal mass (Adams I6)
    """

    J: np.ndarray
    mean_axis: np.ndarray
    modal_mass: np.ndarray

    def __post_init__(self):
        for name in ("J", "mean_axis", "modal_mass"):
            object.__setattr__(self, name, frozen_array(getattr(self, name)))

    def rotated(self, R: np.ndarray) -> "RotaryIntegrals":
        """In axes given by the columns of R: J' = R^T J R, (J Phi*)' = R^T J Phi*; the modal mass is a scalar."""
        return RotaryIntegrals(_sym(R.T @ self.J @ R), R.T @ self.mean_axis, self.modal_mass)

    def converted(self, src: Units, dst: Units) -> "RotaryIntegrals":
        return RotaryIntegrals(self.J * factor(src, dst, "inertia"), self.mean_axis * factor(src, dst, "Ibar"),
                               self.modal_mass)

    def with_modes(self, ix: np.ndarray) -> "RotaryIntegrals":
        return RotaryIntegrals(self.J, self.mean_axis[:, ix], self.modal_mass[ix][:, ix])


def rotary_integrals(J_nodes: np.ndarray, Phi_rot: np.ndarray) -> RotaryIntegrals:
    """The sums of theory 3b from nodal rotary inertia (k, 3, 3) and mode rotations (k, 3, nf) of those nodes."""
    JP = np.einsum("iab,ibp->iap", J_nodes, Phi_rot)
    return RotaryIntegrals(_sym(J_nodes.sum(axis=0)), JP.sum(axis=0),
                           _sym(np.einsum("iap,iar->pr", Phi_rot, JP)))


@dataclass(frozen=True)
class ShapeIntegrals:
    """Nodal-sum integrals of one body in its floating frame (theory section 3).

    mass          sum m
    first_moment  sum m x                 (3,)
    I             I_kl = sum m x_k x_l    (3, 3)
    Ibar          Ibar[k, l] = x_k^T Ms Phi_l     (3, 3, nf)
    Sbar          Sbar[k, l] = Phi_k^T Ms Phi_l   (3, 3, nf, nf), or None when unknown
    mode_sum      sum m S = 1^T Ms Phi_k  (3, nf)  (zero for free-surface modes)
    spin          W3 as (3, nf, nf) when only it is known (an invariants file
                  with Adams' I5 but no I9); None when Sbar is given
    rotary        the sums of nodes with rotary inertia (theory 3b), or None
                  (translational nodes only); W1, W2, W3 stay translational

    Without Sbar, W2 is not evaluable (None), and so is W3 unless ``spin`` is given.
    """

    mass: float
    first_moment: np.ndarray
    I: np.ndarray
    Ibar: np.ndarray
    Sbar: np.ndarray | None
    mode_sum: np.ndarray
    spin: np.ndarray | None = None
    rotary: RotaryIntegrals | None = None

    def __post_init__(self):
        for name in ("first_moment", "I", "Ibar", "Sbar", "mode_sum", "spin"):
            object.__setattr__(self, name, frozen_array(getattr(self, name)))
        object.__setattr__(self, "mass", float(self.mass))
        if self.Sbar is not None:
            object.__setattr__(self, "spin", None)

    @property
    def missing(self) -> tuple[str, ...]:
        """Invariants that cannot be evaluated from the data: 'W2', 'W3'."""
        return (("W2",) if self.Sbar is None else ()) + (("W3",) if self.W3() is None else ())

    @property
    def nf(self) -> int:
        return self.Ibar.shape[2]

    @property
    def com(self) -> np.ndarray:
        return self.first_moment / self.mass

    def I0(self) -> np.ndarray:
        """Inertia tensor of the undeformed body about the frame origin, nodal rotary inertia included (3b)."""
        return I0(self.I) + (0.0 if self.rotary is None else self.rotary.J)

    def modal_mass(self) -> np.ndarray | None:
        """sum m Phi^T Phi (+ sum Phi*^T J Phi*): the identity for mass-normalised modes; None without Sbar."""
        if self.Sbar is None:
            return None
        return np.einsum("kkpr->pr", self.Sbar) + (0.0 if self.rotary is None else self.rotary.modal_mass)

    def W1(self) -> np.ndarray:
        return self._W1

    def W2(self) -> np.ndarray | None:
        return self._W2

    def W3(self) -> np.ndarray | None:
        return self._W3

    # W1, W2, W3 are made once per integrals (their data is immutable) and read-only: significance asks for the
    # 3nf x 3nf W2 once per mode (analyze of a freshly read 100-mode body 19 -> 13 ms)
    @cached_property
    def _W1(self) -> np.ndarray:
        return _read_only(W1(self.Ibar))

    @cached_property
    def _W2(self) -> np.ndarray | None:
        return None if self.Sbar is None else _read_only(W2(self.Sbar))

    @cached_property
    def _W3(self) -> np.ndarray | None:
        if self.Sbar is not None:
            return _read_only(W3(self.Sbar))
        return None if self.spin is None else self.spin.reshape(3 * self.nf, self.nf)

    def __getstate__(self) -> dict:
        """The fields only: a body sent from its reading child carries no made invariants."""
        return {k: v for k, v in vars(self).items() if k not in ("_W1", "_W2", "_W3")}

    def mean_axis_residual(self) -> np.ndarray:
        """sum m u0~ S (+ sum J Phi*, theory 3b) (3, nf): zero for modes satisfying the mean-axis conditions."""
        return np.einsum("klm,lmp->kp", EPS, self.Ibar) + (0.0 if self.rotary is None else self.rotary.mean_axis)

    def shifted(self, c: np.ndarray) -> "ShapeIntegrals":
        """The integrals with the frame origin moved to c (x' = x - c)."""
        c = np.asarray(c, float)
        s = self.first_moment
        I = self.I - np.outer(c, s) - np.outer(s, c) + self.mass * np.outer(c, c)
        Ibar = self.Ibar - c[:, None, None] * self.mode_sum[None, :, :]
        return replace(self, first_moment=s - self.mass * c, I=I, Ibar=Ibar)

    def rotated(self, R: np.ndarray) -> "ShapeIntegrals":
        """The integrals in axes given by the columns of R (x' = R^T x, S' = R^T S)."""
        return replace(
            self,
            first_moment=R.T @ self.first_moment,
            I=_sym(R.T @ self.I @ R),
            Ibar=np.einsum("ak,bl,abp->klp", R, R, self.Ibar),
            Sbar=None if self.Sbar is None else np.einsum("ak,bl,abpr->klpr", R, R, self.Sbar),
            mode_sum=R.T @ self.mode_sum,
            spin=None if self.spin is None else np.einsum("ak,apr->kpr", R, self.spin),
            rotary=None if self.rotary is None else self.rotary.rotated(R),
        )

    def converted(self, src: Units, dst: Units) -> "ShapeIntegrals":
        """The integrals in other units."""
        return ShapeIntegrals(
            mass=self.mass * factor(src, dst, "mass"),
            first_moment=self.first_moment * factor(src, dst, "mass") * factor(src, dst, "length"),
            I=self.I * factor(src, dst, "inertia"),
            Ibar=self.Ibar * factor(src, dst, "Ibar"),
            Sbar=self.Sbar,
            mode_sum=self.mode_sum * factor(src, dst, "mode_sum"),
            spin=self.spin,
            rotary=None if self.rotary is None else self.rotary.converted(src, dst),
        )


def shape_integrals(X: np.ndarray, Ms: sp.sparray, Phi, rotary: RotaryIntegrals | None = None) -> ShapeIntegrals:
    """Shape integrals from node coordinates X (n, 3), scalar mass Ms (n, n) and modes Phi (n, 3, nf) in
    memory, with the sums of the nodes that carry rotary inertia (``rotary_integrals``, theory 3b)."""
    import scipy.sparse as sp
    Ms = sp.csr_array(Ms)
    return nodal_pass(X, lambda a, b: Ms[a:b], lambda a, b: Phi[a:b], Phi.shape[2], rotary).integrals


@dataclass(frozen=True)
class NodalPass:
    """What one pass over the nodes gives: the shape integrals (theory 3) and each mode's largest nodal
    deflection per unit modal coordinate (theory 6)."""

    integrals: ShapeIntegrals
    max_deflection: np.ndarray


SPAN = 3  # row blocks of Phi one block of Ms rows may reach before its columns are taken block by block


def block_rows(nf: int, multiple: int = 1) -> int:
    """Nodal rows per block: about CHUNK_BYTES of Phi, a whole number of ``multiple`` (a file's chunk rows)."""
    rows = max(1, CHUNK_BYTES // (8 * 3 * nf))
    return max(multiple, rows // multiple * multiple)


def nodal_pass(X: np.ndarray, Ms_rows, Phi_rows, nf: int, rotary: RotaryIntegrals | None = None,
               rows: int | None = None) -> NodalPass:
    """Shape integrals and deflection maxima over blocks of nodal rows, never holding Phi whole.

    ``Ms_rows(a, b)`` gives the rows a:b of Ms (CSR, n columns) and
    ``Phi_rows(a, b)`` the modes of nodes a:b as (b - a, 3, nf) floats: from
    memory or from a file's chunks (io.ffrf_h5), validated by the caller. For
    each block, ``Y = Ms[a:b] Phi`` over the node range its columns reach (a
    band matrix: the block and its neighbours; a wider reach block by block),
    then ``Phi^T Ms Phi += Phi[a:b]^T Y`` and ``[1, X]^T Ms Phi += [1, X][a:b]^T Y``.
    Extra memory: a few blocks, whatever n.
    """
    import scipy.sparse as sp
    n = len(X)
    rows = rows or block_rows(nf)
    Xe = np.column_stack([np.ones(n), X])  # [1, x1, x2, x3]
    E = np.zeros((4, 4))  # [1, X]^T Ms [1, X]: mass, first moment, second moments
    moments = np.zeros((4, 3 * nf))  # [1, X]^T Ms Phi
    Sbar = np.zeros((3 * nf, 3 * nf))
    squares = np.zeros(nf)
    for a in range(0, n, rows):
        b = min(n, a + rows)
        Msi = sp.csr_array(Ms_rows(a, b))
        Phi_i, Y = _block_product(Msi, Phi_rows, a, b, rows, nf)
        Sbar += Phi_i.T @ Y
        moments += Xe[a:b].T @ Y
        E += Xe[a:b].T @ (Msi @ Xe)
        squares = np.maximum(squares, largest_squares(Phi_i.reshape(-1, 3, nf)))
    Sbar = 0.5 * (Sbar + Sbar.T)
    integrals = ShapeIntegrals(
        mass=E[0, 0],
        first_moment=E[0, 1:],
        I=_sym(E[1:, 1:]),
        Ibar=moments[1:].reshape(3, 3, nf),
        Sbar=Sbar.reshape(3, nf, 3, nf).transpose(0, 2, 1, 3),
        mode_sum=moments[0].reshape(3, nf),
        rotary=rotary,
    )
    return NodalPass(integrals, np.sqrt(squares))


def largest_squares(Phi: np.ndarray) -> np.ndarray:
    """max over the nodes of |S_p(node)|^2 for modes Phi (k, 3, nf): squared largest deflections (theory 6)."""
    return np.einsum("ikp,ikp->ip", Phi, Phi).max(axis=0, initial=0.0)


def _block_product(Msi: sp.csr_array, Phi_rows, a: int, b: int, rows: int, nf: int) -> tuple[np.ndarray, np.ndarray]:
    """(Phi[a:b], Ms[a:b] Phi) as (b - a, 3 nf) arrays; Phi read over the node range the block's columns reach
    when it spans at most SPAN blocks, else over the column blocks it touches, one at a time."""
    import scipy.sparse as sp
    cols = Msi.indices
    lo, hi = (min(a, int(cols.min())), max(b, int(cols.max()) + 1)) if cols.size else (a, b)
    if hi - lo <= SPAN * rows:
        reach = np.asarray(Phi_rows(lo, hi), float).reshape(hi - lo, 3 * nf)
        shifted = sp.csr_array((Msi.data, cols - lo, Msi.indptr), shape=(b - a, hi - lo))
        return reach[a - lo:b - lo], shifted @ reach
    Y = np.zeros((b - a, 3 * nf))
    row = np.repeat(np.arange(b - a), np.diff(Msi.indptr))
    for j in np.unique(cols // rows):
        c0, c1 = j * rows, min(j * rows + rows, Msi.shape[1])
        m = (cols >= c0) & (cols < c1)
        part = sp.csr_array((Msi.data[m], (row[m], cols[m] - c0)), shape=(b - a, c1 - c0))
        Y += part @ np.asarray(Phi_rows(c0, c1), float).reshape(c1 - c0, 3 * nf)
    return np.asarray(Phi_rows(a, b), float).reshape(b - a, 3 * nf), Y


def _read_only(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


def I0(I: np.ndarray) -> np.ndarray:
    """I0 = trace(I) 1 - I (G17): the inertia tensor from the second moments I_kl."""
    return np.trace(I) * np.eye(3) - I


def W1(Ibar: np.ndarray) -> np.ndarray:
    """W1 (3 x 3nf), blocks 2 delta_kl sum_j Ibar_jj - (Ibar_kl + Ibar_lk) (G17)."""
    nf = Ibar.shape[2]
    tr = np.einsum("jjp->p", Ibar)
    blocks = 2 * np.eye(3)[:, :, None] * tr - (Ibar + Ibar.transpose(1, 0, 2))
    return blocks.reshape(3, 3 * nf)


def W2(Sbar: np.ndarray) -> np.ndarray:
    """W2 (3nf x 3nf), block (k, l) = delta_kl sum_j Sbar_jj - Sbar_lk (G17)."""
    nf = Sbar.shape[2]
    tr = np.einsum("jjpr->pr", Sbar)
    blocks = np.eye(3)[:, :, None, None] * tr - Sbar.transpose(1, 0, 2, 3)
    return blocks.transpose(0, 2, 1, 3).reshape(3 * nf, 3 * nf)


def W3(Sbar: np.ndarray) -> np.ndarray:
    """W3 (3nf x nf), block k = sum_lm eps_klm Sbar_lm, i.e. [S23 - S32; S31 - S13; S12 - S21] (G17)."""
    nf = Sbar.shape[2]
    return np.einsum("klm,lmpr->kpr", EPS, Sbar).reshape(3 * nf, nf)


def Qf(q: np.ndarray) -> np.ndarray:
    """Qf = blockdiag(q, q, q) (3nf x 3)."""
    q = np.asarray(q, float)
    return np.kron(np.eye(3), q[:, None])


def I_TT(integrals: ShapeIntegrals, q: np.ndarray) -> np.ndarray:
    """Inertia of the deformed body I0 + W1 Qf + Qf^T W2 Qf (theory section 3)."""
    Q = Qf(q)
    return integrals.I0() + integrals.W1() @ Q + Q.T @ integrals.W2() @ Q


def principal_axes(I0_: np.ndarray) -> np.ndarray:
    """Rotation R (columns: principal axes) closest to the current axes.

    Eigenvectors of I0 are assigned to the current axes by largest
    overlap and signed to point along them, so a body that is already
    principal keeps its axis labels (det R = +1).
    """
    _, V = np.linalg.eigh(0.5 * (I0_ + I0_.T))
    order = np.zeros(3, int)
    free = list(range(3))
    for k in np.argsort(-np.abs(V).max(axis=1)):  # most decided axes first
        j = max(free, key=lambda col: abs(V[k, col]))
        order[k] = j
        free.remove(j)
    R = V[:, order]
    R = R * np.sign(np.diag(R) + (np.diag(R) == 0))
    if np.linalg.det(R) < 0:
        R[:, np.argmin(np.abs(np.diag(R)))] *= -1
    return R
