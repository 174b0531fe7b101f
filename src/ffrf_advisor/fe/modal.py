"""Free-free modal analysis: shift-invert Lanczos, rigid-mode check, mass normalisation."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .assembly import full_mass

N_RIGID = 6
RIGID_TOL = 1e-6  # |lambda_rigid| / lambda_first_flexible


@dataclass(frozen=True)
class ModalResult:
    """Flexible eigenvalues (nf,), mass-normalised modes Phi (n, 3, nf), and the rigid eigenvalues found."""

    eigenvalues: np.ndarray
    Phi: np.ndarray
    rigid_eigenvalues: np.ndarray


def free_free_modes(K: sp.sparray, Ms: sp.sparray, n_flex: int, shift: float | None = None) -> ModalResult:
    """The lowest ``n_flex`` flexible modes of a free body (theory section 1, assumption 3).

    Solves K phi = lambda M phi with M = kron(Ms, I3) in shift-invert mode about
    a small negative shift (K is singular), checks that exactly six near-zero
    eigenvalues (the rigid modes) come first and drops them. Modes are
    M-normalised and signed so that their largest component is positive.
    """
    M = full_mass(Ms)
    K = sp.csr_array((K + K.T) / 2)
    n3 = K.shape[0]
    k = n_flex + N_RIGID
    if k >= n3:
        raise ValueError(f"asked for {n_flex} flexible modes but the model has only {n3} DOFs")
    if shift is None:
        shift = -1e-3 * _rayleigh_scale(K, M)
    v0 = np.cos(np.arange(n3) * 0.7548776662466927)  # deterministic start: reproducible output
    lam, vec = spla.eigsh(K, k=k, M=M, sigma=shift, which="LM", v0=v0, tol=0.0)
    order = np.argsort(lam)
    lam, vec = lam[order], vec[:, order]
    rigid, flex = lam[:N_RIGID], lam[N_RIGID:]
    if flex[0] <= 0 or np.any(np.abs(rigid) > RIGID_TOL * flex[0]):
        raise ValueError(
            f"expected six rigid modes below {RIGID_TOL:g} x the first flexible eigenvalue, found "
            f"eigenvalues {', '.join(f'{x:.3e}' for x in lam[:N_RIGID + 1])}: the body is not free-free "
            "or not connected")
    Phi = mass_normalised(vec[:, N_RIGID:], M)
    return ModalResult(flex, Phi.reshape(n3 // 3, 3, n_flex), rigid)


def mass_normalised(S: np.ndarray, M: sp.sparray) -> np.ndarray:
    """Columns scaled to S^T M S = 1 and signed so that their largest component is positive."""
    S = S / np.sqrt(np.einsum("ip,ip->p", S, M @ S))
    return S * np.sign(S[np.argmax(np.abs(S), axis=0), np.arange(S.shape[1])])


def _rayleigh_scale(K: sp.sparray, M: sp.sparray) -> float:
    """A rough lowest-eigenvalue scale: smallest positive diagonal ratio, shrunk."""
    ratio = K.diagonal() / M.diagonal()
    return float(np.min(ratio[ratio > 0])) * 1e-6
