"""Other FE codes' own integration rules, on this package's reference elements (``fe.elements``).

A code normalises its modes with the mass it integrated, which is not the exact
mass where its rule is of lower degree (CalculiX's C3D10: the 4-point rule of
degree 2, where N_a N_b alone has degree 4). A reader that assembles the mass
from a deck passes the code's rules to ``mass_matrix`` / ``stiffness_matrix``.

CALCULIX maps CalculiX 2.20's element names to (meshio cell type, rule); each
rule gives the .mas and .sti that ``*FREQUENCY, SOLVER=MATRIXSTORAGE`` writes for
curved elements to 1e-14 (tests/test_fe_elements.py). C3D8R is absent: its
stiffness carries hourglass control, which no rule reproduces.
"""
from __future__ import annotations

import numpy as np

from . import quadrature

_KEAST_A, _KEAST_B = 0.5854101966249685, 0.1381966011250105  # (5 +- 3 sqrt 5) / 20


def _tetra4() -> tuple[np.ndarray, np.ndarray]:
    """The 4-point tetrahedron rule of degree 2."""
    a, b = _KEAST_A, _KEAST_B
    return np.array([[b, b, b], [a, b, b], [b, a, b], [b, b, a]]), np.full(4, 1 / 24)


def _triangle_by_line(tri: tuple[np.ndarray, np.ndarray], n: int) -> tuple[np.ndarray, np.ndarray]:
    """A triangle rule times n Gauss-Legendre points along the wedge's z in [-1, 1]."""
    rs, wt = tri
    z, wz = np.polynomial.legendre.leggauss(n)
    return np.column_stack([np.repeat(rs, n, axis=0), np.tile(z, len(rs))]), np.repeat(wt, n) * np.tile(wz, len(rs))


_CENTROID = (np.array([[1 / 3, 1 / 3]]), np.array([0.5]))
_TRIANGLE3 = (np.array([[1 / 6, 1 / 6], [2 / 3, 1 / 6], [1 / 6, 2 / 3]]), np.full(3, 1 / 6))  # degree 2, interior

CALCULIX = {
    "C3D4": ("tetra", quadrature.tetra(1)),  # the centroid
    "C3D10": ("tetra10", _tetra4()),
    "C3D6": ("wedge", _triangle_by_line(_CENTROID, 2)),
    "C3D15": ("wedge15", _triangle_by_line(_TRIANGLE3, 3)),
    "C3D8": ("hexahedron", quadrature.hexahedron(2)),
    "C3D20": ("hexahedron20", quadrature.hexahedron(3)),
    "C3D20R": ("hexahedron20", quadrature.hexahedron(2)),
}


def rules_of(code_rules: dict, names: dict[str, str]) -> dict:
    """``mass_matrix``'s rules for a mesh whose cell types came from the code's element ``names`` (type -> name)."""
    return {cell_type: code_rules[name][1] for cell_type, name in names.items() if name in code_rules}
