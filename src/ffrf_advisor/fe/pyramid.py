"""Pyramids of 5 and 13 nodes (VTK order): base [-1, 1]^2 at z = 0 counter-clockwise seen from the apex (0, 0, 1).

Their shape functions are rational in (x, y, z) but polynomials in the
collapsed coordinates a = x / (1 - z), b = y / (1 - z), c = z (u = 1 - c), a
corner (a_i, b_i) = (+-1, +-1):

- pyramid: N_i = u (1 + a_i a)(1 + b_i b) / 4, apex N = c;
- pyramid13 (Bedrosian's serendipity pyramid: quad8 on the base, P2 on the
  triangles): corner N_i = u (1 + a_i a)(1 + b_i b)(-1 + (a_i a + b_i b) u) / 4,
  base mid-edge N = g_a g_b u^2 / 2 (g = 1 - a^2 where a_i = 0, else 1 + a_i a),
  apex-edge N = c u (1 + a_i a)(1 + b_i b), apex N = c (2 c - 1).

Every N is independent of (a, b) at the apex, so dN/da carries a factor u; with
A = dN/da / u, B = dN/db / u, C = dN/dc: dN/dx = A, dN/dy = B, dN/dz = C + a A + b B.
At the apex the gradient depends on the direction of approach; it is taken
along the axis (a = b = 0), where the stresses are recovered.
"""
from __future__ import annotations

import numpy as np

_BASE = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], float)
APEX = np.array([[0.0, 0.0, 1.0]])
PYRAMID5_NODES = np.vstack([_BASE, APEX])
PYRAMID_EDGES = [(0, 1), (1, 2), (2, 3), (3, 0), (0, 4), (1, 4), (2, 4), (3, 4)]
PYRAMID13_NODES = np.vstack([PYRAMID5_NODES, (_BASE + np.roll(_BASE, -1, axis=0)) / 2, (_BASE + APEX) / 2])


def _collapsed(xi: np.ndarray) -> tuple[np.ndarray, ...]:
    """(a, b, c, u) as columns (npts, 1); a = b = 0 at the apex."""
    x, y, c = (xi[:, d][:, None] for d in range(3))
    u = 1 - c
    safe = np.where(u > 1e-12, u, 1.0)
    return np.where(u > 1e-12, x / safe, 0.0), np.where(u > 1e-12, y / safe, 0.0), c, u


def _physical(N, A, B, C, a, b) -> tuple[np.ndarray, np.ndarray]:
    """N and dN/d(x, y, z) from the collapsed derivatives (module docstring)."""
    return N, np.stack([A, B, C + a * A + b * B], axis=-1)


def pyramid5(xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a, b, c, u = _collapsed(xi)
    ai, bi = _BASE[:, 0], _BASE[:, 1]
    fa, fb = 1 + ai * a, 1 + bi * b
    ones = np.ones_like(c)
    N = np.hstack([u * fa * fb / 4, c])
    A = np.hstack([ai * fb / 4, 0 * c])
    B = np.hstack([bi * fa / 4, 0 * c])
    C = np.hstack([-fa * fb / 4, ones])
    return _physical(N, A, B, C, a, b)


def pyramid13(xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a, b, c, u = _collapsed(xi)
    corner = _corners13(a, b, c, u)
    mid = _base_edges13(a, b, c, u)
    side = _apex_edges13(a, b, c, u)
    apex = (c * (2 * c - 1), 0 * c, 0 * c, 4 * c - 1)
    N, A, B, C = (np.hstack([corner[k], apex[k], mid[k], side[k]]) for k in range(4))
    return _physical(N, A, B, C, a, b)


def _corners13(a, b, c, u):
    ai, bi = _BASE[:, 0], _BASE[:, 1]
    fa, fb, s = 1 + ai * a, 1 + bi * b, ai * a + bi * b
    N = u * fa * fb * (-1 + s * u) / 4
    A = ai * fb * (-1 + s * u + fa * u) / 4
    B = bi * fa * (-1 + s * u + fb * u) / 4
    C = fa * fb * (1 - 2 * s * u) / 4
    return N, A, B, C


def _base_edges13(a, b, c, u):
    mid = PYRAMID13_NODES[5:9]
    ai, bi = mid[:, 0], mid[:, 1]
    ga = np.where(ai == 0, 1 - a**2, 1 + ai * a)
    gb = np.where(bi == 0, 1 - b**2, 1 + bi * b)
    dga = np.where(ai == 0, -2 * a, ai)
    dgb = np.where(bi == 0, -2 * b, bi)
    return ga * gb * u**2 / 2, dga * gb * u / 2, ga * dgb * u / 2, -ga * gb * u


def _apex_edges13(a, b, c, u):
    ai, bi = _BASE[:, 0], _BASE[:, 1]
    fa, fb = 1 + ai * a, 1 + bi * b
    return c * u * fa * fb, c * ai * fb, c * bi * fa, (1 - 2 * c) * fa * fb
