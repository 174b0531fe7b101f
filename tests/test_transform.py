"""Arbitrary basis -> section-1 form (theory section 4)."""
from __future__ import annotations

import numpy as np

from ffrf_advisor.fe.assembly import mass_matrix, stiffness_matrix
from ffrf_advisor.fe.material import STEEL
from ffrf_advisor.fe.mesh import box_mesh
from ffrf_advisor.fe.modal import free_free_modes
from ffrf_advisor.invariants import shape_integrals
from ffrf_advisor.transform import to_section1_form

NF = 8


def _rotation(rng):
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return Q * np.sign(np.linalg.det(Q))


def test_mixed_rotated_unnormalised_basis_recovers_modes_and_invariants(rng):
    mesh = box_mesh([200.0, 60.0, 30.0], [6, 2, 1], "hexahedron27")
    Ms = mass_matrix(mesh, STEEL.rho)
    ref = free_free_modes(stiffness_matrix(mesh, STEEL), Ms, mesh.points, NF)
    J_ref = shape_integrals(mesh.points, Ms, ref.Phi)

    R0, t = _rotation(rng), np.array([120.0, -40.0, 75.0])
    moved = mesh.transformed(R0, t)
    Ms_m, K_m = mass_matrix(moved, STEEL.rho), stiffness_matrix(moved, STEEL)
    flex = free_free_modes(K_m, Ms_m, moved.points, NF).Phi.reshape(-1, NF)
    X = moved.points
    rigid = np.zeros((len(X), 3, 6))
    for k in range(3):
        rigid[:, k, k] = 1.0
        rigid[:, :, 3 + k] = np.cross(np.eye(3)[k], X)  # rotations about the (wrong) origin
    basis = np.hstack([rigid.reshape(-1, 6), flex])
    Psi = basis @ rng.normal(size=(NF + 6, NF + 6)) * rng.uniform(0.1, 10, NF + 6)

    out = to_section1_form(X, Ms_m, K_m, Psi)
    assert out.dropped == 6
    assert np.abs(out.eigenvalues / ref.eigenvalues - 1).max() < 1e-8
    assert np.abs(out.com - t).max() < 1e-9 * 200

    # The recovered axes are the box axes up to a signed permutation.
    P = R0.T @ out.rotation
    assert np.abs(np.abs(P).round() - np.abs(P)).max() < 1e-8
    P = P.round()
    J_out = shape_integrals(out.points, Ms_m, out.Phi)
    J_exp = J_ref.rotated(P)
    overlap = _overlap(out.Phi, np.einsum("ak,iap->ikp", P, ref.Phi), Ms)
    assert np.allclose(np.abs(overlap), 1, atol=1e-8)  # same modes, up to sign
    d = np.sign(overlap)
    assert np.abs(J_out.I - J_exp.I).max() < 1e-9 * np.abs(J_exp.I).max()
    assert np.abs(J_out.Ibar - J_exp.Ibar * d).max() < 1e-8 * np.abs(J_exp.Ibar).max()
    assert np.abs(J_out.Sbar - J_exp.Sbar * np.outer(d, d)).max() < 1e-8
    assert np.abs(np.einsum("kkpr->pr", J_out.Sbar) - np.eye(NF)).max() < 1e-10
    assert np.abs(J_out.mode_sum).max() / np.sqrt(J_out.mass) < 1e-9


def _overlap(Phi_a, Phi_b, Ms):
    """M-inner products <a_p, b_p> of corresponding modes."""
    n = Phi_a.shape[0]
    MB = (Ms @ Phi_b.reshape(n, -1)).reshape(Phi_b.shape)
    return np.einsum("ikp,ikp->p", Phi_a, MB)
