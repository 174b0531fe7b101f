"""A FlexibleBody from a solid mesh: assembly, free-free modes, modal stress, invariants."""
from __future__ import annotations

from ..body import FlexibleBody, ModalFE, Provenance
from ..invariants import shape_integrals
from ..units import TMM
from .assembly import mass_matrix, stiffness_matrix
from .material import Material
from .mesh import Mesh
from .modal import free_free_modes
from .stress import modal_von_mises


def modal_body(mesh: Mesh, material: Material, n_modes: int, name: str = "body",
               lumping: str | None = None) -> FlexibleBody:
    """Free-free modal body of ``mesh`` in t-mm-N-s, in its CoM principal frame (theory sections 1-3).

    ``lumping`` None gives the consistent mass; 'rowsum' or 'hrz' a diagonal
    mass, used for both the eigenproblem and the invariants.
    """
    Ms = mass_matrix(mesh, material.rho, lumping)
    K = stiffness_matrix(mesh, material)
    modes = free_free_modes(K, Ms, mesh.points, n_modes)
    stress = modal_von_mises(mesh, material, modes.Phi)
    provenance = Provenance(
        source="ffrf_advisor.fe generator",
        mass_matrix="lumped" if lumping else "consistent",
        notes=(f"{material.name}: E={material.E:g}, nu={material.nu:g}, rho={material.rho:g}",
               f"{mesh.n_cells} x {', '.join(mesh.cells)}, {mesh.n_nodes} nodes"
               + (f", {lumping} lumped mass" if lumping else "")),
    )
    body = FlexibleBody(
        name=name,
        integrals=shape_integrals(mesh.points, Ms, modes.Phi),
        eigenvalues=modes.eigenvalues,
        units=TMM,
        sigma_max=stress.max(axis=0),
        provenance=provenance,
        fe=ModalFE(mesh, Ms, modes.Phi, K, stress),
    )
    return body.in_principal_frame()[0]
