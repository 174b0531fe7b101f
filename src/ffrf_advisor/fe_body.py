"""FE data to a FlexibleBody: a solid mesh's assembly, free-free modes, modal stress and invariants, or modes
read from a file (above the body and the FE toolkit it uses: docs of the layout)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.sparse as sp

from .centrifugal import static_centrifugal
from .body import FlexibleBody, ModalFE, Provenance
from .units import TMM, Units
from .fe.assembly import full_mass, mass_matrix, stiffness_matrix
from .fe.material import Material
from .fe.mesh import Mesh
from .fe.geometric import modal_geometric
from .fe.modal import free_free_modes, mass_normalised
from .fe.stress import modal_von_mises


def modal_body(mesh: Mesh, material: Material, n_modes: int, name: str = "body",
               lumping: str | None = None, report=None, added_mass: sp.sparray | None = None) -> FlexibleBody:
    """Free-free modal body of ``mesh`` in t-mm-N-s, in its CoM principal frame (theory sections 1-3), with
    its static centrifugal response and geometric stiffness (theory 9, 11).

    ``lumping`` None gives the consistent mass; 'rowsum' or 'hrz' a diagonal
    mass, used for both the eigenproblem and the invariants. ``added_mass``, a
    scalar nodal mass (n x n; theory 2) such as that of denser parts assembled
    on a sub-mesh (``Mesh.cells_where``) with their extra density, adds to the
    material's; the stiffness stays the material's. ``report(step)``, when
    given, hears of each step before it starts (long work shows progress).
    """
    say = report or (lambda step: None)
    say(f"assembling mass and stiffness ({3 * mesh.n_nodes} DOFs)")
    Ms = mass_matrix(mesh, material.rho, lumping)
    if added_mass is not None:
        Ms = sp.csr_array(Ms + added_mass)
    K = stiffness_matrix(mesh, material)
    say(f"free-free modal analysis ({n_modes} modes)")
    modes = free_free_modes(K, Ms, mesh.points, n_modes)
    say("modal stresses")
    stress = modal_von_mises(mesh, material, modes.Phi)
    provenance = Provenance(
        source="ffrf_advisor.fe generator",
        mass_matrix="lumped" if lumping else "consistent",
        notes=(f"{material.name}: E={material.E:g}, nu={material.nu:g}, rho={material.rho:g}",
               f"{mesh.n_cells} x {', '.join(mesh.cells)}, {mesh.n_nodes} nodes"
               + (f", {lumping} lumped mass" if lumping else "")
               + ("" if added_mass is None else f", added mass {added_mass.sum():g}")),
    )
    body = fe_body(name, mesh, Ms, modes.Phi, modes.eigenvalues, provenance, K, stress, material)
    say("static centrifugal response and geometric stiffness")
    return with_centrifugal_response(body)


def fe_body(name: str, mesh: Mesh, Ms, Phi: np.ndarray, eigenvalues: np.ndarray, provenance: Provenance,
            K=None, stress: np.ndarray | None = None, material: Material | None = None,
            units: Units = TMM) -> FlexibleBody:
    """The body of mass-normalised modes on ``mesh`` (in ``units``), in its CoM principal frame."""
    fe = ModalFE(mesh, Ms, Phi, K, stress, material)
    body = FlexibleBody(
        name=name,
        integrals=fe.integrals(),
        eigenvalues=eigenvalues,
        units=units,
        sigma_max=None if stress is None else stress.max(axis=0),
        provenance=provenance,
        fe=fe,
    )
    return body.in_principal_frame()[0]


def with_centrifugal_response(body: FlexibleBody) -> FlexibleBody:
    """``body`` with its exact static centrifugal response per principal axis (theory 11) and its modal
    geometric stiffness G_kl (theory 9), from one factorisation of K; needs the material."""
    fe = body.fe
    static, U = static_centrifugal(fe, fe.material)
    return replace(body, static_centrifugal=static, geometric=modal_geometric(fe.mesh, fe.material, fe.Phi, U))


def mass_normalised_file_modes(Ms, Phi: np.ndarray, stress: np.ndarray | None, X: np.ndarray):
    """Modes (n, 3, nf) of a file on nodes X scaled to unit modal mass, their nodal stresses scaled alike.

    Returns (Phi, stress, scale) with ``scale`` the file modes' sqrt(modal mass).
    """
    M, S = full_mass(Ms), Phi.reshape(-1, Phi.shape[2])
    scale = np.sqrt(np.einsum("ip,ip->p", S, M @ S))
    return (mass_normalised(S, M, X).reshape(Phi.shape), None if stress is None else stress / scale, scale)
