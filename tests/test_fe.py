"""The solid FE generator against analytic results."""
from __future__ import annotations

import numpy as np
import pytest

from ffrf_advisor.fe.assembly import mass_matrix, stiffness_matrix
from ffrf_advisor.fe.elements import ELEMENT_TYPES
from ffrf_advisor.fe.material import STEEL
from ffrf_advisor.fe.mesh import Box, box_mesh, box_union_mesh
from ffrf_advisor.fe.modal import free_free_modes
from ffrf_advisor.fe.split import box_split_mesh
from ffrf_advisor.fe.stress import modal_von_mises, von_mises
from ffrf_advisor.invariants import I0, shape_integrals

from .conftest import SLENDER

SIZE = (120.0, 50.0, 30.0)


def box_inertia(m, a, b, c):
    return m / 12 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])


@pytest.mark.parametrize("name", list(ELEMENT_TYPES))
def test_consistent_mass_and_I0_of_a_box_are_exact(name):
    mesh = box_split_mesh(SIZE, (4, 3, 2), name)
    Ms = mass_matrix(mesh, STEEL.rho)
    one = np.ones(mesh.n_nodes)
    m_exact = STEEL.rho * np.prod(SIZE)
    X = mesh.points
    assert abs(one @ Ms @ one / m_exact - 1) < 1e-10
    I_num = I0(X.T @ (Ms @ X))
    I_ref = box_inertia(m_exact, *SIZE)
    assert np.abs(I_num - I_ref).max() / np.abs(I_ref).max() < 1e-10


def test_rowsum_lumped_hex8_second_moments_follow_trapezoid_rule():
    """Documented I0 difference: sum m x_k^2 grows by 1 + 2/n_k^2 on a uniform hex8 mesh."""
    n = np.array([4, 3, 2])
    mesh = box_mesh(SIZE, n, "hexahedron")
    Ms = mass_matrix(mesh, STEEL.rho, lumping="rowsum")
    assert abs(Ms.sum() / (STEEL.rho * np.prod(SIZE)) - 1) < 1e-12
    X = mesh.points
    second = np.diag(X.T @ (Ms @ X))
    m = STEEL.rho * np.prod(SIZE)
    exact = m * np.asarray(SIZE) ** 2 / 12
    assert np.allclose(second / exact, 1 + 2 / n**2, rtol=1e-12)


def test_rowsum_lumped_hex27_is_simpson_and_exact():
    mesh = box_mesh(SIZE, (3, 2, 2), "hexahedron27")
    Ms = mass_matrix(mesh, STEEL.rho, lumping="rowsum")
    X = mesh.points
    m = STEEL.rho * np.prod(SIZE)
    assert np.abs(I0(X.T @ (Ms @ X)) - box_inertia(m, *SIZE)).max() < 1e-10 * box_inertia(m, *SIZE).max()


def test_rowsum_of_hex20_is_refused_and_hrz_keeps_mass():
    mesh = box_mesh(SIZE, (2, 2, 2), "hexahedron20")
    with pytest.raises(ValueError, match="hrz"):
        mass_matrix(mesh, STEEL.rho, lumping="rowsum")
    Ms = mass_matrix(mesh, STEEL.rho, lumping="hrz")
    assert np.all(Ms.diagonal() > 0)
    assert abs(Ms.sum() / (STEEL.rho * np.prod(SIZE)) - 1) < 1e-12


@pytest.mark.parametrize("name", list(ELEMENT_TYPES))
def test_stiffness_has_rigid_null_space_and_exact_uniform_strain_energy(name):
    mesh = box_split_mesh(SIZE, (3, 2, 2), name)
    K = stiffness_matrix(mesh, STEEL)
    X = mesh.points
    rot = np.cross([0.3, -0.2, 0.9], X) + [1.0, 2.0, 3.0]
    assert np.abs(K @ rot.ravel()).max() < 1e-10 * abs(K).max() * np.abs(rot).max()
    eps = 1e-4
    u = np.zeros_like(X)
    u[:, 1] = eps * X[:, 2]  # simple shear gamma_yz = eps
    energy = 0.5 * u.ravel() @ (K @ u.ravel())
    assert abs(energy / (0.5 * STEEL.G * eps**2 * np.prod(SIZE)) - 1) < 1e-10


def test_union_of_boxes_is_conforming_and_has_the_right_volume():
    boxes = [Box((0, 0, 0), (100, 20, 20)), Box((80, 20, 0), (100, 70, 20))]
    mesh = box_union_mesh(boxes, 10.0, "hexahedron27")
    Ms = mass_matrix(mesh, 1.0)
    assert abs(Ms.sum() - (100 * 20 * 20 + 20 * 50 * 20)) < 1e-8
    K = stiffness_matrix(mesh, STEEL)
    modes = free_free_modes(K, Ms, mesh.points, 3)  # a non-conforming mesh would show extra zero modes
    assert modes.eigenvalues[0] > 1.0


def test_disconnected_body_is_reported():
    boxes = [Box((0, 0, 0), (40, 20, 20)), Box((60, 0, 0), (100, 20, 20))]
    mesh = box_union_mesh(boxes, 20.0, "hexahedron")
    with pytest.raises(ValueError, match="six lowest modes to be rigid"):
        free_free_modes(stiffness_matrix(mesh, STEEL), mass_matrix(mesh, STEEL.rho), mesh.points, 4)


def _correlation(body, field):
    """|<field, phi_p>_M| / |field|_M for every mode (modes are M-normalised)."""
    fe = body.fe
    n = fe.mesh.n_nodes
    MPhi = (fe.Ms @ fe.Phi.reshape(n, -1)).reshape(fe.Phi.shape)
    return np.abs(np.einsum("ik,ikp->p", field, MPhi)) / np.sqrt(np.einsum("ik,ik", field, fe.Ms @ field))


def test_free_free_beam_against_beam_theory(slender_beam):
    L, a, b = SLENDER
    E, G, rho = STEEL.E, STEEL.G, STEEL.rho
    f = slender_beam.frequencies_hz
    X = slender_beam.fe.mesh.points
    frac = np.einsum("kkpp->kp", slender_beam.integrals.Sbar)  # share of each displacement component
    for axis, I_area in ((1, b * a**3 / 12), (2, a * b**3 / 12)):
        bending = f[frac[axis] > 0.9][:2]
        eb = np.array([4.7300, 7.8532]) ** 2 / (2 * np.pi) * np.sqrt(E * I_area / (rho * a * b * L**4))
        assert np.all(np.abs(bending / eb - 1) < 0.02), (axis, bending, eb)
    s = np.sin(np.pi * X[:, 0] / L)
    torsion_field = np.column_stack([0 * s, -X[:, 2] * s, X[:, 1] * s])
    axial_field = np.column_stack([s, 0 * s, 0 * s])
    n = np.arange(1, 400, 2)
    J = a * b**3 / 3 * (1 - 192 / np.pi**5 * b / a * np.sum(np.tanh(n * np.pi * a / (2 * b)) / n**5))
    Ip = (a * b**3 + a**3 * b) / 12
    f_torsion = np.sqrt(G * J / (rho * Ip)) / (2 * L)
    f_axial = np.sqrt(E / rho) / (2 * L)
    for field, analytic in ((torsion_field, f_torsion), (axial_field, f_axial)):
        p = int(np.argmax(_correlation(slender_beam, field)))
        assert _correlation(slender_beam, field)[p] > 0.95
        assert abs(f[p] / analytic - 1) < 0.03, (f[p], analytic)


def test_axial_mode_stress_matches_the_bar_solution(slender_beam):
    """Mass-normalised axial mode u = sqrt(2/(rho A L)) sin(pi x/L): max stress E sqrt(2/(rho A L)) pi/L."""
    L, a, b = SLENDER
    X = slender_beam.fe.mesh.points
    field = np.column_stack([np.sin(np.pi * X[:, 0] / L), 0 * X[:, 0], 0 * X[:, 0]])
    p = int(np.argmax(_correlation(slender_beam, field)))
    expected = STEEL.E * np.sqrt(2 / (STEEL.rho * a * b * L)) * np.pi / L
    assert abs(slender_beam.sigma_max[p] / expected - 1) < 0.02


def test_von_mises_of_known_tensors():
    s = np.zeros((3, 3, 3))
    s[0, 0, 0] = 100.0  # uniaxial
    s[1, 0, 1] = s[1, 1, 0] = 50.0  # pure shear
    s[2] = 30.0 * np.eye(3)  # hydrostatic
    assert np.allclose(von_mises(s), [100.0, 50.0 * np.sqrt(3), 0.0])


def test_modal_stress_of_a_rigid_motion_is_zero():
    mesh = box_mesh(SIZE, (3, 2, 2), "hexahedron20")
    rigid = np.cross([0.1, 0.4, -0.3], mesh.points)[:, :, None] + np.array([1.0, 0, 0])[None, :, None]
    assert modal_von_mises(mesh, STEEL, rigid).max() < 1e-9


def test_modes_are_mass_normalised_and_deterministic():
    mesh = box_mesh(SIZE, (3, 2, 2), "hexahedron27")
    Ms, K = mass_matrix(mesh, STEEL.rho), stiffness_matrix(mesh, STEEL)
    a, b = free_free_modes(K, Ms, mesh.points, 5), free_free_modes(K, Ms, mesh.points, 5)
    assert np.array_equal(a.Phi, b.Phi)
    J = shape_integrals(mesh.points, Ms, a.Phi)
    assert np.abs(np.einsum("kkpr->pr", J.Sbar) - np.eye(5)).max() < 1e-12
    assert np.all(np.abs(a.rigid_eigenvalues) < 1e-6 * a.eigenvalues[0])
