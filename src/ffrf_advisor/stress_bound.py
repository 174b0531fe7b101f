"""Modal stresses against what the modes allow (docs/advice.md, "The modal-stress bound"), at each mode's peak node.

The bound needs no redundancy: for a mass-normalised mode, sum_e U_e = lambda_p / 2 with every U_e >= 0, and
the distortion part of the energy density is (1 + nu) s_vm^2 / (3 E); so int_e s_vm^2 dV <= 3 E lambda_p /
(2 (1 + nu)) in every element e. The inverse inequality of the element's stress space at its nodes, max s^2 <=
C / V_e int_e s^2 dV (``inverse_constant``), then gives s_vm <= sqrt(C 3 E lambda_p / (2 (1 + nu) V_e)); a
nodal average of tensors is at most the largest of them, so the bound at a node is that of its worst cell.

The recomputation uses the redundancy of a body with its material: the von Mises stress of the mode at the peak
node, by the toolkit's own nodal-averaged recovery (``fe.stress``) from the modes.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np

from .body import ModalFE
from .fe.assembly import _jacobians
from .fe.elements import ELEMENT_TYPES
from .fe.mesh import Mesh
from .fe.stress import modal_von_mises

ALLOWANCE = 8.0  # on C: curved cells reach 3.2 C (the zoo's round bars), other codes extrapolate (docs/advice.md)
RANK = 1e-10     # Gram eigenvalues below this share of the largest span nothing (dependent derivatives)


@cache
def inverse_constant(name: str) -> float:
    """C of ``max_nodes |s|^2 <= C / |T| int_T |s|^2`` for s in the span of the shape-function derivatives of
    cell type ``name`` on its reference element (the Christoffel function at the nodes times |T|): exact for
    affine cells, whose stress components lie in that span."""
    etype = ELEMENT_TYPES[name]
    xi, w = etype.mass_rule()  # exact for products of two derivatives (degree at most that of N_a N_b)
    _, dN = etype.shape(xi)
    F = dN.reshape(len(w), -1)  # (nq, nn * 3): every derivative dN_a / dxi_j
    lam, U = np.linalg.eigh(F.T @ (w[:, None] * F))
    keep = lam > RANK * lam.max()
    _, dN_nodes = etype.shape(etype.ref_nodes)
    values = dN_nodes.reshape(etype.n_nodes, -1) @ U[:, keep] / np.sqrt(lam[keep])  # orthonormal basis at nodes
    return float(w.sum() * np.max(np.einsum("ni,ni->n", values, values)))


def holding(mesh: Mesh, nodes) -> dict[str, np.ndarray]:
    """The solid cells of ``mesh`` that hold any of ``nodes``, by cell type (types without any left out)."""
    cells = {name: conn[np.isin(conn, nodes).any(axis=1)] for name, conn in mesh.cells.items()
             if name in ELEMENT_TYPES}
    return {name: conn for name, conn in cells.items() if len(conn)}


def around(mesh: Mesh, node: int) -> tuple[Mesh, np.ndarray]:
    """The solid cells that hold ``node`` as a mesh of their own nodes, and those nodes' indices in ``mesh``."""
    cells = holding(mesh, [node])
    nodes = np.unique(np.concatenate([c.ravel() for c in cells.values()])) if cells else np.array([node])
    return Mesh(mesh.points[nodes], {name: np.searchsorted(nodes, c) for name, c in cells.items()}), nodes


def cell_volumes(mesh: Mesh, name: str) -> np.ndarray:
    """Volumes of the cells ``name`` of ``mesh``: sum_q w_q det J by the mass rule (exact for det J), in chunks of
    about a million Jacobian entries."""
    etype, conn = ELEMENT_TYPES[name], mesh.cells[name]
    xi, w = etype.mass_rule()
    size = max(1, 2**20 // (9 * len(w)))
    return np.concatenate([_jacobians(etype, mesh.points[conn[a:a + size]], xi)[2] @ w
                           for a in range(0, len(conn), size)] or [np.zeros(0)])


def solid_volume(mesh: Mesh) -> float:
    """The volume of the solid cells of ``mesh`` (0 without any)."""
    return float(sum(cell_volumes(mesh, name).sum() for name in mesh.cells if name in ELEMENT_TYPES))


def capacity(mesh: Mesh) -> float:
    """max over the cells of ALLOWANCE C_e / V_e; 0 without cells."""
    return float(max((ALLOWANCE * inverse_constant(name) / cell_volumes(mesh, name).min() for name in mesh.cells),
                     default=0.0))


@dataclass(frozen=True)
class PeakStress:
    """Per mode: its peak nodal von Mises stress in the file, the node, the bound there (inf: no solid cell at it, or
    a node of shells or beams) and the stress recomputed there from the modes and the material (NaN: likewise)."""

    sigma: np.ndarray
    node: np.ndarray
    bound: np.ndarray
    recomputed: np.ndarray


def peak_stress(fe: ModalFE, eigenvalues: np.ndarray) -> PeakStress | None:
    """The bound and the recomputed stress at each mode's peak node (module docstring); None without nodal
    stress, material or solid cells."""
    if fe.stress_nodal is None or fe.material is None or not fe.mesh.cells:
        return None
    nf = fe.Phi.shape[2]
    node = np.argmax(fe.stress_nodal, axis=0)
    sigma = fe.stress_nodal[node, np.arange(nf)]
    energy = 3 * fe.material.E * np.clip(eigenvalues, 0, None) / (2 * (1 + fe.material.nu))  # >= int s_vm^2
    bound, recomputed = np.full(nf, np.inf), np.full(nf, np.nan)
    peaks = Mesh(fe.mesh.points, holding(fe.mesh, node))  # one pass over the cells; then only theirs per mode
    structural = set() if fe.rotary is None else set(fe.rotary.nodes.tolist())  # shells, beams: not bounded here
    for p in range(nf):
        if int(node[p]) in structural:
            continue
        local, nodes = around(peaks, int(node[p]))
        if local.cells:
            bound[p] = np.sqrt(capacity(local) * energy[p])
            at = int(np.searchsorted(nodes, node[p]))
            recomputed[p] = modal_von_mises(local, fe.material, fe.Phi[nodes][:, :, p:p + 1])[at, 0]
    return PeakStress(sigma, node, bound, recomputed)
