"""Tetrahedral, wedge and pyramid meshes of boxes: a structured hexahedral grid split cell by cell.

Every cell is split the same way, so the pieces conform across the grid:
six tetrahedra around its diagonal 0-6 (Kuhn's triangulation), two wedges
over its bottom diagonal 0-2 (top 4-6, the diagonals Kuhn's tetrahedra put on
those faces), or six pyramids on its faces with a new node at its centre.
``quadratic`` adds mid-edge nodes (tetra10, wedge15, pyramid13, hexahedron20);
map the mesh afterwards (``Mesh.mapped``) to curve the elements.
"""
from __future__ import annotations

from itertools import permutations

import numpy as np

from .elements import EDGES, TETRA_EDGES, WEDGE_EDGES, element_type
from .mesh import Mesh, box_mesh
from .pyramid import PYRAMID_EDGES

_VERTEX = {(0, 0, 0): 0, (1, 0, 0): 1, (1, 1, 0): 2, (0, 1, 0): 3,
           (0, 0, 1): 4, (1, 0, 1): 5, (1, 1, 1): 6, (0, 1, 1): 7}  # VTK hexahedron corners by (x, y, z) bits


def _kuhn() -> np.ndarray:
    """The six tetrahedra (6, 4) of the unit cube's paths 0 -> 6, one axis step at a time."""
    tets = []
    for axes in permutations(range(3)):
        v = np.zeros(3, int)
        path = [_VERTEX[tuple(v)]]
        for a in axes:
            v[a] = 1
            path.append(_VERTEX[tuple(v)])
        tets.append(path)
    return np.array(tets)


_PIECES = {
    "tetra": _kuhn(),
    "wedge": np.array([[0, 1, 2, 4, 5, 6], [0, 2, 3, 4, 6, 7]]),
    "pyramid": np.array([[0, 1, 2, 3, 8], [4, 7, 6, 5, 8], [0, 4, 5, 1, 8],
                         [1, 5, 6, 2, 8], [2, 6, 7, 3, 8], [3, 7, 4, 0, 8]]),  # 8: the cell's centre
}
_FLIP = {"tetra": [0, 2, 1, 3], "wedge": [0, 2, 1, 3, 5, 4], "pyramid": [0, 3, 2, 1, 4]}
_QUADRATIC = {"tetra": ("tetra10", TETRA_EDGES), "wedge": ("wedge15", WEDGE_EDGES),
              "pyramid": ("pyramid13", PYRAMID_EDGES), "hexahedron": ("hexahedron20", EDGES)}


def split_hexahedra(mesh: Mesh, kind: str) -> Mesh:
    """A mesh of 8-node hexahedra with each cell split into ``kind`` ('tetra', 'wedge', 'pyramid')."""
    hexes = mesh.cells["hexahedron"]
    points = mesh.points
    if kind == "pyramid":
        centres = points[hexes].mean(axis=1)
        hexes = np.column_stack([hexes, mesh.n_nodes + np.arange(len(hexes))])
        points = np.vstack([points, centres])
    conn = hexes[:, _PIECES[kind]].reshape(-1, _PIECES[kind].shape[1])
    return Mesh(points, {kind: _oriented(points, conn, kind)})


def _oriented(points: np.ndarray, conn: np.ndarray, kind: str) -> np.ndarray:
    """Connectivity with every element of negative det J (at its reference centroid) mirrored."""
    etype = element_type(kind)
    _, dN = etype.shape(etype.ref_nodes.mean(axis=0))
    detJ = np.linalg.det(np.einsum("na,enb->eab", dN[0], points[conn]))
    return np.where((detJ < 0)[:, None], conn[:, _FLIP[kind]], conn)


def quadratic(mesh: Mesh) -> Mesh:
    """The mesh with a node at the middle of every edge, its linear cells now quadratic (same corners)."""
    n = mesh.n_nodes
    pairs = {}
    for name, conn in mesh.cells.items():
        edges = np.array(_QUADRATIC[name][1])
        ends = np.sort(conn[:, edges], axis=2)  # (ne, nedges, 2)
        pairs[name] = ends[..., 0].astype(np.int64) * n + ends[..., 1]
    keys, inverse = np.unique(np.concatenate([p.ravel() for p in pairs.values()]), return_inverse=True)
    a, b = np.divmod(keys, n)
    points = np.vstack([mesh.points, (mesh.points[a] + mesh.points[b]) / 2])
    cells, start = {}, 0
    for name, conn in mesh.cells.items():
        size = pairs[name].size
        mids = n + inverse[start:start + size].reshape(pairs[name].shape)
        cells[_QUADRATIC[name][0]] = np.hstack([conn, mids])
        start += size
    return Mesh(points, cells)


def box_split_mesh(size, divisions, cell_type: str, centred: bool = True) -> Mesh:
    """A box of ``size`` in ``divisions`` hexahedral cells split into ``cell_type`` (tetra, tetra10, wedge,
    wedge15, pyramid, pyramid13; a hexahedron type is ``box_mesh``'s): e.g. the quadratic-tetrahedron bodies of
    the benchmarks."""
    kind = cell_type.rstrip("0123456789")
    if kind == "hexahedron":
        return box_mesh(size, divisions, cell_type, centred)
    mesh = split_hexahedra(box_mesh(size, divisions, "hexahedron", centred), kind)
    return mesh if cell_type == kind else quadratic(mesh)


def by_position(mesh: Mesh) -> Mesh:
    """The mesh with its nodes numbered by position, x slowest, z fastest: a node's neighbours lie within about
    one y-z layer of nodes in the numbering (so blocks of mass rows reach few other blocks)."""
    order = np.lexsort(mesh.points.T[::-1])  # new -> old
    inverse = np.empty_like(order)
    inverse[order] = np.arange(len(order))
    return Mesh(mesh.points[order], {name: inverse[conn] for name, conn in mesh.cells.items()})
