"""Isoparametric solid elements in VTK/meshio node order.

Each element type is given by its reference node coordinates on [-1, 1]^3
(VTK order, so connectivity read by meshio or written to VTK needs no
permutation), its shape functions and a Gauss rule that integrates the
mass matrix of an undistorted element exactly.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from itertools import product

import numpy as np

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
    """A hexahedral element family: meshio name, reference nodes, Gauss order."""

    name: str
    ref_nodes: np.ndarray  # (nn, 3)
    gauss_order: int

    @property
    def n_nodes(self) -> int:
        return len(self.ref_nodes)

    def shape(self, xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Shape functions N (npts, nn) and derivatives dN/dxi (npts, nn, 3) at xi (npts, 3)."""
        xi = np.atleast_2d(np.asarray(xi, float))
        if self.name == "hexahedron20":
            return _serendipity20(xi, self.ref_nodes)
        return _lagrange_tensor(xi, self.ref_nodes)

    def gauss_rule(self) -> tuple[np.ndarray, np.ndarray]:
        """Tensor Gauss-Legendre points (nq, 3) and weights (nq,)."""
        return _gauss_rule(self.gauss_order)


def _lagrange_1d(t: np.ndarray, a: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray]:
    """1D Lagrange basis on nodes {-1, 1} (order 1) or {-1, 0, 1} (order 2), node values a."""
    t = t[:, None]
    if order == 1:
        return 0.5 * (1 + a * t), 0.5 * a * np.ones_like(t)
    value = np.where(a == 0, 1 - t**2, 0.5 * t * (t + a))
    deriv = np.where(a == 0, -2 * t, t + 0.5 * a)
    return value, deriv


def _lagrange_tensor(xi: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    order = 2 if np.any(ref == 0) else 1
    vals, ders = zip(*(_lagrange_1d(xi[:, d], ref[:, d], order) for d in range(3)))
    N = vals[0] * vals[1] * vals[2]
    dN = np.stack([ders[0] * vals[1] * vals[2],
                   vals[0] * ders[1] * vals[2],
                   vals[0] * vals[1] * ders[2]], axis=-1)
    return N, dN


def _serendipity20(xi: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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


@cache
def _gauss_rule(order: int) -> tuple[np.ndarray, np.ndarray]:
    t, w = np.polynomial.legendre.leggauss(order)
    pts = np.array(list(product(t, t, t)))
    wts = np.array([wi * wj * wk for wi, wj, wk in product(w, w, w)])
    return pts, wts


HEX8 = ElementType("hexahedron", _CORNERS, 2)
HEX20 = ElementType("hexahedron20", np.vstack([_CORNERS, _EDGE_MIDS]), 3)
HEX27 = ElementType("hexahedron27", np.vstack([_CORNERS, _EDGE_MIDS, _FACES, np.zeros((1, 3))]), 3)

ELEMENT_TYPES = {e.name: e for e in (HEX8, HEX20, HEX27)}


def element_type(name: str) -> ElementType:
    """Look up a supported solid element by its meshio cell-type name."""
    try:
        return ELEMENT_TYPES[name]
    except KeyError:
        raise ValueError(
            f"unsupported cell type {name!r}; supported: {', '.join(ELEMENT_TYPES)}") from None
