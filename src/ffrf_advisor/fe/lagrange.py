"""Nodal (Lagrange) bases of tetrahedra and wedges from their polynomial spaces.

A basis is the polynomial space's monomials x^i y^j z^k times the inverse of
their values at the reference nodes (the Vandermonde matrix), so
N_a(node_b) = delta_ab by construction:

- tetra (4): total degree <= 1; tetra10: total degree <= 2 (P2);
- wedge (6): P1(r, s) x P1(z); wedge15: P2(r, s) x P1(z) + P1(r, s) z^2, the
  15-node serendipity wedge, quadratic along every edge and P2 on its
  triangles, so it conforms with tetra10 and the 20-node hexahedron.
"""
from __future__ import annotations

import numpy as np


def tetra_exponents(degree: int) -> np.ndarray:
    """Exponents (i, j, k) with i + j + k <= degree."""
    r = range(degree + 1)
    return np.array([(i, j, k) for i in r for j in r for k in r if i + j + k <= degree])


def wedge_exponents(degree: int) -> np.ndarray:
    """Exponents of P1 or the 15-node serendipity space (module docstring) on triangle x line."""
    r = range(degree + 1)
    low = [(i, j, k) for i in r for j in r for k in (0, 1) if i + j <= degree]
    return np.array(low + ([(0, 0, 2), (1, 0, 2), (0, 1, 2)] if degree == 2 else []))


def _monomials(xi: np.ndarray, exps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Values (npts, m) and gradients (npts, m, 3) of the monomials prod_d xi_d^exps[m, d]."""
    powers = xi[:, None, :] ** exps[None]  # (npts, m, 3)
    lower = np.where(exps > 0, xi[:, None, :] ** np.maximum(exps - 1, 0) * exps, 0.0)
    grads = np.stack([lower[..., d] * np.prod(np.delete(powers, d, axis=2), axis=2) for d in range(3)], -1)
    return np.prod(powers, axis=2), grads


class LagrangeBasis:
    """Shape functions N (npts, nn) and dN/dxi (npts, nn, 3) of the space ``exps`` on the nodes ``ref_nodes``."""

    def __init__(self, ref_nodes: np.ndarray, exps: np.ndarray):
        self.exps = exps
        self.inverse = np.linalg.inv(_monomials(ref_nodes, exps)[0])

    def __call__(self, xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        P, dP = _monomials(xi, self.exps)
        return P @ self.inverse, np.einsum("pmd,mn->pnd", dP, self.inverse)
