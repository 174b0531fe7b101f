"""MAPDL elements of a run as meshio cells in VTK node order, and the element types the reader refuses.

MAPDL writes a wedge, pyramid or tetrahedron of SOLID185 and SOLID186 as the brick with repeated corner node
numbers (the Element Reference's geometry of each; ansys-mapdl-reader's VTK conversion tells them apart the same
way): prism K=L, O=P; pyramid M=N=O=P; tetrahedron K=L, M=N=O=P (corners I J K L M N O P). SOLID186's mid-side
nodes Q R S T (on IJ JK KL LI), U V W X (MN NO OP PM), Y Z A B (IM JN KO LP) of the edges that remain give the
15-node wedge, 13-node pyramid and 10-node tetrahedron of MAPDL's theory manual (fe.elements); those of
collapsed edges are not read (MAPDL writes them with a coincident node, a tetrahedron's S with its apex).
SOLID187: corners I J K L, mid-side nodes M N O P Q R on IJ JK KI IL JL KL, VTK's tetra10 order; written with its
four corners only when its mid-side nodes were removed (straight edges, a linear field: a 4-node tetra).
The brick's bottom I J K (L) turns about the axis towards its top, as the fe.elements reference shapes do.
"""
from __future__ import annotations

import numpy as np

from ..errors import BodyFileError

I, J, K, L, M, N, O, P, Q, R, S, T, U, V, W, X, Y, Z, A, B = range(20)
TOP = (M, N, O, P)
CORNERS = {"brick": (), "prism": ((K, L), (O, P)), "pyramid": (TOP,), "tetrahedron": ((K, L), TOP)}
SHAPES = {  # (routine, nodes listed) -> corner form -> (meshio type, VTK order of the listed nodes)
    (185, 8): {"brick": ("hexahedron", tuple(range(8))), "prism": ("wedge", (I, J, K, M, N, O)),
               "pyramid": ("pyramid", (I, J, K, L, M)), "tetrahedron": ("tetra", (I, J, K, M))},
    (186, 20): {"brick": ("hexahedron20", tuple(range(20))),
                "prism": ("wedge15", (I, J, K, M, N, O, Q, R, T, U, V, X, Y, Z, A)),
                "pyramid": ("pyramid13", (I, J, K, L, M, Q, R, S, T, Y, Z, A, B)),
                "tetrahedron": ("tetra10", (I, J, K, M, Q, R, T, Y, Z, A))},
    (187, 10): {"tetrahedron": ("tetra10", tuple(range(10)))}, (187, 4): {"tetrahedron": ("tetra", tuple(range(4)))}}
SOLIDS = ("SOLID185", "SOLID186", "SOLID187")
NO_SOLUTION = {200: "MESH200"}  # mesh-only elements: no mass, no stiffness
HEADER_WORDS = 10  # a row of the library's element table: 10 header words, then the element's nodes
POINT_MASS = 21  # MASS21: its mass is in the .full's M; without rotary inertia (KEYOPT(3)=2) UX, UY, UZ only
READ = "SOLID185, SOLID186, SOLID187 and MASS21 without rotary inertia (KEYOPT(3)=2)"
WAY_FORWARD = "mesh the part with these, or read shells, beams and rotary inertia from a Nastran run (theory 3b)"


def refuse_unreadable(rst, names: list[str], dofs: list[str]) -> None:
    """One line naming the element types the reader cannot carry and the way forward, if any."""
    counts = {t: names.count(t) for t in sorted(set(names))}
    other = {t: c for t, c in counts.items() if t not in SOLIDS and t not in ("MASS21", *NO_SOLUTION.values())}
    if other:
        raise BodyFileError(rst, "element types", f"{READ}: {WAY_FORWARD}",
                            ", ".join(f"{t} ({c} elements)" for t, c in other.items()))
    if dofs != ["UX", "UY", "UZ"]:
        what = "MASS21 with rotary inertia (KEYOPT(3)=0)" if "MASS21" in counts else "DOFs " + ", ".join(dofs)
        raise BodyFileError(rst, "DOFs", f"UX, UY, UZ at every node ({READ}: {WAY_FORWARD})", what)


def cells_of(rst, elem, routines: np.ndarray, nodes: np.ndarray) \
        -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """The solid elements as meshio cells (node indices, VTK order) and each cell's element row; MASS21 and
    MESH200 make no cells. A degenerate form MAPDL does not define, a removed mid-side node or a node that is
    not in the mesh is refused naming the element."""
    sizes = np.fromiter((len(e) for e in elem), np.int64, len(elem))
    flat = np.concatenate(elem).astype(np.int64) if len(elem) else np.zeros(0, np.int64)
    starts = np.cumsum(sizes) - sizes + HEADER_WORDS
    routines = np.asarray(routines, np.int64)
    solid = ~np.isin(routines, [*NO_SOLUTION, POINT_MASS])
    cells: dict[str, list] = {}
    rows: dict[str, list] = {}
    for routine, size in sorted(set(zip(routines[solid].tolist(), sizes[solid].tolist()))):
        ks = np.flatnonzero(solid & (routines == routine) & (sizes == size))
        conn = flat[starts[ks, None] + np.arange(size - HEADER_WORDS)]
        for kind, (order, picked) in _shapes(rst, (routine, size - HEADER_WORDS), conn, ks, elem).items():
            cells.setdefault(kind, []).append(_indices(rst, conn[picked][:, order], nodes))
            rows.setdefault(kind, []).append(ks[picked])
    return {t: np.concatenate(c) for t, c in cells.items()}, {t: np.concatenate(r) for t, r in rows.items()}


def _shapes(rst, key: tuple[int, int], conn: np.ndarray, ks: np.ndarray, elem) \
        -> dict[str, tuple[tuple[int, ...], np.ndarray]]:
    """Per meshio type, the VTK order of the listed nodes and the elements (rows of ``conn``) of that form."""
    name = f"SOLID{key[0]}"
    shapes = SHAPES.get(key)
    if shapes is None:
        raise BodyFileError(rst, "elements", f"{name} with {_listed(key[0])} nodes", f"{key[1]} nodes")
    zero = np.flatnonzero((conn <= 0).any(axis=1))
    if zero.size:
        raise BodyFileError(rst, f"{name} element {elem[ks[zero[0]]][8]}", "every node of the element "
                            "(mid-side nodes removed on some edges are not integrated; keep or remove all)",
                            "node 0")
    brick = key[0] in (185, 186)
    a, b = np.triu_indices(8 if brick else 4, 1)  # the corners
    same = conn[:, a] == conn[:, b]
    out, claimed = {}, np.zeros(len(conn), bool)
    for form, (kind, order) in shapes.items():
        wanted = np.zeros(len(a), bool)
        for g in CORNERS[form] if brick else ():
            wanted |= np.isin(a, g) & np.isin(b, g)
        hit = np.flatnonzero((same == wanted).all(axis=1))
        used = np.sort(conn[hit][:, order], axis=1)
        hit = hit[(np.diff(used, axis=1) != 0).all(axis=1)]
        if hit.size:
            out[kind] = (order, hit)
            claimed[hit] = True
    if not claimed.all():
        bad = int(np.flatnonzero(~claimed)[0])
        raise BodyFileError(rst, f"{name} element {elem[ks[bad]][8]}", "a brick or one of MAPDL's degenerate "
                            "prism, pyramid or tetrahedron forms with distinct nodes otherwise",
                            f"nodes {' '.join(map(str, conn[bad]))}")
    return out


def _listed(routine: int) -> str:
    return " or ".join(str(n) for r, n in SHAPES if r == routine)


def _indices(rst, numbers: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """Node numbers -> indices into ``nodes`` (sorted), or one line naming a node that is not in the mesh."""
    at = np.minimum(np.searchsorted(nodes, numbers), len(nodes) - 1)
    missing = nodes[at] != numbers
    if missing.any():
        raise BodyFileError(rst, "elements", "element nodes among the nodes", f"node {numbers[missing][0]}")
    return at
