"""Checks of theory section 4: each fires with the expected value on a deliberately broken body."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from ffrf_advisor.body import ModalFE
from ffrf_advisor.checks import check_values, run_checks
from ffrf_advisor.invariants import shape_integrals


def _failed(body):
    return {c.name for c in run_checks(body) if not c.passed}


def _with_modes(body, Phi):
    fe = body.fe
    return replace(body, integrals=shape_integrals(fe.mesh.points, fe.Ms, Phi),
                   fe=ModalFE(fe.mesh, fe.Ms, Phi, fe.K))


def test_generated_bodies_pass_every_check(block_body, lshape_body):
    assert _failed(block_body) == set()
    assert _failed(lshape_body) == set()


def test_com_offset_is_measured(block_body):
    c = np.array([3.0, -4.0, 0.0])
    moved = replace(block_body, integrals=block_body.integrals.shifted(c))
    assert abs(check_values(moved)["com_offset"] - 5.0 / 300.0) < 1e-12
    # about the new origin the product of inertia -m c_x c_y appears as well
    assert _failed(moved) == {"com_offset", "principal_axes"}


def test_principal_axis_misalignment_is_measured(block_body):
    theta = 0.01
    R = np.array([[np.cos(theta), -np.sin(theta), 0], [np.sin(theta), np.cos(theta), 0], [0, 0, 1]])
    turned = replace(block_body, integrals=block_body.integrals.rotated(R))
    I0 = block_body.I0
    expected = abs(I0[0, 0] - I0[1, 1]) * np.sin(theta) * np.cos(theta) / np.trace(I0)
    assert abs(check_values(turned)["principal_axes"] / expected - 1) < 1e-8
    assert "principal_axes" in _failed(turned)


def test_unnormalised_modes_fail(block_body):
    bad = _with_modes(block_body, block_body.fe.Phi * 1.01)
    assert abs(check_values(bad)["mass_normalisation"] - (1.01**2 - 1)) < 1e-12
    assert "mass_normalisation" in _failed(bad)


def test_rigid_content_in_modes_fails_free_surface(block_body):
    Phi = np.array(block_body.fe.Phi)
    t = 1e-3
    Phi[:, 0, 2] += t  # a rigid translation mixed into mode 3
    bad = _with_modes(block_body, Phi)
    expected = t * block_body.mass / np.sqrt(block_body.mass)
    assert abs(check_values(bad)["free_surface_translation"] / expected - 1) < 1e-6
    Phi = np.array(block_body.fe.Phi)
    Phi[:, :, 1] += 1e-3 * np.cross([0, 0, 1.0], block_body.fe.mesh.points)  # a rigid rotation
    assert "free_surface_rotation" in _failed(_with_modes(block_body, Phi))


def test_eigenvalue_order_and_sign(block_body):
    lam = np.array(block_body.eigenvalues)
    lam[[0, 1]] = lam[[1, 0]]
    assert check_values(replace(block_body, eigenvalues=lam))["eigenvalue_order"] == 1
    lam = np.array(block_body.eigenvalues)
    lam[0] = -1.0
    assert "eigenvalue_order" in _failed(replace(block_body, eigenvalues=lam))
