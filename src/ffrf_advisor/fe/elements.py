"""Isoparametric solid elements in VTK/meshio node order.

Each element type is given by its family's reference domain (``fe.quadrature``),
its reference node coordinates there (VTK order, so connectivity read by meshio
or written to VTK needs no permutation), its shape functions and two Gauss
rules, ``n`` points per direction of its family's rule:

- ``mass_order`` integrates N_a N_b det J exactly on any isoparametric element,
  curved ones included (the degrees below, per reference coordinate, or total
  degree on tetrahedra and the wedge's triangle);
- ``gauss_order`` integrates the stiffness of a straight-sided (affine)
  element exactly (the tensor hexahedra: their usual full rules).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from . import quadrature
from .lagrange import LagrangeBasis, tetra_exponents, wedge_exponents
from .pyramid import PYRAMID5_NODES, PYRAMID13_NODES, PYRAMID_EDGES, pyramid5, pyramid13

_CORNERS = np.array(
    [[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
     [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], dtype=float)
EDGES = [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4),
          (0, 4), (1, 5), (2, 6), (3, 7)]
# VTK_TRIQUADRATIC_HEXAHEDRON face centres: -x, +x, -y, +y, -z, +z, then the body centre.
_FACES = np.array([[-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 1, 0], [0, 0, -1], [0, 0, 1]], float)
_EDGE_MIDS = np.array([(_CORNERS[a] + _CORNERS[b]) / 2 for a, b in EDGES])


@dataclass(frozen=True)
class ElementType:
    """A solid element: meshio name, family (reference domain), reference nodes, basis, Gauss orders."""

    name: str
    family: str  # a key of quadrature.RULES
    ref_nodes: np.ndarray  # (nn, 3)
    basis: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
    gauss_order: int  # points per direction: stiffness of affine elements exact
    mass_order: int  # points per direction: N_a N_b det J exact on curved elements

    @property
    def n_nodes(self) -> int:
        return len(self.ref_nodes)

    def shape(self, xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Shape functions N (npts, nn) and derivatives dN/dxi (npts, nn, 3) at xi (npts, 3)."""
        return self.basis(np.atleast_2d(np.asarray(xi, float)))

    def gauss_rule(self, order: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The family's rule of ``order`` (default ``gauss_order``) points per direction: points (nq, 3), weights."""
        return quadrature.RULES[self.family](order or self.gauss_order)

    def mass_rule(self) -> tuple[np.ndarray, np.ndarray]:
        """The rule exact for the consistent mass of a curved element (``mass_order``)."""
        return self.gauss_rule(self.mass_order)


def _lagrange_1d(t: np.ndarray, a: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray]:
    """1D Lagrange basis on nodes {-1, 1} (order 1) or {-1, 0, 1} (order 2), node values a."""
    t = t[:, None]
    if order == 1:
        return 0.5 * (1 + a * t), 0.5 * a * np.ones_like(t)
    value = np.where(a == 0, 1 - t**2, 0.5 * t * (t + a))
    deriv = np.where(a == 0, -2 * t, t + 0.5 * a)
    return value, deriv


def _lagrange_tensor(ref: np.ndarray, xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    order = 2 if np.any(ref == 0) else 1
    vals, ders = zip(*(_lagrange_1d(xi[:, d], ref[:, d], order) for d in range(3)))
    N = vals[0] * vals[1] * vals[2]
    dN = np.stack([ders[0] * vals[1] * vals[2],
                   vals[0] * ders[1] * vals[2],
                   vals[0] * vals[1] * ders[2]], axis=-1)
    return N, dN


def _serendipity20(ref: np.ndarray, xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    x, y, z = (xi[:, d][:, None] for d in range(3))
    a, b, c = ref[:, 0], ref[:, 1], ref[:, 2]
    fx, fy, fz = 1 + a * x, 1 + b * y, 1 + c * z
    corner = (a != 0) & (b != 0) & (c != 0)
    s = a * x + b * y + c * z - 2
    N_c = fx * fy * fz * s / 8
    dN_c = np.stack([a * fy * fz * (s + fx), b * fx * fz * (s + fy), c * fx * fy * (s + fz)], -1) / 8
    # mid-edge nodes: one reference coordinate is zero
    gx = np.where(a == 0, 1 - x**2, fx)
    gy = np.where(b == 0, 1 - y**2, fy)
    gz = np.where(c == 0, 1 - z**2, fz)
    dgx = np.where(a == 0, -2 * x, a)
    dgy = np.where(b == 0, -2 * y, b)
    dgz = np.where(c == 0, -2 * z, c)
    N_e = gx * gy * gz / 4
    dN_e = np.stack([dgx * gy * gz, gx * dgy * gz, gx * gy * dgz], -1) / 4
    N = np.where(corner, N_c, N_e)
    dN = np.where(corner[None, :, None], dN_c, dN_e)
    return N, dN


def _hexahedron(name: str, ref: np.ndarray, basis, gauss_order: int, mass_order: int) -> ElementType:
    return ElementType(name, "hexahedron", ref, lambda xi: basis(ref, xi), gauss_order, mass_order)


def _edge_nodes(corners: np.ndarray, edges: list[tuple[int, int]]) -> np.ndarray:
    return np.vstack([corners, [(corners[a] + corners[b]) / 2 for a, b in edges]])


def _lagrange(name: str, family: str, ref: np.ndarray, exps: np.ndarray, gauss_order: int,
              mass_order: int) -> ElementType:
    return ElementType(name, family, ref, LagrangeBasis(ref, exps), gauss_order, mass_order)


_TET = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
TETRA_EDGES = [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)]
_WEDGE = np.array([[0, 0, -1], [1, 0, -1], [0, 1, -1], [0, 0, 1], [1, 0, 1], [0, 1, 1]], float)
WEDGE_EDGES = [(0, 1), (1, 2), (2, 0), (3, 4), (4, 5), (5, 3), (0, 3), (1, 4), (2, 5)]

# Stiffness (gauss_order): grad N_a . grad N_b of an affine element, degree 2 (p - 1) in total on tetrahedra and
# triangles, per coordinate elsewhere: tetra 1, tetra10 2, wedge 2, wedge15 3 (degree 4), pyramid 2, pyramid13 3.
# Mass degrees per reference coordinate (N_a N_b: 2p, det J of the isoparametric map: sum of its columns' degrees):
# hexahedron 2 + 2 = 4 -> 3 points; hexahedron20/27 4 + 5 = 9 -> 5 points.
HEX8 = _hexahedron("hexahedron", _CORNERS, _lagrange_tensor, 2, 3)
HEX20 = _hexahedron("hexahedron20", np.vstack([_CORNERS, _EDGE_MIDS]), _serendipity20, 3, 5)
HEX27 = _hexahedron("hexahedron27", np.vstack([_CORNERS, _EDGE_MIDS, _FACES, np.zeros((1, 3))]),
                    _lagrange_tensor, 3, 5)
# Total degree on the tetrahedron: tetra 2 + 0 -> 2 points (exact to 3); tetra10 4 + 3 = 7 -> 4 points.
TET4 = _lagrange("tetra", "tetra", _TET, tetra_exponents(1), 1, 2)
TET10 = _lagrange("tetra10", "tetra", _edge_nodes(_TET, TETRA_EDGES), tetra_exponents(2), 2, 4)
# (triangle total degree, degree along z): wedge (2, 2) + (1, 2) = (3, 4) -> 3 points; wedge15 (4, 4) + (4, 5) ->
# (8, 9) -> 5 points.
WEDGE6 = _lagrange("wedge", "wedge", _WEDGE, wedge_exponents(1), 2, 3)
WEDGE15 = _lagrange("wedge15", "wedge", _edge_nodes(_WEDGE, WEDGE_EDGES), wedge_exponents(2), 3, 5)
# Collapsed coordinates (a, b, c) (fe.pyramid): det(dx/d(a, b, c)) = (1 - c)^2 g, the Gauss-Jacobi weight times g;
# N_a N_b g has degree (3, 3, 2) for the pyramid (g is linear in a and in b: the a-terms of its b column are
# parallel to the ab-terms of its c column) -> 2 points; (9, 9, 7) for pyramid13 -> 5 points.
PYR5 = ElementType("pyramid", "pyramid", PYRAMID5_NODES, pyramid5, 2, 2)
PYR13 = ElementType("pyramid13", "pyramid", PYRAMID13_NODES, pyramid13, 3, 5)

ELEMENT_TYPES = {e.name: e for e in (HEX8, HEX20, HEX27, TET4, TET10, WEDGE6, WEDGE15, PYR5, PYR13)}


# Faces by corner index, normals outward (right-hand rule), per family.
_CORNER_FACES = {
    "hexahedron": ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)),
    "tetra": ((0, 2, 1), (0, 1, 3), (1, 2, 3), (2, 0, 3)),
    "wedge": ((0, 2, 1), (3, 4, 5), (0, 1, 4, 3), (1, 2, 5, 4), (2, 0, 3, 5)),
    "pyramid": ((0, 3, 2, 1), (0, 1, 4), (1, 2, 4), (2, 3, 4), (3, 0, 4)),
}
_EDGE_LISTS = {"hexahedron": EDGES, "tetra": TETRA_EDGES, "wedge": WEDGE_EDGES, "pyramid": PYRAMID_EDGES}


def element_faces(name: str) -> tuple[tuple[int, ...], ...]:
    """The faces of a cell type as rings of its node indices, outward: corners, or corner, mid-edge, corner, ...
    for the quadratic types (their mid-face and centre nodes left out, as the 27-node hexahedron's)."""
    etype = element_type(name)
    edges = _EDGE_LISTS[etype.family]
    corners = len({i for face in _CORNER_FACES[etype.family] for i in face})
    if etype.n_nodes == corners:
        return _CORNER_FACES[etype.family]
    mid = {frozenset(e): corners + k for k, e in enumerate(edges)}
    return tuple(tuple(x for a, b in zip(face, face[1:] + face[:1]) for x in (a, mid[frozenset((a, b))]))
                 for face in _CORNER_FACES[etype.family])


def element_type(name: str) -> ElementType:
    """Look up a supported solid element by its meshio cell-type name."""
    try:
        return ELEMENT_TYPES[name]
    except KeyError:
        raise ValueError(
            f"unsupported cell type {name!r}; supported: {', '.join(ELEMENT_TYPES)}") from None
