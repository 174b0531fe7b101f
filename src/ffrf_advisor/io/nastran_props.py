"""The nodal mass of a Nastran run checked against the model's own mass data (theory 3b, 4): pyNastran's mass
properties of the same model (``pyNastran.bdf.mesh_utils.mass_properties``) and the grid point weight
generator's table in the OP2 (``PARAM,GRDPNT``).

pyNastran treats every element as a point mass at its centroid (a CONM2 with its inertia), so its inertia
lacks each element's own, which the check adds (``own_inertia``: solids as uniform tetrahedra, shells and lines
as lumped at their grids). Its formulas are exact for tetrahedra, right prisms (CPENTA, CHEXA on a
parallelogram) with straight edges, shells and lines; they are not for CPYRAM (centroid at half the height,
not a quarter), other CPENTA and CHEXA (volume as mean face area times the distance of the face centres),
curved mid-side grids (corners only), CTETRA of the other handedness (signed volume) and a CONM2's products of
inertia or its inertia in a CID frame (pyNastran 1.4.1: opposite sign, zeros): what they affect is not
compared, and the note says why.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import BodyFileError, FFRFError
from ..fe.elements import element_type
from .nastran_mass import LINES, SHELLS, NodalMass, beam_torsion, wtmass
from .nastran_solids import NASTRAN
from .pynastran import quietly

PROPS_TOL = 1e-6  # relative: OP2 grids are float32 (6e-8), so right prisms are right to ~1e-7 of the body
GPWG_TOL = 1e-6  # the OP2 holds the weight generator's mass in float32 (6e-8); Nastran's own summation order
QUANTITIES = ("mass", "CG", "inertia")
MAX_ELEMENTS = 20_000  # pyNastran's mass properties loop over the cards: 0.3 ms each (12,000 CTETRA10: 3.7 s)


@dataclass
class Properties:
    """Mass, centre of mass and inertia tensor about it (basic)."""

    mass: float
    cg: np.ndarray
    inertia: np.ndarray


def of_nodal_mass(mass: NodalMass, points: np.ndarray) -> Properties:
    """By nodal sums: m = 1^T Ms 1, m c = X^T Ms 1, I = tr(S) 1 - S + sum_p J_p with S = Y^T Ms Y, Y = X - c."""
    X = np.concatenate([points, mass.extra_points])
    total = float(mass.Ms.sum())
    cg = (mass.Ms @ X).sum(axis=0) / (total if total else 1.0)
    Y = X - cg
    S = Y.T @ (mass.Ms @ Y)
    return Properties(total, cg, np.trace(S) * np.eye(3) - S + mass.J.sum(axis=0))


def checked(path, m, mass: NodalMass, points: np.ndarray, assembled: bool) -> list[str]:
    """Notes on the nodal mass against the grid point weight generator's mass and (assembled from the model's
    elements) pyNastran's mass properties (with PARAM,WTMASS, which the weight generator divides out); a
    disagreement beyond their precision is a BodyFileError."""
    ours, w = of_nodal_mass(mass, points), wtmass(path, m)
    notes = _against_gpwg(path, m, ours.mass / w, mass.what)
    if not assembled or not ours.mass > 0:  # no mass: the body's own mass check refuses it
        return notes
    count = len(m.elements) + len(m.masses)
    if count > MAX_ELEMENTS:
        return notes + [f"pyNastran's mass properties not compared: {count} cards, more than the {MAX_ELEMENTS} "
                        "its loop over them takes in seconds"]
    return notes + _against_pynastran(path, m, mass, points, ours, w)


def _against_gpwg(path, m, ours: float, what: str) -> list[str]:
    tables = getattr(m, "grid_point_weight", None) or {}
    if not tables:
        return []
    gpwg = next(iter(tables.values()))
    theirs = float(np.asarray(gpwg.mass, dtype=float)[0])
    error = abs(ours / theirs - 1)
    if not error <= GPWG_TOL:
        raise BodyFileError(path, "grid point weight generator (PARAM,GRDPNT)", f"its mass to agree with {what} "
                            f"within {GPWG_TOL:g}", f"Nastran's {theirs:.7g} against {ours:.7g}")
    return [f"mass within {error:.1g} of Nastran's grid point weight generator"]


def _against_pynastran(path, m, mass: NodalMass, points: np.ndarray, ours: Properties, w: float) -> list[str]:
    from pyNastran.bdf.mesh_utils.mass_properties import mass_properties

    try:
        total, cg, I6 = quietly(path, "a model pyNastran's mass properties take",
                                lambda model, log: mass_properties(model), m)
    except FFRFError as e:
        return [f"pyNastran's mass properties not compared: {e.got}"]
    Ixx, Iyy, Izz, Ixy, Ixz, Iyz = (float(v) for v in I6)
    theirs = Properties(float(total), np.asarray(cg, dtype=float),
                        np.array([[Ixx, -Ixy, -Ixz], [-Ixy, Iyy, -Iyz], [-Ixz, -Iyz, Izz]]))
    reasons = _approximations(m, mass, points)
    skipped = {q for affected, _ in reasons for q in affected}
    size = max(float(np.ptp(points, axis=0).max()), np.finfo(float).tiny)
    errors = {"mass": abs(ours.mass / theirs.mass - 1) if theirs.mass else np.inf,
              "CG": float(np.linalg.norm(ours.cg - theirs.cg)) / size,
              "inertia": _inertia_error(ours.inertia - theirs.inertia - w * own_inertia(m, mass, points),
                                        float(np.abs(ours.inertia).max()))}
    for q in QUANTITIES:
        if q not in skipped and not errors[q] <= PROPS_TOL:
            raise BodyFileError(path, "mass properties", f"the assembled {q} to agree with pyNastran's mass "
                                f"properties of the model within {PROPS_TOL:g}",
                                f"{_show(q, ours)} against pyNastran's {_show(q, theirs)}")
    compared = [f"{q} within {errors[q]:.1g}" for q in QUANTITIES if q not in skipped]
    why = "; ".join(f"{text} ({', '.join(affected)} not compared)" for affected, text in reasons)
    return [f"pyNastran's mass properties of the model: {', '.join(compared) or 'nothing compared'}"
            + (f"; pyNastran approximates {why}" if why else "")]


def _show(q: str, p: Properties) -> str:
    if q == "mass":
        return f"{p.mass:.7g}"
    if q == "CG":
        return "(" + ", ".join(f"{v:.7g}" for v in p.cg) + ")"
    return "diag(" + ", ".join(f"{v:.7g}" for v in np.diag(p.inertia)) + ")"


def _inertia_error(D: np.ndarray, scale: float) -> float:
    """The largest eigenvalue of |D| (symmetric part) relative to ``scale``."""
    return float(np.abs(np.linalg.eigvalsh(0.5 * (D + D.T))).max()) / max(scale, np.finfo(float).tiny)


def own_inertia(m, mass: NodalMass, points: np.ndarray) -> np.ndarray:
    """The elements' inertia about their own centroids, which pyNastran's point masses lack: solids as uniform
    tetrahedra (theirs where straight-sided, ``SPLIT``), shells and lines as lumped at their grids (as
    assembled), CBEAM's torsional rho J L about its axis."""
    I = np.zeros((3, 3))
    for cell, rho, conn, _ in mass.solids:
        I += _solid_own_inertia(cell, points[conn], rho)
    for e in m.elements.values():
        if e.type not in (*LINES, *SHELLS):
            continue
        X = np.array([n.get_position() for n in e.nodes_ref if n is not None], dtype=float)[:2 if e.type in LINES
                                                                                            else None]
        Y = X - X.mean(axis=0)
        I += float(e.Mass()) / len(X) * _inertia_of(Y.T @ Y)
        if e.type == "CBEAM":
            I += beam_torsion(e, X[0], X[1])
    return I


def _inertia_of(S: np.ndarray) -> np.ndarray:
    """Inertia tensor tr(S) 1 - S of the second moments S (3 x 3, or (..., 3, 3))."""
    return np.trace(S, axis1=-2, axis2=-1)[..., None, None] * np.eye(3) - S


# Each cell's corners as tetrahedra (VTK order): exact for straight-sided tetrahedra, prisms and parallelepipeds.
SPLIT = {"tetra": [(0, 1, 2, 3)], "wedge": [(0, 1, 2, 3), (1, 2, 3, 4), (2, 3, 4, 5)],
         "hexahedron": [(0, 1, 2, 6), (0, 2, 3, 6), (0, 3, 7, 6), (0, 7, 4, 6), (0, 4, 5, 6), (0, 5, 1, 6)],
         "pyramid": [(0, 1, 2, 4), (0, 2, 3, 4)]}


def _solid_own_inertia(cell: str, X: np.ndarray, rho: float) -> np.ndarray:
    """Sum over the cells of their inertia about their centroids: a uniform tetrahedron's second moments about
    its centroid are (V / 20) sum_i v_i v_i^T (v_i: corners from the centroid)."""
    T = X[:, SPLIT[cell.rstrip("0123456789")]]  # (ne, k, 4, 3)
    c = T.mean(axis=2)
    V = rho * np.abs(np.einsum("eki,eki->ek", T[:, :, 1] - T[:, :, 0],
                               np.cross(T[:, :, 2] - T[:, :, 0], T[:, :, 3] - T[:, :, 0]))) / 6
    v = T - c[:, :, None]
    S = np.einsum("ek,ekpa,ekpb->eab", V / 20, v, v)
    centre = np.einsum("ek,eka->ea", V, c) / V.sum(axis=1)[:, None]
    d = c - centre[:, None]
    S += np.einsum("ek,eka,ekb->eab", V, d, d)
    return _inertia_of(S.sum(axis=0))


def _approximations(m, mass: NodalMass, points: np.ndarray) -> list[tuple[tuple[str, ...], str]]:
    """(quantities affected, why) for each kind of card pyNastran's mass properties approximate."""
    tol = PROPS_TOL * max(float(np.abs(points).max()), np.finfo(float).tiny)
    out = []
    for cell, _, conn, mirrored in mass.solids:
        signed = mirrored if cell.startswith("tetra") else False  # pyNastran's CTETRA volume is signed
        inexact = signed | ~_straight(cell, points[conn], tol) | ~_right_prism(cell, points[conn], tol)
        if inexact.any():
            out.append((QUANTITIES, f"{int(inexact.sum())} {_named(cell, conn)} (not a tetrahedron or right prism with "
                                    "straight edges, or of the other handedness)"))
        elif cell.startswith("pyramid"):
            out.append((QUANTITIES[1:], f"{len(conn)} {_named(cell, conn)} (centroid at half height)"))
    conm2 = [c for c in m.masses.values() if c.type == "CONM2"]
    odd = sum(1 for c in conm2 if c.Cid() not in (0, -1) or any(float(c.I[k]) for k in (1, 3, 4)))
    if odd:
        out.append((("inertia",), f"{odd} CONM2 (products of inertia, or inertia in a CID frame)"))
    return out


def _named(cell: str, conn: np.ndarray) -> str:
    """Nastran's name of the cells: CTETRA with 10 grids."""
    return f"{NASTRAN[cell]} with {conn.shape[1]} grids"


def _straight(cell: str, X: np.ndarray, tol: float) -> np.ndarray:
    """Per cell: every mid-side node at the middle of its edge's corners (the FE module's reference nodes)."""
    ref = element_type(cell).ref_nodes
    corners = {"tetra": 4, "wedge": 6, "pyramid": 5, "hexahedron": 8}[cell.rstrip("0123456789")]
    ok = np.ones(len(X), dtype=bool)
    for k in range(corners, len(ref)):
        a, b = _edge_of(ref, corners, k)
        ok &= np.abs(X[:, k] - (X[:, a] + X[:, b]) / 2).max(axis=1) <= tol
    return ok


def _edge_of(ref: np.ndarray, corners: int, k: int) -> tuple[int, int]:
    """The two corners whose middle is reference node k."""
    return next((a, b) for a in range(corners) for b in range(a + 1, corners)
                if np.allclose((ref[a] + ref[b]) / 2, ref[k]))


def _right_prism(cell: str, X: np.ndarray, tol: float) -> np.ndarray:
    """Per cell: a tetrahedron, or a wedge or hexahedron whose top face is its bottom face moved along the
    bottom's normal (a hexahedron's bottom a parallelogram); pyramids pass (their centroid is flagged apart)."""
    base = {"wedge": 3, "hexahedron": 4}.get(cell.rstrip("0123456789"))
    if base is None:
        return np.ones(len(X), dtype=bool)
    v = X[:, base:2 * base] - X[:, :base]
    ok = np.abs(v - v[:, :1]).max(axis=(1, 2)) <= tol
    for edge in (X[:, 1] - X[:, 0], X[:, base - 1] - X[:, 0]):
        ok &= np.abs(np.einsum("ei,ei->e", v[:, 0], edge)) <= tol * (np.linalg.norm(v[:, 0], axis=1)
                                                                      + np.linalg.norm(edge, axis=1))
    if base == 4:
        ok &= np.abs(X[:, 0] + X[:, 2] - X[:, 1] - X[:, 3]).max(axis=1) <= tol
    return ok
