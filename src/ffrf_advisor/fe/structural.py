"""Mass of shells, beams and point masses (theory 2, 3b): a scalar translational mass Ms over the nodes (the
full translational mass is kron(Ms, I3)) and a rotary inertia J_p (3 x 3) per node.

Shells (``triangle``, ``triangle6``, ``quad``, ``quad8``, ``quad9``; thickness t per cell) and beams (``line``,
``line3``; area A, second moments I22, I33, an orientation) are isoparametric in VTK/meshio node order:
x(xi) = sum_a N_a(xi) x_a on the mid-surface or the axis. A point of a shell is x + z n (|z| <= t/2, n the unit
normal), of a beam x + y e2 + z e3 over the section, so its kinetic energy splits into
- the mid-surface/axis motion: Ms_ab = int rho t N_a N_b dA (shells), int rho A N_a N_b ds (beams), consistent;
- the turn of each fibre (the terms linear in z or y vanish, the section's centroid lies on x):
  rho int z^2 dz (|n|^2 I - n n^T) = rho t^3/12 (I - n n^T) per area for a shell, and per length for a beam
  rho int (|r|^2 I - r r^T) dA = rho [(I22 + I33) e1 e1^T + I22 e2 e2^T + I33 e3 e3^T]
  = rho [I22 e1 e1^T + I33 I + (I22 - I33) e2 e2^T], with I22 = int x3^2 dA (about e2), I33 = int x2^2 dA,
  e1 the axis, e2 the orientation vector made normal to it, e3 = e1 x e2 (principal section axes; where
  I22 = I33 no orientation is needed). Its integral over the element is lumped to the nodes in proportion to
  the diagonal of the element's mass (Hinton-Rock-Zienkiewicz): J_a = (M_aa / sum_b M_bb) int T, so every
  J_a is positive semi-definite (the integrals of quadratic shape functions are negative at corners) and
  sum_a J_a is the exact fibre part of I0 (theory 3b: I0 = x^T Ms x terms + sum_p J_p). For linear
  elements of constant Jacobian it is the integral of each shape function.
Point masses: m on the diagonal of Ms and their 3 x 3 inertia J at their node.

Integrals by Gauss rules (collapsed Gauss-Jacobi on triangles), exact wherever the area or length element is a
polynomial (flat shells, straight beams, any mid-side node placement along them); on curved quadratic
elements the area element is a square root and the rule's 8 points per direction leave an error far
below the geometry's own.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from itertools import product
from typing import Iterator

import numpy as np
import scipy.sparse as sp

from . import quadrature
from .lagrange import LagrangeBasis

_CHUNK = 2_000_000  # quadrature-point x node-pair entries per chunk (bounds peak memory)


@dataclass(frozen=True)
class Reference:
    """A shell or beam element: meshio name, reference nodes (nn, dim), monomials (nn, dim) spanning its
    shape functions, Gauss points per direction; ``triangle`` elements live on r, s >= 0, r + s <= 1."""

    name: str
    nodes: tuple
    monomials: tuple
    points: int
    triangle: bool = False

    @property
    def dim(self) -> int:
        return len(self.nodes[0])

    @property
    def n_nodes(self) -> int:
        return len(self.nodes)

    def shape(self, xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """N (nq, nn) and dN/dxi (nq, nn, dim) at xi (nq, dim): the monomials times the inverse of their values
        at the nodes (``fe.lagrange``, in 3D with the unused coordinates 0)."""
        N, dN = _basis(self)(_padded(xi))
        return N, dN[..., :self.dim]

    def rule(self) -> tuple[np.ndarray, np.ndarray]:
        """Quadrature points (nq, dim) and weights (nq,) on the reference element."""
        return _rule(self.dim, self.points, self.triangle)


def _padded(a) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    return np.hstack([a, np.zeros((len(a), 3 - a.shape[1]))])


@cache
def _basis(ref: Reference) -> LagrangeBasis:
    return LagrangeBasis(_padded(ref.nodes), _padded(ref.monomials).astype(int))


@cache
def _rule(dim: int, n: int, triangle: bool) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre on [-1, 1], tensor on [-1, 1]^2; on the triangle ``fe.quadrature``'s collapsed rule (exact
    for total degree 2n - 1)."""
    if triangle:
        return quadrature.triangle(n)
    t, w = np.polynomial.legendre.leggauss(n)
    if dim == 1:
        return t[:, None], w
    return np.array(list(product(t, t))), np.array([a * b for a, b in product(w, w)])


_SQ = ((-1, -1), (1, -1), (1, 1), (-1, 1))
_SQ_MID = ((0, -1), (1, 0), (0, 1), (-1, 0))
_TRI = ((0, 0), (1, 0), (0, 1))
_TRI_MID = ((0.5, 0), (0.5, 0.5), (0, 0.5))
SHELLS = {r.name: r for r in (
    Reference("triangle", _TRI, ((0, 0), (1, 0), (0, 1)), 4, True),
    Reference("triangle6", _TRI + _TRI_MID, ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2)), 8, True),
    Reference("quad", _SQ, ((0, 0), (1, 0), (0, 1), (1, 1)), 4),
    Reference("quad8", _SQ + _SQ_MID, ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2), (2, 1), (1, 2)), 8),
    Reference("quad9", _SQ + _SQ_MID + ((0, 0),),
              ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2), (2, 1), (1, 2), (2, 2)), 8),
)}
BEAMS = {r.name: r for r in (
    Reference("line", ((-1,), (1,)), ((0,), (1,)), 4),
    Reference("line3", ((-1,), (1,), (0,)), ((0,), (1,), (2,)), 8),
)}


@dataclass(frozen=True)
class StructuralMass:
    """Scalar translational mass Ms (n x n) and nodal rotary inertia J (n, 3, 3) (theory 2, 3b)."""

    Ms: sp.csr_array
    J: np.ndarray

    @classmethod
    def zero(cls, n: int) -> "StructuralMass":
        return cls(sp.csr_array((n, n)), np.zeros((n, 3, 3)))

    def __add__(self, other: "StructuralMass") -> "StructuralMass":
        return StructuralMass(sp.csr_array(self.Ms + other.Ms), self.J + other.J)


@dataclass(frozen=True)
class BeamSection:
    """Per cell: area A, second moments I22 = int x3^2 dA and I33 = int x2^2 dA about the principal section
    axes e2, e3, and a vector v (ne, 3) whose part normal to the axis is e2 (unused where I22 = I33)."""

    area: np.ndarray
    I22: np.ndarray
    I33: np.ndarray
    orientation: np.ndarray | None = None


def _chunks(ne: int, per_element: int) -> Iterator[slice]:
    size = max(1, _CHUNK // per_element)
    for start in range(0, ne, size):
        yield slice(start, min(start + size, ne))


def _geometry(ref: Reference, coords: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """N (nq, nn), weighted measure dA or ds (ne, nq) and unit normal or tangent (ne, nq, 3) of each element."""
    xi, w = ref.rule()
    N, dN = ref.shape(xi)
    T = np.einsum("qnd,enb->eqdb", dN, coords)  # tangents dx/dxi_d
    g = np.cross(T[:, :, 0], T[:, :, 1]) if ref.dim == 2 else T[:, :, 0]
    size = np.linalg.norm(g, axis=-1)
    if np.any(size <= 1e-12 * np.abs(coords).max()):
        bad = int(np.argwhere(size <= 1e-12 * np.abs(coords).max())[0, 0])
        raise ValueError(f"element {bad} ({ref.name}) is degenerate (zero {'area' if ref.dim == 2 else 'length'})")
    return N, size * w, g / size[..., None]


def _assemble(n: int, conn: np.ndarray, Me: np.ndarray, Te: np.ndarray) -> StructuralMass:
    """Element masses Me (ne, nn, nn) and fibre inertias Te (ne, 3, 3), the latter lumped by HRZ."""
    rows = np.broadcast_to(conn[:, :, None], Me.shape)
    cols = np.broadcast_to(conn[:, None, :], Me.shape)
    Ms = sp.coo_array((Me.ravel(), (rows.ravel(), cols.ravel())), shape=(n, n)).tocsr()
    diag = np.einsum("enn->en", Me)
    J = np.zeros((n, 3, 3))
    np.add.at(J, conn.ravel(), ((diag / diag.sum(axis=1, keepdims=True))[:, :, None, None]
                                * Te[:, None]).reshape(-1, 3, 3))
    return StructuralMass(sp.csr_array(Ms), J)


def shell_mass(points: np.ndarray, cell_type: str, conn: np.ndarray, thickness, rho: float) -> StructuralMass:
    """Ms_ab = int rho t N_a N_b dA and the fibre inertia rho t^3/12 (I - n n^T) per area, lumped (module
    docstring), of the shell cells ``conn`` (ne, nn) with thickness per cell (or one)."""
    ref, conn = SHELLS[cell_type], np.asarray(conn, dtype=np.int64)
    t = np.broadcast_to(np.asarray(thickness, dtype=float), (len(conn),))
    total = StructuralMass.zero(len(points))
    for part in _chunks(len(conn), ref.n_nodes ** 2 * len(ref.rule()[1])):
        N, dA, nrm = _geometry(ref, points[conn[part]])
        Me = rho * np.einsum("e,eq,qn,qm->enm", t[part], dA, N, N, optimize=True)
        fibre = np.eye(3) * dA.sum(axis=1)[:, None, None] - np.einsum("eq,eqa,eqb->eab", dA, nrm, nrm)
        total = total + _assemble(len(points), conn[part], Me, rho * t[part, None, None] ** 3 / 12 * fibre)
    return total


def beam_mass(points: np.ndarray, cell_type: str, conn: np.ndarray, section: BeamSection,
              rho: float) -> StructuralMass:
    """Ms_ab = int rho A N_a N_b ds and the section's inertia rho [I22 e1 e1^T + I33 I + (I22 - I33) e2 e2^T]
    per length, lumped (module docstring), of the beam cells ``conn`` (ne, nn)."""
    ref, conn = BEAMS[cell_type], np.asarray(conn, dtype=np.int64)
    ne = len(conn)
    A, I22, I33 = (np.broadcast_to(np.asarray(a, dtype=float), (ne,)) for a in (section.area, section.I22,
                                                                                 section.I33))
    total = StructuralMass.zero(len(points))
    for part in _chunks(ne, ref.n_nodes ** 2 * len(ref.rule()[1])):
        N, ds, e1 = _geometry(ref, points[conn[part]])
        Me = rho * np.einsum("e,eq,qn,qm->enm", A[part], ds, N, N, optimize=True)
        T = (I22[part, None, None] * np.einsum("eq,eqa,eqb->eab", ds, e1, e1)
             + I33[part, None, None] * np.eye(3) * ds.sum(axis=1)[:, None, None])
        skew = I22[part] != I33[part]
        if np.any(skew):
            e2 = _second_axis(section.orientation, part, e1, skew)
            T += (I22[part] - I33[part])[:, None, None] * np.einsum("eq,eqa,eqb->eab", ds, e2, e2)
        total = total + _assemble(len(points), conn[part], Me, rho * T)
    return total


def _second_axis(orientation, part: slice, e1: np.ndarray, skew: np.ndarray) -> np.ndarray:
    """e2 (ne, nq, 3): the orientation vector without its part along the axis e1, unit; needed where ``skew``
    (I22 != I33) only, elsewhere any unit vector."""
    if orientation is None:
        raise ValueError("a section with I22 != I33 needs an orientation")
    v = np.broadcast_to(np.asarray(orientation, dtype=float), (part.stop - (part.start or 0), 3)) \
        if np.ndim(orientation) == 1 else np.asarray(orientation, dtype=float)[part]
    normal = v[:, None, :] - np.einsum("eqa,ea->eq", e1, v)[..., None] * e1
    size = np.linalg.norm(normal, axis=-1)
    bad = skew & np.any(size <= 1e-6 * np.linalg.norm(v, axis=-1)[:, None], axis=1)
    if np.any(bad):
        raise ValueError(f"the orientation of beam {int(np.argmax(bad)) + (part.start or 0)} is (nearly) along "
                         "its axis")
    return normal / np.where(size > 0, size, 1.0)[..., None]


def point_mass(n: int, nodes: np.ndarray, mass: np.ndarray, inertia: np.ndarray | None = None) -> StructuralMass:
    """Point masses m (k,) with inertia (k, 3, 3) (about their node) at ``nodes`` (k,) of n."""
    nodes = np.asarray(nodes, dtype=np.int64)
    Ms = sp.coo_array((np.asarray(mass, dtype=float), (nodes, nodes)), shape=(n, n)).tocsr()
    J = np.zeros((n, 3, 3))
    if inertia is not None:
        np.add.at(J, nodes, np.asarray(inertia, dtype=float))
    return StructuralMass(sp.csr_array(Ms), J)
