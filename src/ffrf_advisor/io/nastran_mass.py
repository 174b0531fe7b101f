"""The 6-DOF nodal mass of a Nastran run (theory 3b), assembled from its elements and point masses, and the
modal masses it gives the run's modes:
- CONM2: mass and inertia at its CG (an offset CG becomes a node moving rigidly with its grid);
- CBAR, CBEAM, CROD, CONROD, CTUBE: half the element mass (with non-structural mass) at each end; CBEAM
  also half its torsional inertia rho J L about its axis;
- CQUAD4, CQUADR, CQUAD8, CTRIA3, CTRIAR, CTRIA6: the element mass shared equally by its nodes;
- CHEXA with 8 or 20 nodes: the consistent mass of the FE module;
- springs, dampers and rigid elements carry no mass; any other element is refused by name.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..errors import BodyFileError
from ..fe.assembly import mass_matrix
from ..fe.mesh import Mesh
from .nastran_modes import NastranModes

LINES = ("CBAR", "CBEAM", "CROD", "CONROD", "CTUBE")
SHELLS = ("CQUAD4", "CQUADR", "CQUAD8", "CTRIA3", "CTRIAR", "CTRIA6")
MASSLESS = ("CELAS1", "CELAS2", "CELAS3", "CELAS4", "CDAMP1", "CDAMP2", "CDAMP3", "CDAMP4", "CVISC", "CBUSH",
            "CBUSH1D", "CGAP", "PLOTEL")
HEX20 = list(range(12)) + list(range(16, 20)) + list(range(12, 16))  # Nastran CHEXA20 -> VTK node order


@dataclass
class NodalMass:
    """Scalar translational mass over the grids (+ offset CG nodes), nodal rotary inertia, extra nodes."""

    Ms: sp.csr_array
    J: np.ndarray                 # (n + k, 3, 3)
    extra_points: np.ndarray      # (k, 3) CG of offset CONM2s
    extra_of: np.ndarray          # (k,) the grid index each moves with
    notes: list[str]
    what: str = "the assembled mass"


def assembled_mass(path, m, run: NastranModes) -> NodalMass:
    """The mass of the elements and point masses of ``m`` over the grids of ``run`` (theory 3b)."""
    index = {int(g): i for i, g in enumerate(run.grids)}
    n = len(run.grids)
    diag, J = np.zeros(n), np.zeros((n, 3, 3))
    solids = _element_mass(path, m, run, index, diag, J)
    extra = _point_masses(path, m, run, index, diag, J)
    k = len(extra)
    Ms = sp.diags_array(np.concatenate([diag, [e[2] for e in extra]])).tocsr()
    for (cell, rho), conns in solids.items():
        hexes = Mesh(run.points, {cell: np.array(conns)})
        Ms = Ms + sp.block_diag([mass_matrix(hexes, rho), sp.csr_array((k, k))]).tocsr()
    notes = [f"mass assembled from {', '.join(f'{v} {t}' for t, v in run.element_types.items())}"
             + (f"; {k} CONM2 with an offset CG as nodes moving rigidly with their grid" if k else "")]
    return NodalMass(sp.csr_array(Ms), np.concatenate([J, np.array([e[3] for e in extra]).reshape(k, 3, 3)]),
                         np.array([e[0] for e in extra]).reshape(k, 3), np.array([e[1] for e in extra], np.int64),
                         notes)


def _element_mass(path, m, run: NastranModes, index: dict, diag: np.ndarray, J: np.ndarray) -> dict:
    """Lumped line and shell masses into ``diag`` and ``J``; the CHEXA connectivities by (cell type, rho)."""
    refused = sorted({e.type for e in m.elements.values()} - set(LINES) - set(SHELLS) - set(MASSLESS) - {"CHEXA"})
    if refused:
        raise BodyFileError(path, "elements", "element types whose mass the reader assembles (docs/format.md)",
                            ", ".join(refused))
    solids: dict[tuple[str, float], list] = {}
    for e in m.elements.values():
        if e.type in MASSLESS:
            continue
        nodes = [index[g] for g in e.node_ids if g is not None]
        if e.type == "CHEXA":
            _hexa(path, e, nodes, solids)
        elif e.type in LINES:
            a, b = nodes[:2]
            diag[[a, b]] += float(e.Mass()) / 2
            if e.type == "CBEAM":  # half the torsional inertia rho J L at each end, about the axis
                axis = (run.points[b] - run.points[a]) / e.Length()
                torsion = e.pid_ref.mid_ref.rho * np.atleast_1d(e.pid_ref.J())[0] * e.Length() / 2
                J[[a, b]] += torsion * np.outer(axis, axis)
        else:
            diag[nodes] += float(e.Mass()) / len(nodes)
    return solids


def _point_masses(path, m, run: NastranModes, index: dict, diag: np.ndarray, J: np.ndarray) -> list[tuple]:
    """CONM2 at their grid into ``diag`` and ``J``; those with an offset CG as (CG, grid index, mass, inertia)."""
    extra = []
    for c in m.masses.values():
        if c.type != "CONM2":
            raise BodyFileError(path, "masses", "CONM2 point masses", c.type)
        i = index[c.nid]
        cg, inertia = np.asarray(c.Centroid(), dtype=float), np.asarray(c.Inertia(), dtype=float)
        if np.linalg.norm(cg - run.points[i]) <= 1e-12 * max(1.0, np.abs(run.points).max()):
            diag[i] += c.mass
            J[i] += inertia
        else:
            extra.append((cg, i, c.mass, inertia))
    return extra


def _hexa(path, e, nodes: list[int], solids: dict) -> None:
    if len(nodes) not in (8, 20):
        raise BodyFileError(path, f"CHEXA {e.eid}", "8 or 20 nodes", str(len(nodes)))
    cell = "hexahedron" if len(nodes) == 8 else "hexahedron20"
    order = nodes if len(nodes) == 8 else [nodes[i] for i in HEX20]
    solids.setdefault((cell, float(e.pid_ref.mid_ref.rho)), []).append(order)


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
