"""Geometric (stress) stiffness of a prestressed solid and its modal matrices (theory section 9).

For a Cauchy prestress sigma the geometric stiffness is
``K_G[a i, b j] = delta_ij int dN_a/dx_m sigma_mn dN_b/dx_n dV``: a scalar
nodal matrix ``Ks`` (n x n) times I3, like the mass, so the modal matrix is
``Phi^T K_G Phi = sum_i Phi_i^T Ks Phi_i`` over the three components. The
prestress of each centrifugal load case comes from its static deflection
(``centrifugal.static_centrifugal``); the element integrals use the elements'
full Gauss rules.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .assembly import _blocks, _chunks, element_gradients, scattered, summed
from .material import Material
from .mesh import Mesh


def _element_geometric(etype, coords: np.ndarray, material: Material, ue: np.ndarray) -> np.ndarray:
    """Scalar element geometric stiffness (ne, nn, nn) of the prestress of nodal displacements ue (ne, nn, 3)."""
    lam, mu = material.lame
    xi, w = etype.gauss_rule()
    G, detJ = element_gradients(etype, coords, xi)  # (ne, nq, nn, 3)
    grad = np.einsum("eqni,enj->eqij", G, ue)  # d u_j / d x_i
    eps = 0.5 * (grad + grad.transpose(0, 1, 3, 2))
    sig = 2 * mu * eps + lam * np.einsum("eqii->eq", eps)[:, :, None, None] * np.eye(3)
    return np.einsum("eqni,eqij,eqmj,eq->enm", G, sig, G, detJ * w, optimize=True)


def geometric_scalar(mesh: Mesh, material: Material, u: np.ndarray) -> sp.csr_array:
    """``Ks`` (n x n) of the prestress of the displacement field u (n, 3); K_G = kron(Ks, I3)."""
    n = mesh.n_nodes
    return summed((scattered(_element_geometric(etype, mesh.points[conn[part]], material, u[conn[part]]),
                             conn[part], n)
                   for etype, conn in _blocks(mesh) for part in _chunks(conn, etype.n_nodes**2 * 9)), (n, n))


def modal_geometric(mesh: Mesh, material: Material, Phi: np.ndarray, U: np.ndarray) -> np.ndarray:
    """The six modal geometric stiffness matrices G_kl (6, nf, nf) of the load cases' deflections U (3n, 6)."""
    n = mesh.n_nodes
    out = []
    for c in range(U.shape[1]):
        Ks = geometric_scalar(mesh, material, U[:, c].reshape(n, 3))
        Gc = sum(Phi[:, i, :].T @ (Ks @ Phi[:, i, :]) for i in range(3))
        out.append(0.5 * (Gc + Gc.T))
    return np.array(out)
