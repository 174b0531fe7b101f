"""Centrifugal geometric stiffening (theory section 9, issue 13): G_kl from FE data, geo_stiff, s_crit."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla

from ffrf_advisor.centrifugal import static_centrifugal
from ffrf_advisor.analysis import Options, analyze
from ffrf_advisor.body import rotated_pairs
from ffrf_advisor.fe.assembly import full_mass, stiffness_matrix
from ffrf_advisor.fe_body import modal_body
from ffrf_advisor.fe.geometric import geometric_scalar
from ffrf_advisor.fe.material import STEEL
from ffrf_advisor.fe.mesh import box_mesh
from ffrf_advisor.fe.modal import rigid_modes
from ffrf_advisor.guidelines import Situation, softening_situations
from ffrf_advisor.io import read_body, write_body
from ffrf_advisor.response import geometric_matrix, softening_matrix
from ffrf_advisor.sim.model import build_model
from ffrf_advisor.significance import softening_speeds
from ffrf_advisor.verify.runner import run_scene
from ffrf_advisor.verify.scenes import SceneOptions, make_scene

DIR = Path(__file__).resolve().parent.parent / "sample_bodies"


@pytest.fixture(scope="module")
def bar():
    """A slender steel bar 400 x 12 x 8 mm along axis 3 (quadratic hexahedra), 16 free-free modes."""
    return modal_body(box_mesh((12.0, 8.0, 400.0), (2, 1, 40), "hexahedron20"), STEEL, 16, name="bar")


def _modal_frequencies(body, k: int, s: float, nf: int) -> np.ndarray:
    """sqrt of eig(Omega^2 - s^2 Kc + s^2 G) about principal axis k with the first nf modes (rotating frame)."""
    b = body.first_modes(nf)
    a = np.eye(3)[k]
    A = np.diag(b.eigenvalues) - s**2 * (softening_matrix(b, a) - geometric_matrix(b, a))
    return np.sqrt(np.sort(np.linalg.eigvalsh(A)))


def _mesh_frequencies(body, k: int, s: float, count: int) -> np.ndarray:
    """The same on all DOFs: K + s^2 (K_G(sigma_c) - kron(Ms, I - a a^T)), rigid motions held by a penalty."""
    fe, X = body.fe, body.fe.mesh.points
    _, U = static_centrifugal(fe, fe.material)
    Ks = geometric_scalar(fe.mesh, fe.material, U[:, k].reshape(-1, 3)).toarray()
    K = stiffness_matrix(fe.mesh, fe.material).toarray()
    Ms = fe.Ms.toarray()
    a = np.eye(3)[k]
    M = full_mass(fe.Ms).toarray()
    R = rigid_modes(X)
    MR = M @ R
    penalty = 1e3 * body.eigenvalues.max() * MR @ np.linalg.solve(R.T @ MR, MR.T)
    A = K + s**2 * (np.kron(Ks, np.eye(3)) - np.kron(Ms, np.eye(3) - np.outer(a, a))) + penalty
    lam = sla.eigh(A, M, eigvals_only=True, subset_by_index=[0, count - 1])
    return np.sqrt(lam)


@pytest.mark.slow  # seconds: kept out of the default run's 2-minute budget, run by CI
def test_modal_stiffening_converges_to_the_full_mesh_analysis_of_the_spinning_prestressed_body(bar):
    """Spin at 80 % of the unstiffened s_crit about a transverse axis: the lowest four frequencies of the modal
    equations approach the all-DOF ones as modes are added (measured: 4, 8, 16 modes)."""
    k = 0
    s = 0.8 * softening_speeds(bar)[k]
    exact = _mesh_frequencies(bar, k, s, 4)
    errors = [np.max(np.abs(_modal_frequencies(bar, k, s, nf)[:4] / exact - 1)) for nf in (4, 8, 16)]
    assert errors[0] >= errors[1] >= errors[2]
    assert errors[2] < 0.01, errors


@pytest.mark.slow  # seconds: kept out of the default run's 2-minute budget, run by CI
def test_southwell_out_of_plane_bending_rises_more_than_in_plane_with_the_full_mesh_coefficients(bar):
    """Spin about axis 1 (across the bar): bending along axis 1 (out of the plane of rotation) rises by
    s^2 G, bending along axis 2 (in the plane) by s^2 (G - 1); the coefficients (f(s)^2 - f0^2) / s^2 match the
    all-DOF analysis to 2 %."""
    k, s = 0, 0.5 * softening_speeds(bar)[0]
    f0, fs = _modal_frequencies(bar, k, 0.0, 16), _modal_frequencies(bar, k, s, 16)
    m0, ms = _mesh_frequencies(bar, k, 0.0, 2), _mesh_frequencies(bar, k, s, 2)
    modal = (fs[:2] ** 2 - f0[:2] ** 2) / s**2
    mesh = (ms**2 - m0**2) / s**2
    assert np.all(modal > 0) and modal.max() > modal.min() + 0.5  # both rise, by G and by G - 1
    assert np.allclose(np.sort(modal), np.sort(mesh), rtol=0.02)


def test_about_the_long_axis_G_is_small_and_s_crit_stays_the_whirling_speed(bar):
    """Axis 3 is the bar's long axis: its tension is tiny, so G barely touches the bending modes (the first
    eight; measured 0.2-2 % of Kc), while Kc softens them fully."""
    assert np.argmin(np.diag(bar.I0)) == 2
    a = np.eye(3)[2]
    G, Kc = np.diag(geometric_matrix(bar, a))[:8], np.diag(softening_matrix(bar, a))[:8]
    assert np.all(np.abs(G) < 0.03 * Kc) and np.all(Kc > 0.95)
    plain, stiff = softening_speeds(bar), softening_speeds(bar, stiffened=True)
    assert stiff[2] == pytest.approx(plain[2], rel=0.01)
    assert stiff[0] > 2 * plain[0]  # across the bar the stiffening wins


def test_spin_up_past_s_crit_diverges_with_cf2_alone_and_stays_bounded_with_geo_stiff(bar):
    """Prescribed spin-up about a transverse axis to 1.3 times the unstiffened s_crit (Kane, Ryan and Banerjee
    1987, free-body form)."""
    a = analyze(bar, Options(situation=Situation(w_op=0.0)))
    s = 1.3 * softening_speeds(bar)[0]
    scene = make_scene("spin-up", a, SceneOptions(speed=s, axis=1))
    soft = run_scene(build_model(bar, ("cf1", "cf2")), scene)
    stiff = run_scene(build_model(bar, ("cf1", "cf2", "geo_stiff")), scene)
    nf = bar.nf
    q = lambda run: np.abs(run.y[:, 7:7 + nf]).max()  # noqa: E731
    assert soft.failed or q(soft) > 1e3 * q(stiff)
    assert not stiff.failed and np.isfinite(q(stiff))


def test_geometric_stiffness_is_stored_sliced_and_turned_consistently(tmp_path, bar):
    path = tmp_path / "bar.ffrf.h5"
    write_body(bar, path, "ffrf-h5")
    back = read_body(path)
    assert np.array_equal(back.geometric, bar.geometric)
    cut = bar.first_modes(5)
    assert np.array_equal(cut.geometric, bar.geometric[:, :5, :5])
    R = sla.expm(np.array([[0, -0.3, 0.2], [0.3, 0, -0.1], [-0.2, 0.1, 0]]))
    w = np.array([0.3, -1.2, 0.7])
    turned = rotated_pairs(bar.geometric, R)
    G = lambda six, v: sum(v[k] * v[l] * (1 if k == l else 2) * g for (k, l), g in  # noqa: E731
                           zip(((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)), six))
    assert np.allclose(G(turned, R.T @ w), G(bar.geometric, w), rtol=1e-12, atol=1e-12 * np.abs(bar.geometric).max())


def test_the_advisor_decides_cf2_and_geo_stiff_together_and_names_the_situation():
    beam = read_body(DIR / "beam.ffrf.h5")
    assert beam.geometric is not None
    a = analyze(beam, Options(situation=Situation(w_op=400.0)))
    assert {"cf2", "geo_stiff"} <= set(a.advice.terms)
    sig = a.significance
    assert sig.s_crit_stiffened is not None and sig.s_crit_stiffened[0] > 2 * sig.s_crit[0]
    assert any("softening is real" in w or "stiffens it" in w for w in a.advice.warnings)
    across, _, along = softening_situations(a)
    assert "extends across" in across and "long along" in along  # axis 3 is the beam's long axis
