"""Bring an arbitrary modal basis into the form of theory section 1 (theory section 4).

Shift to the CoM, turn to the principal axes, M-orthogonalise the basis
against the six rigid-body modes, solve the reduced eigenproblem and
mass-normalise. Needs the stiffness K; without it only shift and rotation
are possible and the remaining failed assumptions must be reported.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .fe.assembly import full_mass
from .fe.modal import mass_normalised, rigid_modes, without_rigid
from .invariants import I0, principal_axes

RANK_TOL = 1e-10  # relative M-norm below which a projected basis vector is dependent


@dataclass(frozen=True)
class BasisTransform:
    """Result: eigenvalues (nf,), modes Phi (n, 3, nf) and points in the principal CoM frame."""

    eigenvalues: np.ndarray
    Phi: np.ndarray
    points: np.ndarray
    com: np.ndarray        # old-frame CoM
    rotation: np.ndarray   # columns: principal axes in the old frame
    dropped: int           # basis vectors removed as rigid or dependent


def to_section1_form(X: np.ndarray, Ms: sp.sparray, K: sp.sparray, Psi: np.ndarray) -> BasisTransform:
    """Transform basis Psi (3n x nb, node-interleaved) of the FE model (X, Ms, K) to free-surface modes."""
    M = full_mass(Ms)
    one = np.ones(len(X))
    mass = one @ (Ms @ one)
    c = (one @ (Ms @ X)) / mass
    Xc = X - c
    R = principal_axes(I0(Xc.T @ (Ms @ Xc)))
    lam, S, dropped = free_surface_ritz(M, K, Psi, rigid_modes(Xc))
    S = mass_normalised(S, M, Xc)
    n, nf = len(X), S.shape[1]
    Phi = np.einsum("ak,iap->ikp", R, S.reshape(n, 3, nf))
    return BasisTransform(lam, Phi, Xc @ R, c, R, dropped)


def free_surface_ritz(M: sp.sparray, K: sp.sparray, Psi: np.ndarray, rigid: np.ndarray) \
        -> tuple[np.ndarray, np.ndarray, int]:
    """Theory 4 on any DOF layout: Psi M-orthogonalised against the ``rigid`` modes, the dependent vectors
    dropped, the reduced eigenproblem solved. Eigenvalues, M-orthonormal Ritz vectors and the number dropped."""
    P = without_rigid(Psi, rigid, M)
    Mr = P.T @ (M @ P)
    Kr = P.T @ (K @ P)
    d, V = np.linalg.eigh(0.5 * (Mr + Mr.T))
    keep = d > RANK_TOL * d.max()
    T = V[:, keep] / np.sqrt(d[keep])
    A = T.T @ Kr @ T
    import scipy.linalg as sla  # scipy.linalg: ~0.1 s of import the analysis of a cached body does without
    lam, Z = sla.eigh(0.5 * (A + A.T))
    return np.asarray(lam), P @ (T @ Z), int(Psi.shape[1] - keep.sum())
