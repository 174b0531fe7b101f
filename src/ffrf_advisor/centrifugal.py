"""The exact static centrifugal response of an FE body (theory section 11).

Spin ``s`` about a unit axis ``a`` through the CoM loads the body with
``f = s^2 M vec(x - (a . x) a)`` (the centrifugal body force on the nodes).
The exact static response solves ``K u = f`` with inertia relief (the load's
rigid part removed; nothing for a principal axis, where the load is
self-equilibrated): three supports that only fix the rigid motion (3-2-1,
statically determinate, so they carry no reaction), one sparse
factorisation, then the rigid part of u removed. Per principal axis and per
unit spin^2 (rad per body time unit) the body keeps the compliance ``f^T u``
and the largest von Mises stress of u (``StaticCentrifugal``): both depend
on the FE model only, not on the kept modes; ``adequacy`` judges the kept
modes from them.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .body import SYM_PAIRS, StaticCentrifugal
from .errors import FFRFError
from .fe.assembly import full_mass, stiffness_matrix
from .fe.modal import rigid_modes, spd_solver
from .fe.stress import nodal_stress, von_mises


def centrifugal_loads(X: np.ndarray, Ms) -> np.ndarray:
    """(3n, 6): the symmetrised centrifugal load cases ``f_kl`` (order 11 22 33 12 13 23; the body force at
    spin w is ``sum_kl w_k w_l f_kl``, theory 9) about axes through the frame's origin (the CoM of a body in its
    principal frame), inertia-relieved. The first three are the loads of unit spin about the axes."""
    M = full_mass(Ms)
    cols = []
    for k, l in SYM_PAIRS:
        a = np.zeros_like(X)
        if k == l:
            a += X
        a[:, k] -= 0.5 * X[:, l]
        a[:, l] -= 0.5 * X[:, k]
        cols.append(M @ a.ravel())
    F = np.column_stack(cols)
    R = rigid_modes(X)
    return F - M @ (R @ np.linalg.solve(R.T @ (M @ R), R.T @ F))


def support_dofs(X: np.ndarray) -> np.ndarray:
    """Six DOFs (node-interleaved) that fix the rigid motion only: 3 at a node A far from the centre, 2 at the
    node B farthest from A (across AB), 1 at the node C farthest from the line AB (out of plane ABC)."""
    A = int(np.argmax(np.linalg.norm(X - X.mean(axis=0), axis=1)))
    B = int(np.argmax(np.linalg.norm(X - X[A], axis=1)))
    ab = (X[B] - X[A]) / np.linalg.norm(X[B] - X[A])
    off = (X - X[A]) - np.outer((X - X[A]) @ ab, ab)
    C = int(np.argmax(np.linalg.norm(off, axis=1)))
    normal = np.cross(ab, off[C])
    across = np.argsort(np.abs(ab))[:2]
    dofs = np.array([3 * A, 3 * A + 1, 3 * A + 2, *(3 * B + across), 3 * C + int(np.argmax(np.abs(normal)))])
    R = rigid_modes(X)
    if np.linalg.cond(R[dofs]) > 1e8:
        raise ValueError("no statically determinate support found: the mesh is degenerate (collinear nodes)")
    return dofs


def static_deflections(X: np.ndarray, Ms, K, F: np.ndarray) -> np.ndarray:
    """u with ``K u = F`` for self-equilibrated loads F (3n, k), free of rigid motion (M-orthogonal to it)."""
    n3 = K.shape[0]
    free = np.ones(n3, bool)
    free[support_dofs(X)] = False
    solve = spd_solver(sp.csr_array(K)[free][:, free])
    U = np.zeros_like(F)
    U[free] = solve(np.ascontiguousarray(F[free]))
    M, R = full_mass(Ms), rigid_modes(X)
    return U - R @ np.linalg.solve(R.T @ (M @ R), R.T @ (M @ U))


def static_centrifugal(fe, material) -> tuple[StaticCentrifugal, np.ndarray]:
    """The exact static response of an FE body to the six load cases at unit spin: the stored summary of the
    principal axes (compliance, largest von Mises stress) and the deflections U (3n, 6) (the first three are the
    residual vectors of ``augment``, all six give the prestress of the geometric stiffness)."""
    if fe.rotary is not None:
        raise FFRFError("static centrifugal response: expected translational (solid-element) nodes; this body's "
                        f"{len(fe.rotary.nodes)} nodes with rotary inertia (theory 3b) need 6-DOF stiffness and "
                        "loads, which are not supported")
    X = fe.mesh.points
    K = fe.K if fe.K is not None else stiffness_matrix(fe.mesh, material)
    F = centrifugal_loads(X, fe.Ms)
    U = static_deflections(X, fe.Ms, K, F)
    n = len(X)
    sigma = von_mises(nodal_stress(fe.mesh, material, U[:, :3].reshape(n, 3, 3)).transpose(0, 3, 1, 2)).max(axis=0)
    return StaticCentrifugal(np.einsum("ik,ik->k", F[:, :3], U[:, :3]), sigma), U
