"""Mass and stiffness matrices punched by Nastran (``PARAM,EXTOUT,DMIGPCH``): DMIG ``MAAX`` and ``KAAX`` in
``JOBNAME.pch`` beside ``JOBNAME.op2`` (theory 3b and 4).

In the matrices here, DOF ``6 i + c`` is component c (T1-T3, R1-R3) of the run's grid i, in basic
coordinates (Nastran punches them in each grid's CD frame). DOFs the punch does not list (MPC-dependent
DOFs of the a-set) have no entries: their mass and stiffness are condensed into the others.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..errors import BodyFileError
from ..fe.modal import rigid_residual
from .limits import check_file_size
from .nastran_mass import NodalMass
from .pynastran import quietly

MASS, STIFFNESS = "MAAX", "KAAX"
OFFSET_TOL = 1e-9  # a grid block as a rigid mass off the grid, to the punch's 11 significant digits
PUNCH_FACTOR = 8  # bytes of pyNastran's card objects per byte of punch (16-character fields, two lines a term)


@dataclass
class Matrices:
    """The punched matrices of a run over its grids (6n x 6n, basic); None where the punch has none."""

    source: str
    M: sp.csr_array | None
    K: sp.csr_array | None


def read(pch: str, grids: np.ndarray, frames: np.ndarray) -> Matrices:
    """``MAAX`` and ``KAAX`` of the punch ``pch`` over ``grids``; ``frames[i]`` turns grid i's CD to basic."""
    check_file_size(pch, PUNCH_FACTOR)
    cards = _load(pch)
    index = {int(g): i for i, g in enumerate(grids)}
    T = _frame_matrix(frames)
    M, K = (None if name not in cards else _matrix(pch, name, cards[name], index, T) for name in (MASS, STIFFNESS))
    if M is None and K is None:
        raise BodyFileError(pch, "DMIG", f"the matrices {MASS} or {STIFFNESS} (PARAM,EXTOUT,DMIGPCH)",
                            ", ".join(sorted(cards)) or "none")
    return Matrices(pch, M, K)


def _load(pch: str) -> dict:
    from pyNastran.bdf.bdf import read_bdf

    return quietly(pch, "a punch file pyNastran can read", read_bdf, pch, punch=True, xref=False, validate=False,
                   read_cards=["DMIG"]).dmig


def _matrix(pch: str, name: str, dmig, index: dict, T: sp.csr_array) -> sp.csr_array:
    """One DMIG over the grids' 6 DOFs, turned to basic: ``T A T^T``."""
    field = f"DMIG {name}"
    if dmig.matrix_form not in (1, 6) or dmig.tin not in (1, 2):
        raise BodyFileError(pch, field, "a real square or symmetric matrix (IFO 1 or 6, TIN 1 or 2)",
                            f"IFO {dmig.matrix_form}, TIN {dmig.tin}")
    try:
        A, rows, cols = dmig.get_matrix(is_sparse=True, apply_symmetry=dmig.matrix_form == 6)
    except (Exception, SystemExit) as e:
        raise BodyFileError(pch, field, "a matrix pyNastran can assemble", f"{type(e).__name__}: {e}") from None
    A = sp.coo_array(A)
    r, c = _dofs(pch, field, rows, index), _dofs(pch, field, cols, index)
    n6 = 6 * len(index)
    full = sp.csr_array((A.data.astype(float), (r[A.row], c[A.col])), shape=(n6, n6))
    turned = sp.csr_array(T @ full @ T.T)
    if not np.all(np.isfinite(turned.data)):
        raise BodyFileError(pch, field, "finite numbers", "NaN or infinity")
    return turned


def _dofs(pch: str, field: str, labels: dict, index: dict) -> np.ndarray:
    """Matrix index -> DOF 6 i + c - 1 of (grid, component c)."""
    out = np.empty(len(labels), np.int64)
    for k, label in labels.items():
        grid, comp = (label, 0) if np.isscalar(label) else label
        if comp not in range(1, 7) or int(grid) not in index:
            what = f"scalar point {grid}" if comp == 0 else f"grid {grid} component {comp}"
            raise BodyFileError(pch, field, "terms on the components 1-6 of the OP2's grids", what)
        out[k] = 6 * index[int(grid)] + comp - 1
    return out


def _frame_matrix(frames: np.ndarray) -> sp.csr_array:
    """Block diagonal of (F_i, F_i) per grid: basic DOFs = T times CD DOFs."""
    n = len(frames)
    blocks = np.zeros((n, 2, 3, 2, 3))
    blocks[:, 0, :, 0, :] = blocks[:, 1, :, 1, :] = frames
    rows = (6 * np.arange(n))[:, None, None] + np.arange(6)[None, :, None] + np.zeros((1, 1, 6), int)
    cols = np.transpose(rows, (0, 2, 1))
    return sp.csr_array((blocks.reshape(n, 6, 6).ravel(), (rows.ravel(), cols.ravel())), shape=(6 * n, 6 * n))


# ---------------------------------------------------------------- 6-DOF vectors and the nodal form (theory 3b)
def six_dof(T: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Translations and rotations (n, 3, k) as 6n x k vectors in the DOF order of the matrices."""
    n, _, k = T.shape
    return np.concatenate([T, R], axis=1).reshape(6 * n, k)


def rigid_modes_6(X: np.ndarray) -> np.ndarray:
    """The six rigid-body modes of 6-DOF nodes at X (6n x 6): translations e_k; rotations (e_k x x, e_k)."""
    n = len(X)
    R = np.zeros((n, 6, 6))
    for k in range(3):
        R[:, k, k] = 1.0
        R[:, :3, 3 + k] = np.cross(np.eye(3)[k], X)
        R[:, 3 + k, 3 + k] = 1.0
    return R.reshape(6 * n, 6)


def nodal_form(M: sp.csr_array, X: np.ndarray, source: str) -> NodalMass:
    """The part of a 6-DOF mass that the body model holds (theory 3b): the scalar mass Ms (n x n), the mean of
    the T1, T2, T3 blocks, and the nodal rotary inertia J (n, 3, 3), the diagonal blocks of the rotations.

    A grid whose 6 x 6 block is that of a rigid mass off the grid (``[[m I, -m a~], [m a~, J]]``, its
    translations coupled to no other grid: lumped masses, CONM2 with an offset) becomes a node at x + a that
    moves rigidly with the grid, with the inertia ``J - m a~^T a~`` about it: exact. Other couplings
    (consistent beam mass) are dropped; ``rigid_mass_loss`` measures them.
    """
    n = M.shape[0] // 6
    B = _diagonal_blocks(M, n)
    Ms = sp.csr_array(sum(M[np.arange(n) * 6 + c][:, np.arange(n) * 6 + c] for c in range(3)) / 3)
    J = 0.5 * (B[:, 3:, 3:] + B[:, 3:, 3:].transpose(0, 2, 1))
    off = _offset_nodes(M, B)
    m = np.trace(B[off, :3, :3], axis1=1, axis2=2) / 3
    a_tilde = -B[off, :3, 3:] / m[:, None, None]
    a = np.stack([a_tilde[:, 2, 1], a_tilde[:, 0, 2], a_tilde[:, 1, 0]], axis=1)
    J_cg = J[off] - m[:, None, None] * np.einsum("kba,kbc->kac", a_tilde, a_tilde)
    Ms = Ms - sp.diags_array(np.bincount(off, weights=m, minlength=n).astype(float))
    J[off] = 0.0
    return NodalMass(sp.csr_array(sp.block_diag([Ms, sp.diags_array(m)])), np.concatenate([J, J_cg]),
                     X[off] + a, off, [f"mass from DMIG {MASS} of {os.path.basename(source)}"
                                       + (f"; {len(off)} grids' mass off the grid as nodes moving rigidly with it"
                                          if len(off) else "")],
                     f"the nodal form of {MASS}")


def _diagonal_blocks(M: sp.csr_array, n: int) -> np.ndarray:
    """Each grid's 6 x 6 block (n, 6, 6)."""
    return np.stack([np.stack([M[np.arange(n) * 6 + a][:, np.arange(n) * 6 + b].diagonal() for b in range(6)], -1)
                     for a in range(6)], 1)


def _offset_nodes(M: sp.csr_array, B: np.ndarray) -> np.ndarray:
    """Grids whose block is a rigid mass off the grid: translations m I, coupling -m a~ (skew), translations
    coupled to no other grid (to the punch's 11 digits)."""
    m = np.trace(B[:, :3, :3], axis1=1, axis2=2) / 3
    C = B[:, :3, 3:]
    scale = np.abs(C).max(axis=(1, 2))
    coo = M.tocoo()
    coupled = np.unique(coo.row[(coo.row % 6 < 3) & (coo.row // 6 != coo.col // 6) & (coo.data != 0)] // 6)
    isotropic = np.abs(B[:, :3, :3] - m[:, None, None] * np.eye(3)).max(axis=(1, 2)) <= OFFSET_TOL * m
    skew = np.abs(C + C.transpose(0, 2, 1)).max(axis=(1, 2)) <= OFFSET_TOL * scale
    ok = (m > 0) & (scale > 0) & isotropic & skew
    ok[coupled] = False
    return np.flatnonzero(ok)


def nodal_matrix(mass: NodalMass, X: np.ndarray) -> sp.csr_array:
    """The 6-DOF mass over the grids that a nodal mass stands for: Ms on each translation, J_i on the rotations
    of node i, and each extra node's mass and inertia carried to its grid (``L^T (m, J) L``, L = [[I, -a~],
    [0, I]])."""
    n = mass.Ms.shape[0] - len(mass.extra_of)
    k = len(mass.extra_of)
    trans = sp.kron(mass.Ms, sp.diags_array([1.0, 1, 1, 0, 0, 0]))
    rows = (6 * np.arange(n + k) + 3)[:, None, None] + np.arange(3)[None, :, None] + np.zeros((1, 1, 3), int)
    rot = sp.csr_array((mass.J.ravel(), (rows.ravel(), np.transpose(rows, (0, 2, 1)).ravel())),
                       shape=(6 * (n + k), 6 * (n + k)))
    carry = _carry(mass, X)
    return sp.csr_array(carry.T @ (trans + rot) @ carry)


def _carry(mass: NodalMass, X: np.ndarray) -> sp.csr_array:
    """DOFs of the grids X and extra nodes from the grids' DOFs (6 (n + k) x 6 n): u = u_g - a~ theta_g."""
    n, k = len(X), len(mass.extra_of)
    L = np.tile(np.eye(6), (k, 1, 1))
    L[:, :3, 3:] = -np.cross(np.eye(3)[None], (mass.extra_points - X[mass.extra_of])[:, None, :])  # -a~
    rows = 6 * (n + np.arange(k))[:, None, None] + np.arange(6)[None, :, None] + np.zeros((1, 1, 6), int)
    cols = 6 * mass.extra_of[:, None, None] + np.arange(6)[None, None, :] + np.zeros((1, 6, 1), int)
    extra = sp.csr_array((L.ravel(), (rows.ravel(), cols.ravel())), shape=(6 * (n + k), 6 * n))
    return sp.csr_array(sp.eye_array(6 * (n + k), 6 * n) + extra)


def rigid_mass_loss(M: sp.csr_array, mass: NodalMass, X: np.ndarray) -> float:
    """How much of the rigid-body mass matrix of M the nodal mass loses: max |R^T (Mn - M) R| / max |R^T M R|,
    with the rotations of the rigid modes R scaled by the body's size (dimensionless)."""
    R = rigid_modes_6(X - X.mean(axis=0))
    R[:, 3:] /= max(np.ptp(X, axis=0).max(), np.finfo(float).tiny)
    full = R.T @ (M @ R)
    nodal = R.T @ (nodal_matrix(mass, X) @ R)
    return float(np.abs(nodal - full).max() / np.abs(full).max())


def free_body_residual(K: sp.csr_array, X: np.ndarray) -> float:
    """fe.modal.rigid_residual of K with the six-DOF rigid modes of the grids X."""
    return rigid_residual(K, rigid_modes_6(X - X.mean(axis=0)))
