"""Nastran solid elements (CTETRA, CPENTA, CPYRAM, CHEXA) as cells of the FE module (meshio names, VTK node order).

Corners: Nastran and VTK number them alike. Mid-side nodes: CTETRA10 and CPYRAM13 alike too; CPENTA15 and
CHEXA20 list the edges between the two end faces before the top face's edges, VTK after them. Nastran takes
either handedness of an element, the FE module the VTK one (``CORNER_TET`` of positive volume), so a mirrored
element is renumbered to its mirror image: the same solid, the same mass.
"""
from __future__ import annotations

import numpy as np

from ..errors import BodyFileError
from ..fe.assembly import mass_matrix
from ..fe.mesh import Mesh

CELLS = {("CTETRA", 4): "tetra", ("CTETRA", 10): "tetra10", ("CPENTA", 6): "wedge", ("CPENTA", 15): "wedge15",
         ("CPYRAM", 5): "pyramid", ("CPYRAM", 13): "pyramid13", ("CHEXA", 8): "hexahedron",
         ("CHEXA", 20): "hexahedron20"}
SOLIDS = tuple(sorted({name for name, _ in CELLS}))
NASTRAN = {cell: name for (name, _), cell in CELLS.items()}
# VTK node k of a cell is Nastran grid TO_VTK[cell][k] of the element (identity where absent).
TO_VTK = {"wedge15": [0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 13, 14, 9, 10, 11],
          "hexahedron20": list(range(12)) + list(range(16, 20)) + list(range(12, 16))}
# The mirror image of a cell in VTK order: two corners of the first face swapped, and their edges with them.
MIRROR = {"tetra": [0, 2, 1, 3], "tetra10": [0, 2, 1, 3, 6, 5, 4, 7, 9, 8],
          "wedge": [0, 2, 1, 3, 5, 4], "wedge15": [0, 2, 1, 3, 5, 4, 8, 7, 6, 11, 10, 9, 12, 14, 13],
          "pyramid": [0, 3, 2, 1, 4], "pyramid13": [0, 3, 2, 1, 4, 8, 7, 6, 5, 9, 12, 11, 10],
          "hexahedron": [0, 3, 2, 1, 4, 7, 6, 5],
          "hexahedron20": [0, 3, 2, 1, 4, 7, 6, 5, 11, 10, 9, 8, 15, 14, 13, 12, 16, 19, 18, 17]}
# Four corners spanning a positive volume in VTK order (the reference element's own, fe.elements).
CORNER_TET = {"tetra": [0, 1, 2, 3], "wedge": [0, 1, 2, 3], "pyramid": [0, 1, 3, 4], "hexahedron": [0, 1, 3, 4]}


def cell_of(path, e, nodes: list[int]) -> str:
    """The meshio cell of Nastran solid ``e`` with ``nodes`` (its grids given, blanks left out)."""
    cell = CELLS.get((e.type, len(nodes)))
    if cell is None:
        counts = " or ".join(str(k) for t, k in CELLS if t == e.type)
        raise BodyFileError(path, f"{e.type} {e.eid}", f"{counts} grids (every mid-side grid or none: the FE "
                            "module has no element with some of them)", str(len(nodes)))
    return cell


def to_vtk(cell: str, nodes: list[int]) -> list[int]:
    """The element's grid indices in VTK order."""
    order = TO_VTK.get(cell)
    return nodes if order is None else [nodes[k] for k in order]


def corner_volume(cell: str, X: np.ndarray) -> np.ndarray:
    """Six times the signed volume of each cell's corner tetrahedron, X (ne, nn, 3) in VTK order."""
    a, b, c, d = CORNER_TET[cell.rstrip("0123456789")]
    return np.einsum("ei,ei->e", X[:, b] - X[:, a], np.cross(X[:, c] - X[:, a], X[:, d] - X[:, a]))


def oriented(cell: str, conn: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``conn`` (ne, nn) with its mirrored cells renumbered to their mirror images, and which were."""
    mirrored = corner_volume(cell, points[conn]) < 0
    out = conn.copy()
    out[mirrored] = conn[mirrored][:, MIRROR[cell]]
    return out, mirrored


def solid_mass(path, points: np.ndarray, cell: str, conn: np.ndarray, eids: np.ndarray, rho: float):
    """The consistent scalar mass of one block of cells; an inverted or degenerate one named by its Nastran id."""
    try:
        return mass_matrix(Mesh(points, {cell: conn}), rho)
    except ValueError:
        k = _first_failing(points, cell, conn)
        raise BodyFileError(path, f"{NASTRAN[cell]} {eids[k]}", "an element whose Jacobian is positive throughout "
                            "(grids in Nastran's order, not folded or degenerate)", "an inverted or degenerate "
                            "element") from None


def _first_failing(points: np.ndarray, cell: str, conn: np.ndarray) -> int:
    """The first cell the FE module refuses (bisection: log2(ne) assemblies of shrinking blocks)."""
    lo, hi = 0, len(conn)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        try:
            mass_matrix(Mesh(points, {cell: conn[lo:mid]}), 1.0)
            lo = mid
        except ValueError:
            hi = mid
    return lo

