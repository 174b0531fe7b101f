"""An L-bracket with a hole, meshed by gmsh (OCC kernel) in each solid element type, as a project Mesh.

The L-shaped profile [0, 60] x [0, 20] united with [0, 20] x [0, 50] (mm), a
hole of radius 5 at (42, 10), extruded 10 mm along z. Tetrahedra are meshed
in the volume; wedges and hexahedra are the profile's triangles or quads
extruded in layers. Quadratic elements take gmsh's nodes on the geometry
(curved hole edges), serendipity for hexahedra and wedges.
"""
from __future__ import annotations

import numpy as np

from ffrf_advisor.fe.mesh import Mesh

KINDS = ("tetra", "tetra10", "wedge", "wedge15", "hexahedron", "hexahedron20")
THICKNESS = 10.0
HOLE = (42.0, 10.0, 5.0)  # centre x, y and radius of the hole (mm)


def _profile(gmsh) -> int:
    occ = gmsh.model.occ
    legs = [(2, occ.addRectangle(0, 0, 0, 60, 20)), (2, occ.addRectangle(0, 0, 0, 20, 50))]
    (plate,), _ = occ.fuse(legs[:1], legs[1:])
    (face,), _ = occ.cut([plate], [(2, occ.addDisk(*HOLE[:2], 0, HOLE[2], HOLE[2]))])
    return face[1]


def _build(gmsh, kind: str, size: float) -> None:
    occ, mesh = gmsh.model.occ, gmsh.model.mesh
    face = _profile(gmsh)
    layered = not kind.startswith("tetra")
    occ.extrude([(2, face)], 0, 0, THICKNESS, numElements=[2] if layered else [], recombine=layered)
    occ.synchronize()
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    gmsh.option.setNumber("Mesh.MeshSizeMin", size / 2)
    if kind.startswith("hexahedron"):
        mesh.setRecombine(2, face)
        gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 1)
    gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 1)
    mesh.generate(3)
    if kind[-2:] in ("10", "15", "20"):
        mesh.setOrder(2)


N_NODES = {"tetra": 4, "tetra10": 10, "wedge": 6, "wedge15": 15, "hexahedron": 8, "hexahedron20": 20}
GMSH_TYPES = {"tetra": 4, "tetra10": 11, "wedge": 6, "wedge15": 18, "hexahedron": 5, "hexahedron20": 17}


def l_bracket(kind: str, size: float = 8.0) -> Mesh:
    """The bracket meshed in ``kind`` (KINDS; a meshio name) with element size ``size`` mm, VTK node order
    (meshio's permutation of gmsh's order)."""
    import gmsh
    from meshio.gmsh.common import _gmsh_to_meshio_order

    gmsh.initialize(["-noenv"], readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        _build(gmsh, kind, size)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        _, nodes = gmsh.model.mesh.getElementsByType(GMSH_TYPES[kind])
    finally:
        gmsh.finalize()
    points = np.zeros((int(tags.max()) + 1, 3))
    points[tags.astype(np.int64)] = coords.reshape(-1, 3)
    conn = _gmsh_to_meshio_order(kind, nodes.astype(np.int64).reshape(-1, N_NODES[kind]))
    used, inverse = np.unique(conn, return_inverse=True)  # the nodes of the volume's elements, numbered from 0
    return Mesh(points[used], {kind: inverse.reshape(conn.shape).astype(np.int64)})


def l_profile(size: float = 8.0) -> tuple[np.ndarray, np.ndarray]:
    """The bracket's profile (z = 0) meshed in 8-node quadrilaterals: points (n, 3), quad8 cells (VTK order, which
    is CalculiX's S8 order)."""
    import gmsh

    gmsh.initialize(["-noenv"], readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        face = _profile(gmsh)
        gmsh.model.occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.option.setNumber("Mesh.MeshSizeMin", size / 2)
        gmsh.model.mesh.setRecombine(2, face)
        gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 1)
        gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 1)
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(2)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        _, nodes = gmsh.model.mesh.getElementsByType(16)  # gmsh's 8-node quadrangle, VTK order
    finally:
        gmsh.finalize()
    points = np.zeros((int(tags.max()) + 1, 3))
    points[tags.astype(np.int64)] = coords.reshape(-1, 3)
    used, inverse = np.unique(nodes.astype(np.int64), return_inverse=True)
    return points[used], inverse.reshape(-1, 8)
