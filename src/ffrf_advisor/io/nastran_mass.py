"""The 6-DOF nodal mass of a Nastran run (theory 3b), assembled from its elements and point masses, and the
modal masses it gives the run's modes:
- CONM2: mass and inertia at its CG (an offset CG becomes a node moving rigidly with its grid);
- CBAR, CBEAM, CROD, CONROD, CTUBE: half the element mass (with non-structural mass) at each end; CBEAM
  also half its torsional inertia rho J L about its axis, the others no rotary inertia;
- CQUAD4, CQUADR, CQUAD8, CTRIA3, CTRIAR, CTRIA6: the element mass (with non-structural mass) shared equally
  by its nodes, translations only: no rotary inertia (as Nastran's lumped shell mass);
- CTETRA (4, 10 grids), CPENTA (6, 15), CPYRAM (5, 13), CHEXA (8, 20): the consistent mass of the FE module
  (``nastran_solids``: the node order and handedness);
- springs, dampers and rigid elements (RBE2, RBE3, RBAR: not elements to pyNastran) carry no mass: a mass on
  a dependent grid moves with the grid's recovered motion, which the OP2 holds at every grid, so its modal
  mass is exact; any other element is refused by name.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..errors import BodyFileError
from . import nastran_solids
from .nastran_modes import NastranModes

LINES = ("CBAR", "CBEAM", "CROD", "CONROD", "CTUBE")
SHELLS = ("CQUAD4", "CQUADR", "CQUAD8", "CTRIA3", "CTRIAR", "CTRIA6")
MASSLESS = ("CELAS1", "CELAS2", "CELAS3", "CELAS4", "CDAMP1", "CDAMP2", "CDAMP3", "CDAMP4", "CVISC", "CBUSH",
            "CBUSH1D", "CGAP", "PLOTEL")
FORWARD = "give the mass as DMIG MAAX beside the OP2 (PARAM,EXTOUT,DMIGPCH): then no element is assembled"


@dataclass
class NodalMass:
    """Scalar translational mass over the grids (+ offset CG nodes), nodal rotary inertia, extra nodes."""

    Ms: sp.csr_array
    J: np.ndarray                 # (n + k, 3, 3)
    extra_points: np.ndarray      # (k, 3) CG of offset CONM2s
    extra_of: np.ndarray          # (k,) the grid index each moves with
    notes: list[str]
    what: str = "the assembled mass"
    solids: list[tuple[str, float, np.ndarray, np.ndarray]] = field(default_factory=list)  # cell, rho, conn, mirrored


def assembled_mass(path, m, run: NastranModes) -> NodalMass:
    """The mass of the elements and point masses of ``m`` over the grids of ``run`` (theory 3b)."""
    index = {int(g): i for i, g in enumerate(run.grids)}
    n = len(run.grids)
    diag, J = np.zeros(n), np.zeros((n, 3, 3))
    solids = _element_mass(path, m, run, index, diag, J)
    extra = _point_masses(path, m, run, index, diag, J)
    k = len(extra)
    Ms = sp.diags_array(np.concatenate([diag, [e[2] for e in extra]])).tocsr()
    cells = []
    for (cell, rho), (conns, eids) in solids.items():
        conn, mirrored = nastran_solids.oriented(cell, np.array(conns), run.points)
        cells.append((cell, rho, conn, mirrored))
        block = nastran_solids.solid_mass(path, run.points, cell, conn, np.array(eids), rho)
        Ms = Ms + sp.block_diag([block, sp.csr_array((k, k))]).tocsr()
    mirrored = sum(int(c[3].sum()) for c in cells)
    w = wtmass(path, m)
    notes = [f"mass assembled from {', '.join(f'{v} {t}' for t, v in run.element_types.items())}"
             + (f"; {k} CONM2 with an offset CG as nodes moving rigidly with their grid" if k else "")
             + (f"; {mirrored} solids of the other handedness renumbered" if mirrored else "")
             + (f"; times PARAM,WTMASS {w:g}, as Nastran's mass matrix" if w != 1 else "")]
    return NodalMass(sp.csr_array(Ms * w), w * np.concatenate([J, np.array([e[3] for e in extra]).reshape(k, 3, 3)]),
                     np.array([e[0] for e in extra]).reshape(k, 3), np.array([e[1] for e in extra], np.int64),
                     notes, solids=cells)


def wtmass(path, m) -> float:
    """PARAM,WTMASS of the model (1 without it): Nastran multiplies the mass of every card by it."""
    card = getattr(m, "params", {}).get("WTMASS")
    w = 1.0 if card is None else float(card.values[0])
    if not (np.isfinite(w) and w > 0):
        raise BodyFileError(path, "PARAM,WTMASS", "a positive factor", f"{w:g}")
    return w


def _element_mass(path, m, run: NastranModes, index: dict, diag: np.ndarray, J: np.ndarray) -> dict:
    """Lumped line and shell masses into ``diag`` and ``J``; the solids' VTK connectivities and element ids by
    (cell type, rho)."""
    known = {*LINES, *SHELLS, *MASSLESS, *nastran_solids.SOLIDS}
    refused = sorted({e.type for e in m.elements.values()} - known)
    if refused:
        carried = ", ".join(sorted(known - set(MASSLESS)))
        raise BodyFileError(path, "elements", f"element types whose mass the reader assembles ({carried}; "
                            f"docs/format.md), or {FORWARD}", ", ".join(refused))
    solids: dict[tuple[str, float], tuple[list, list]] = {}
    for e in m.elements.values():
        if e.type in MASSLESS:
            continue
        nodes = _indices(path, e, [g for g in e.nodes if g is not None], index)  # ids (node_ids: 80 us each)
        if e.type in nastran_solids.SOLIDS:
            cell = nastran_solids.cell_of(path, e, nodes)
            conns, eids = solids.setdefault((cell, float(e.Rho())), ([], []))
            conns.append(nastran_solids.to_vtk(cell, nodes))
            eids.append(e.eid)
        elif e.type in LINES:
            a, b = nodes[:2]
            diag[[a, b]] += float(e.Mass()) / 2
            if e.type == "CBEAM":  # half the torsional inertia at each end
                J[[a, b]] += beam_torsion(e, run.points[a], run.points[b]) / 2
        else:
            diag[nodes] += float(e.Mass()) / len(nodes)
    return solids


def beam_torsion(e, xa: np.ndarray, xb: np.ndarray) -> np.ndarray:
    """A CBEAM's torsional inertia rho J L about its axis (3 x 3, basic), from its ends' positions."""
    axis = (xb - xa) / np.linalg.norm(xb - xa)
    return e.pid_ref.mid_ref.rho * np.atleast_1d(e.pid_ref.J())[0] * e.Length() * np.outer(axis, axis)


def _point_masses(path, m, run: NastranModes, index: dict, diag: np.ndarray, J: np.ndarray) -> list[tuple]:
    """CONM2 at their grid into ``diag`` and ``J``; those with an offset CG as (CG, grid index, mass, inertia)."""
    extra = []
    for c in m.masses.values():
        if c.type != "CONM2":
            raise BodyFileError(path, "masses", f"CONM2 point masses, or {FORWARD}", c.type)
        i = _indices(path, c, [c.nid], index)[0]
        cg, inertia = np.asarray(c.Centroid(), dtype=float), _conm2_inertia(path, c)
        if np.linalg.norm(cg - run.points[i]) <= 1e-12 * max(1.0, np.abs(run.points).max()):
            diag[i] += c.mass
            J[i] += inertia
        else:
            extra.append((cg, i, c.mass, inertia))
    return extra


def _indices(path, card, grids: list[int], index: dict) -> list[int]:
    """The run's indices of a card's grids; a grid without a mode shape refused naming the card."""
    try:
        return [index[g] for g in grids]
    except KeyError as e:
        raise BodyFileError(path, f"{card.type} {card.eid}", "grids with mode shapes in the OP2 (DISP=ALL)",
                            f"grid {e.args[0]}") from None


def _conm2_inertia(path, c) -> np.ndarray:
    """A CONM2's inertia at its CG in basic: ``[[I11, -I21, -I31], [-I21, I22, -I32], [-I31, -I32, I33]]`` in
    its CID's axes (pyNastran's ``Inertia`` gives zeros for a CID other than 0 or -1)."""
    I11, I21, I22, I31, I32, I33 = (float(v) for v in c.I)
    A = np.array([[I11, -I21, -I31], [-I21, I22, -I32], [-I31, -I32, I33]])
    if c.Cid() in (0, -1):
        return A
    if c.cid_ref.type not in ("CORD1R", "CORD2R"):
        raise BodyFileError(path, f"CONM2 {c.eid} CID", "a rectangular frame for its offset and inertia",
                            f"{c.cid_ref.type} {c.Cid()}")
    B = np.asarray(c.cid_ref.beta(), dtype=float)  # rows: the frame's axes in basic
    return B.T @ A @ B


def modes_with_extra_nodes(run: NastranModes, mass: NodalMass) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points, translations and rotations with the offset-CG nodes appended: u = u_g + theta_g x (x - x_g)."""
    g = mass.extra_of
    arm = mass.extra_points - run.points[g]
    T = np.concatenate([run.T, run.T[g] + np.cross(run.R[g], arm[:, :, None], axisa=1, axisb=1, axisc=1)])
    return np.concatenate([run.points, mass.extra_points]), T, np.concatenate([run.R, run.R[g]])


def modal_mass_parts(run: NastranModes, mass: NodalMass) -> tuple[np.ndarray, np.ndarray]:
    """Per mode of the file, the translational sum Phi^T Ms Phi and the rotary sum Phi*^T J Phi* (theory 3b)."""
    _, T, R = modes_with_extra_nodes(run, mass)
    n, _, nm = T.shape
    trans = np.einsum("iap,iap->p", T, (mass.Ms @ T.reshape(n, 3 * nm)).reshape(n, 3, nm))
    return trans, np.einsum("iap,iab,ibp->p", R, mass.J, R)


def generalized_mass_error(run: NastranModes, mass: NodalMass) -> np.ndarray:
    """Per mode, (assembled modal mass) / (Nastran's generalised mass) - 1."""
    trans, rot = modal_mass_parts(run, mass)
    return (trans + rot) / run.generalized_mass - 1


def rotary_share(run: NastranModes, mass: NodalMass) -> np.ndarray:
    """Per mode, the share of the modal mass that is rotary inertia (1 for a pure torsion of beam nodes)."""
    trans, rot = modal_mass_parts(run, mass)
    return np.divide(rot, trans + rot, out=np.zeros_like(rot), where=trans + rot > 0)
