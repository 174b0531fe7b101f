"""Gauss rules of ``n`` points per direction on each solid family's reference domain.

Hexahedron [-1, 1]^3: tensor Gauss-Legendre, exact for degree 2n - 1 in each
coordinate. Tetrahedron {r, s, t >= 0, r + s + t <= 1}, the wedge's triangle
{r, s >= 0, r + s <= 1} x [-1, 1] and the pyramid (base [-1, 1]^2 at t = 0, apex
(0, 0, 1)) are images of a cube under the collapsed (Duffy) map; the collapse
factors (1 - t)^k of its Jacobian are Gauss-Jacobi weights, so a rule is exact
where the integrand times that Jacobian is a polynomial of degree 2n - 1 in each
cube coordinate: every polynomial of total degree 2n - 1 on a tetrahedron or
triangle, and the pyramid's rational shape functions, which are polynomials in
the collapsed coordinates (``fe.pyramid``).
"""
from __future__ import annotations

from functools import cache
from itertools import product

import numpy as np
from scipy.special import roots_jacobi


@cache
def _line(n: int, alpha: int) -> tuple[np.ndarray, np.ndarray]:
    """Points on [0, 1] and weights of int_0^1 (1 - t)^alpha f(t) dt, exact for f of degree 2n - 1."""
    x, w = roots_jacobi(n, alpha, 0)
    return (1 + x) / 2, w / 2 ** (alpha + 1)


def _tensor(*rules: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Tensor product of 1D rules: points (nq, len(rules)), weights (nq,)."""
    pts = np.array(list(product(*(r[0] for r in rules))))
    wts = np.prod(np.array(list(product(*(r[1] for r in rules)))), axis=1)
    return pts, wts


def _legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    t, w = _line(n, 0)
    return 2 * t - 1, 2 * w


@cache
def hexahedron(n: int) -> tuple[np.ndarray, np.ndarray]:
    """n^3 Gauss-Legendre points on [-1, 1]^3."""
    return _tensor(_legendre(n), _legendre(n), _legendre(n))


@cache
def tetra(n: int) -> tuple[np.ndarray, np.ndarray]:
    """n^3 collapsed points: t = c, s = b (1 - c), r = a (1 - b)(1 - c); dV = (1 - b)(1 - c)^2 da db dc."""
    abc, w = _tensor(_line(n, 0), _line(n, 1), _line(n, 2))
    a, b, c = abc.T
    return np.column_stack([a * (1 - b) * (1 - c), b * (1 - c), c]), w


@cache
def triangle(n: int) -> tuple[np.ndarray, np.ndarray]:
    """n^2 collapsed points on the unit triangle: s = b, r = a (1 - b); dA = (1 - b) da db."""
    ab, w = _tensor(_line(n, 0), _line(n, 1))
    return np.column_stack([ab[:, 0] * (1 - ab[:, 1]), ab[:, 1]]), w


@cache
def wedge(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The triangle's n^2 points times n Gauss-Legendre points along [-1, 1]."""
    (rs, wt), (z, wz) = triangle(n), _legendre(n)
    pts = np.column_stack([np.repeat(rs, n, axis=0), np.tile(z, len(rs))])
    return pts, np.repeat(wt, n) * np.tile(wz, len(rs))


@cache
def pyramid(n: int) -> tuple[np.ndarray, np.ndarray]:
    """n^3 collapsed points: x = a (1 - c), y = b (1 - c), z = c with a, b in [-1, 1]; dV = (1 - c)^2 da db dc."""
    (a, wa), (c, wc) = _legendre(n), _line(n, 2)
    abc, w = _tensor((a, wa), (a, wa), (c, wc))
    return np.column_stack([abc[:, 0] * (1 - abc[:, 2]), abc[:, 1] * (1 - abc[:, 2]), abc[:, 2]]), w


RULES = {"hexahedron": hexahedron, "tetra": tetra, "wedge": wedge, "pyramid": pyramid}
