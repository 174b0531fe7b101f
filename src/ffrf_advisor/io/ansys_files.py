"""An MAPDL modal run read from ``JOB.rst`` and ``JOB.full`` with ansys-mapdl-reader (the optional extra
``ffrf-advisor[ansys]``), as the files hold it: the file's units and frame, before any requirement on it.
Each file is read in a guarded reading child of its own (io.guard): what the library raises or a crash in it names
that file.
"""
from __future__ import annotations

import contextlib
import io
import os
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..consistency import check_frequencies, check_mode_numbers
from ..errors import BodyFileError, FFRFError
from .ansys_cells import cells_of, refuse_unreadable
from .limits import Budget

ANALYSES = {0: "static", 1: "buckling", 3: "harmonic", 4: "transient", 7: "substructure", 8: "spectrum"}
FAMILIES = {"SOLID": (45, 92, 95, 185, 186, 187, 285), "SHELL": (63, 181, 208, 209, 281), "BEAM": (4, 44, 188, 189),
            "MASS": (21,), "COMBIN": (14, 39, 40), "LINK": (180,), "MPC": (184,), "PLANE": (182, 183),
            "SURF": (154, 156), "TARGE": (169, 170), "CONTA": (171, 172, 173, 174, 175, 177), "MESH": (200,)}
CORNERS = {"hexahedron": 8, "wedge": 6, "pyramid": 5, "tetra": 4}  # corners of each cell family (VTK lists them first)


@dataclass
class AnsysRun:
    """A modal run in the file's units and global frame (theory 2): nodes, the solid elements as cells
    (ansys_cells) with each cell's material, eigenvalues, modes, corner stresses per cell type, and the .full's
    M and K over the node-interleaved DOFs ``3 i + c`` (K as stored: a constrained DOF keeps a unit diagonal)."""

    source: str
    full: str
    nodes: np.ndarray              # (n,) node numbers
    points: np.ndarray             # (n, 3)
    cells: dict[str, np.ndarray]   # meshio cell type -> (ne, nn) node indices
    cell_material: dict[str, np.ndarray]  # meshio cell type -> (ne,) MP material number of each cell
    cell_numbers: dict[str, np.ndarray]   # meshio cell type -> (ne,) MAPDL element number of each cell
    element_types: dict[str, int]  # e.g. {"SOLID186": 40}
    materials: dict[int, dict[str, float]]  # MP tables (EX, NUXY, DENS, ...) by material number
    cell_materials: set[int]       # the material numbers the solid elements use (MASS21 and MESH200 have none)
    units: str                     # the /UNITS record as the library names it ("User Defined", "SI", ...)
    eigenvalues: np.ndarray        # (nm,) (2 pi f)^2
    modes: np.ndarray              # (n, 3, nm) UX, UY, UZ
    corner_stress: dict[str, np.ndarray] | None  # cell type -> (ne, corners, 6, nm) SX SY SZ SXY SYZ SXZ
    # (float32); None when the run has no element stresses
    M: sp.csr_array
    K: sp.csr_array
    constrained: np.ndarray        # (3n,) bool: DOFs the .full's run held


def library():
    """ansys-mapdl-reader, imported quietly (it warns on import), or the one-line error naming the extra."""
    try:
        with warnings.catch_warnings(), contextlib.redirect_stderr(io.StringIO()):
            warnings.simplefilter("ignore")
            from ansys.mapdl import reader
    except ImportError:
        raise FFRFError("the ANSYS reader needs ansys-mapdl-reader: pip install 'ffrf-advisor[ansys]'") from None
    return reader


@contextlib.contextmanager
def _silenced():
    """The library's prints, warnings and what its C++ code writes to stderr before it aborts, silenced."""
    saved, devnull = os.dup(2), os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 2)
        with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()), \
                contextlib.redirect_stderr(io.StringIO()):
            warnings.simplefilter("ignore")
            yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(devnull)


def quietly(path, expected: str, fn, *args):
    """``fn(*args)`` silenced; what the library raises -> one line naming ``path``."""
    try:
        with _silenced():
            return fn(*args)
    except FFRFError:
        raise
    except Exception as e:  # the library raises many kinds on damaged input (struct, assertions, index)
        raise BodyFileError(path, "file", expected, f"{type(e).__name__}: {' '.join(str(e).split())[:160]}") \
            from None


def load_result(rst: str) -> AnsysRun:
    """Nodes, elements, modes and stresses of the .rst (M and K still empty)."""
    return quietly(rst, "a modal result file ansys-mapdl-reader can read (/FCOMP,RST,0)", _result, library(), rst,
                   Budget(rst))


def load_matrices(full: str, nodes: np.ndarray) -> tuple[sp.csr_array, sp.csr_array, np.ndarray]:
    """M and K of the .full over the DOFs 3 i + c of ``nodes``, and the DOFs its run held."""
    return quietly(full, "a .full file ansys-mapdl-reader can read", _matrices, library(), full, nodes, Budget(full))


def _result(lib, rst: str, budget: Budget) -> AnsysRun:
    """The run of a modal .rst with UX, UY, UZ per node, nodes sorted by number (M and K empty)."""
    r = lib.read_binary(rst, parse_vtk=False)
    if type(r) is not lib.rst.Result:
        raise BodyFileError(rst, "file", "the result file of one modal run (RESCOMBINE distributed ones)",
                            type(r).__name__)
    kind = int(r._resultheader["kan"])
    if kind != 2 or r.n_sector > 1:
        raise BodyFileError(rst, "analysis type", "a modal analysis (ANTYPE,MODAL) without cyclic symmetry",
                            f"{r.n_sector} sectors" if kind == 2 else ANALYSES.get(kind, f"type {kind}"))
    mesh = r.mesh
    routines = np.asarray(mesh.etype, np.int64)
    names = [_name(int(t)) for t in routines]
    refuse_unreadable(rst, names, list(r.result_dof(0)))
    order = np.argsort(np.asarray(mesh.nnum, np.int64), kind="stable")
    nodes, points = np.asarray(mesh.nnum, np.int64)[order], np.asarray(mesh.nodes, float)[order, :3]
    cells, rows = cells_of(rst, mesh.elem, routines, nodes)
    material = np.asarray(mesh.material_type, np.int64)
    frequencies = np.asarray(r.time_values, float)
    check_sets(rst, r, frequencies)
    budget.take("NSL", 24.0 * len(nodes) * len(frequencies))
    modes = np.stack([_at_nodes(rst, nodes, *r.nodal_solution(i), f"NSL of mode {i + 1}")
                      for i in range(len(frequencies))], axis=-1)
    stress = _corner_stress(rst, r, cells, rows, np.asarray(mesh.enum), nodes, len(frequencies), budget) \
        if cells and r.available_results["ENS"] else None
    empty = sp.csr_array((0, 0))
    return AnsysRun(source=rst, full="", nodes=nodes, points=points, cells=cells,
                    cell_material={t: material[k] for t, k in rows.items()},
                    cell_numbers={t: np.asarray(mesh.enum, np.int64)[k] for t, k in rows.items()},
                    element_types={t: names.count(t) for t in sorted(set(names))},
                    materials={int(k): {p: float(v) for p, v in d.items()} for k, d in r.materials.items()},
                    cell_materials={int(m) for k in rows.values() for m in material[k]},
                    units=str(r._resultheader["units"]),
                    eigenvalues=np.sign(frequencies) * (2 * np.pi * frequencies) ** 2, modes=modes,
                    corner_stress=stress, M=empty, K=empty, constrained=np.zeros(0, bool))


def check_sets(rst, r, frequencies: np.ndarray) -> None:
    """The result sets' mode numbers (the substeps of the set table and of each set's solution header) count
    1, 2, 3 ...; each set's solution header TIMFRQ is its frequency in the time table (one double, written twice).
    """
    table = np.asarray(r._resultheader["ls_table"], np.int64).reshape(-1, 3)
    check_mode_numbers(rst, "result set table (substeps: mode numbers)", table[:, 1], first=1)
    check_mode_numbers(rst, "solution headers (substeps: mode numbers)",
                       [r._solution_header(i)["iter"] for i in range(len(frequencies))], first=1)
    check_frequencies(rst, ("solution headers TIMFRQ", "the time table's frequencies"),
                      np.abs([r.solution_info(i)["timfrq"] for i in range(len(frequencies))]),
                      (2 * np.pi * frequencies) ** 2, None)


def _name(routine: int) -> str:
    return next((f"{family}{routine}" for family, numbers in FAMILIES.items() if routine in numbers),
                f"element {routine}")


def _at_nodes(rst, nodes: np.ndarray, nnum: np.ndarray, values: np.ndarray, field: str) -> np.ndarray:
    """A nodal result (n, 3), checked to hold finite values at every node of the mesh in its order."""
    values = np.asarray(values, float)
    if not np.array_equal(np.asarray(nnum), nodes) or values.shape != (len(nodes), 3) \
            or not np.all(np.isfinite(values)):
        raise BodyFileError(rst, field, "finite UX, UY, UZ at every node of the mesh", "missing or NaN values")
    return values


def corners(kind: str) -> int:
    """The corners of a cell type (VTK lists them first): 8, 6, 5 or 4."""
    return CORNERS[kind.rstrip("0123456789")]


def _corner_stress(rst, r, cells: dict, rows: dict, enum: np.ndarray, nodes: np.ndarray, nm: int,
                   budget: Budget) -> dict[str, np.ndarray]:
    """Per cell type, the component stresses at each cell's corners (ne, nc, 6, nm) as the file holds them. MAPDL
    writes them at the element's first listed nodes (8 for SOLID185/186 in every form, a collapsed corner
    repeated; 4 for SOLID187), which the library returns with them."""
    budget.take("ENS", 4.0 * 6 * nm * sum(len(c) * corners(t) for t, c in cells.items()))
    out = {t: np.zeros((len(c), corners(t), 6, nm), np.float32) for t, c in cells.items()}
    picks: dict[str, np.ndarray | None] = {}
    for p in range(nm):
        numbers, values, enodes = r.element_stress(p)
        numbers = np.asarray(numbers)
        for t, conn in cells.items():
            wanted = enum[rows[t]]
            at = np.minimum(np.searchsorted(numbers, wanted), max(len(numbers) - 1, 0))
            ok = len(numbers) > 0 and np.array_equal(numbers[at], wanted) and \
                all(np.shape(values[k]) == (len(enodes[k]), 6) for k in at)
            if ok and t not in picks:
                picks[t] = _positions([enodes[k] for k in at], nodes[conn[:, :corners(t)]])
            v = np.stack([np.asarray(values[k])[q] for k, q in zip(at, picks[t])]) \
                if ok and picks[t] is not None else None
            if v is None or not np.all(np.isfinite(v)):
                raise BodyFileError(rst, f"ENS of mode {p + 1}", "finite stresses at the corners of every element "
                                    "(MXPAND,,,,YES with OUTRES,ALL,ALL)", "missing or other elements' stresses")
            out[t][:, :, :, p] = v
    return out


def _positions(enodes: list, corner_nodes: np.ndarray) -> np.ndarray | None:
    """Per element, where each of its corners (ne, nc) lies among the nodes its stresses are given at, or None
    when a corner has no stress."""
    width = max((len(e) for e in enodes), default=0)
    listed = np.full((len(enodes), width), -1, np.int64)
    for i, e in enumerate(enodes):
        listed[i, :len(e)] = e
    match = listed[:, :, None] == corner_nodes[:, None, :]
    return match.argmax(axis=1) if match.any(axis=1).all() else None


def _matrices(lib, full: str, nodes: np.ndarray, budget: Budget) -> tuple[sp.csr_array, sp.csr_array, np.ndarray]:
    """Every stored term of M and K (upper triangles, symmetric), over the DOFs 3 i + c of ``nodes``."""
    from ansys.mapdl.reader import _binary_reader
    from ansys.mapdl.reader.common import two_ints_to_long

    f = lib.read_binary(full)
    if type(f) is not lib.full.FullFile:
        raise BodyFileError(full, "file", "an MAPDL .full file (the mass and stiffness of the run)", type(f).__name__)
    h = f._header
    if h["numdof"] != 3:
        raise BodyFileError(full, "DOFs", "3 per node (UX, UY, UZ: solid elements)", str(h["numdof"]))
    terms = {name: two_ints_to_long(h[f"nterm{name}l"], h[f"nterm{name}h"]) for name in ("K", "M")}
    budget.take(".full", 2 * 16.0 * sum(terms.values()), copies=1)  # the library's copy and ours, in the child
    budget.take(".full", 12.0 * sum(terms.values()))
    dof_ref = np.asarray(f.load_km(sort=False)[0], np.int64)
    eq = _equations(full, dof_ref, nodes)
    if len(eq) != 3 * len(nodes) or len(np.unique(eq)) != len(eq):
        raise BodyFileError(full, "DOFs", f"UX, UY, UZ of each of the {len(nodes)} nodes of the .rst once",
                            f"{len(eq)} equations")
    held = np.zeros(3 * len(nodes), bool)
    held[_equations(full, np.asarray(f.const, np.int64).reshape(-1, 2), nodes)] = True
    every = np.ones(f.neqn, np.int32)  # read every term: the library drops those of held DOFs
    M, K = (_symmetric(full, name, *_binary_reader.read_array(f.filename, h[ptr], terms[key], f.neqn, every), eq)
            for name, ptr, key in (("mass matrix", "ptrMAS", "M"), ("stiffness matrix", "ptrSTF", "K")))
    return M, K, held


def _equations(full: str, dof_ref: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """The DOF 3 i + c of each (node, component) row of ``dof_ref``."""
    i = np.searchsorted(nodes, dof_ref[:, 0])
    i = np.minimum(i, len(nodes) - 1)
    bad = (nodes[i] != dof_ref[:, 0]) | (dof_ref[:, 1] < 0) | (dof_ref[:, 1] > 2)
    if bad.any():
        node, c = dof_ref[np.argmax(bad)]
        raise BodyFileError(full, "DOFs", "UX, UY, UZ of the nodes of the .rst", f"node {node} DOF {c}")
    return 3 * i + dof_ref[:, 1]


def _symmetric(full: str, field: str, rows, cols, data, eq: np.ndarray) -> sp.csr_array:
    """The full symmetric matrix over the node DOFs from the stored upper triangle (in equation order)."""
    rows, cols, data = np.asarray(rows, np.int64), np.asarray(cols, np.int64), np.asarray(data, float)
    n3 = len(eq)
    if np.any(rows > cols) or (len(rows) and (rows.min() < 0 or cols.max() >= n3)):
        raise BodyFileError(full, field, "the upper triangle of a symmetric matrix over every node's UX, UY, UZ",
                            "other terms")
    if not np.all(np.isfinite(data)):
        raise BodyFileError(full, field, "finite numbers", "NaN or infinity")
    off = rows != cols
    A = sp.coo_array((np.r_[data, data[off]], (np.r_[eq[rows], eq[cols[off]]], np.r_[eq[cols], eq[rows[off]]])),
                     shape=(n3, n3))
    return sp.csr_array(A.tocsr())
