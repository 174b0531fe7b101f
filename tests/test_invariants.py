"""Invariants against nodal sums on real meshes (theory section 3)."""
from __future__ import annotations

import pickle

import numpy as np
import pytest

from ffrf_advisor import invariants
from ffrf_advisor.invariants import EPS, I_TT, Qf, shape_integrals


def nodal_I_TT(fe, q):
    """sum m u~^T u~ with u = u0 + S q, evaluated directly on the nodes."""
    u = fe.mesh.points + fe.Phi @ q
    second = u.T @ (fe.Ms @ u)
    return np.trace(second) * np.eye(3) - second


def nodal_coupling(fe, q):
    """sum m u~ S (3 x nf) on the nodes."""
    u = fe.mesh.points + fe.Phi @ q
    n, _, nf = fe.Phi.shape
    MPhi = (fe.Ms @ fe.Phi.reshape(n, -1)).reshape(n, 3, nf)
    return np.einsum("klm,il,imp->kp", EPS, u, MPhi)


@pytest.mark.parametrize("fixture", ["block_body", "lshape_body"])
def test_deformed_inertia_and_coupling_equal_nodal_sums(fixture, request, rng):
    body = request.getfixturevalue(fixture)
    fe = body.fe
    for scale in (0.1, 1.0, 10.0):
        q = scale * rng.normal(size=body.nf)
        ref = nodal_I_TT(fe, q)
        assert np.abs(I_TT(body.integrals, q) - ref).max() < 1e-12 * np.abs(ref).max()
        C = nodal_coupling(fe, q)
        assert np.abs(Qf(q).T @ body.W3 - C).max() < 1e-9 * np.abs(C).max()


def test_W_matrices_match_the_printed_block_layout(lshape_body):
    """W1, W2, W3 written out block by block as in theory section 3 (G17)."""
    J = lshape_body.integrals
    Ib, S = J.Ibar, J.Sbar
    B = lambda k, l: Ib[k - 1, l - 1][None, :]  # noqa: E731
    W1 = np.block([[2 * (B(2, 2) + B(3, 3)), -(B(1, 2) + B(2, 1)), -(B(1, 3) + B(3, 1))],
                   [-(B(1, 2) + B(2, 1)), 2 * (B(1, 1) + B(3, 3)), -(B(2, 3) + B(3, 2))],
                   [-(B(1, 3) + B(3, 1)), -(B(2, 3) + B(3, 2)), 2 * (B(1, 1) + B(2, 2))]])
    s = lambda k, l: S[k - 1, l - 1]  # noqa: E731
    W2 = np.block([[s(2, 2) + s(3, 3), -s(2, 1), -s(3, 1)],
                   [-s(1, 2), s(1, 1) + s(3, 3), -s(3, 2)],
                   [-s(1, 3), -s(2, 3), s(1, 1) + s(2, 2)]])
    W3 = np.vstack([s(2, 3) - s(3, 2), s(3, 1) - s(1, 3), s(1, 2) - s(2, 1)])
    for got, want in ((J.W1(), W1), (J.W2(), W2), (J.W3(), W3)):
        assert got.shape == want.shape
        assert np.abs(got - want).max() <= 1e-14 * np.abs(want).max()


def test_W_matrices_are_made_once_and_read_only(lshape_body):
    """Each is computed once per integrals (significance asks for W2 once per mode) and cannot be written
    through: the one copy every caller shares."""
    J = lshape_body.integrals
    for W in (J.W1, J.W2, J.W3):
        assert W() is W()
        with pytest.raises(ValueError):
            W()[0, 0] = 1.0
    assert not {"_W1", "_W2", "_W3"} & set(vars(pickle.loads(pickle.dumps(J))))  # as a reading child sends it


def test_structure_and_cauchy_schwarz_bounds(lshape_body):
    J = lshape_body.integrals
    nf = J.nf
    W2, W3 = J.W2(), J.W3()
    assert np.abs(W2 - W2.T).max() < 1e-15
    for k in range(3):
        block = W3[k * nf:(k + 1) * nf]
        assert np.abs(block + block.T).max() < 1e-15
    assert np.abs(J.Sbar).max() <= 1 + 1e-12
    assert np.abs(W2).max() <= 2 + 1e-12 and np.abs(W3).max() <= 2 + 1e-12
    for k in range(3):
        for l in range(3):
            diag = np.diag(J.Sbar[l, l])
            assert np.all(J.Ibar[k, l] ** 2 <= J.I[k, k] * diag * (1 + 1e-12))


def test_free_surface_residuals_of_generated_modes(block_body, lshape_body):
    for body in (block_body, lshape_body):
        J = body.integrals
        assert np.abs(J.mode_sum).max() / np.sqrt(J.mass) < 1e-9
        scale = np.sqrt(np.diag(J.I0()))[:, None]
        assert (np.abs(J.mean_axis_residual()) / scale).max() < 1e-9


def test_shift_and_rotation_of_integrals_equal_recomputation(lshape_body, rng):
    fe, J = lshape_body.fe, lshape_body.integrals
    R, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    c = rng.normal(size=3) * 50
    direct = shape_integrals((fe.mesh.points - c) @ R, fe.Ms, np.einsum("ak,iap->ikp", R, fe.Phi))
    moved = J.shifted(c).rotated(R)
    for name in ("I", "Ibar", "Sbar", "first_moment"):
        a, b = getattr(direct, name), getattr(moved, name)
        assert np.abs(a - b).max() < 1e-12 * np.abs(a).max(), name
    assert np.abs(direct.mode_sum - moved.mode_sum).max() < 1e-12


def test_chunked_products_equal_one_product(block_body, monkeypatch):
    fe = block_body.fe
    whole = shape_integrals(fe.mesh.points, fe.Ms, fe.Phi)
    monkeypatch.setattr(invariants, "CHUNK_BYTES", 8 * 3 * block_body.nf * 37)  # 37-node blocks
    chunked = shape_integrals(fe.mesh.points, fe.Ms, fe.Phi)
    for name in ("I", "Ibar", "Sbar"):
        a, b = getattr(whole, name), getattr(chunked, name)
        assert np.abs(a - b).max() < 1e-13 * np.abs(a).max(), name


def test_body_is_immutable(block_body):
    with pytest.raises(ValueError):
        block_body.integrals.Sbar[0, 0, 0, 0] = 1.0
    with pytest.raises(ValueError):
        block_body.eigenvalues[0] = 1.0
    with pytest.raises(AttributeError):
        block_body.name = "x"
