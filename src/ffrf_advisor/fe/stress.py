"""Modal stress recovery: nodal-averaged stress tensors and von Mises per mode."""
from __future__ import annotations

import numpy as np

from .assembly import _blocks, _chunks, element_gradients
from .material import Material
from .mesh import Mesh


def von_mises(s: np.ndarray) -> np.ndarray:
    """Von Mises stress of symmetric tensors s (..., 3, 3)."""
    dev = s - np.trace(s, axis1=-2, axis2=-1)[..., None, None] * np.eye(3) / 3
    return np.sqrt(1.5 * np.einsum("...ij,...ij->...", dev, dev))


def nodal_stress(mesh: Mesh, material: Material, Phi: np.ndarray) -> np.ndarray:
    """Stress tensors (n, 3, 3, nf) of each mode at unit modal coordinate.

    Evaluated in every element at its own nodes and averaged over the
    elements that share a node (the usual nodal-averaged FE stress).
    """
    lam, mu = material.lame
    n, _, nf = Phi.shape
    total = np.zeros((n, 3, 3, nf))
    count = np.zeros(n)
    for etype, conn in _blocks(mesh):
        for part in _chunks(conn, etype.n_nodes**2 * 9 * nf):
            c = conn[part]
            G, _ = element_gradients(etype, mesh.points[c], etype.ref_nodes)  # (ne, nn, nm, 3)
            grad = np.einsum("enmi,emjp->enijp", G, Phi[c])  # d u_j / d x_i
            eps = 0.5 * (grad + grad.transpose(0, 1, 3, 2, 4))
            tr = np.einsum("eniip->enp", eps)
            sig = 2 * mu * eps + lam * tr[:, :, None, None, :] * np.eye(3)[None, None, :, :, None]
            np.add.at(total, c.ravel(), sig.reshape(-1, 3, 3, nf))
            np.add.at(count, c.ravel(), 1.0)
    return total / count[:, None, None, None]


def modal_von_mises(mesh: Mesh, material: Material, Phi: np.ndarray) -> np.ndarray:
    """Nodal von Mises stress (n, nf) of each mode at unit modal coordinate."""
    return von_mises(nodal_stress(mesh, material, Phi).transpose(0, 3, 1, 2))
