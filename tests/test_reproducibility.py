"""Regenerated bodies equal the shipped ones to the accuracy of their eigenpairs, whatever the mode signs (issue 9)."""
from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from ffrf_advisor.equivalence import compare_modal_bodies
from ffrf_advisor.fe_body import fe_body, modal_body
from ffrf_advisor.fe.material import STEEL
from ffrf_advisor.fe.mesh import Mesh, box_mesh
from ffrf_advisor.fe.stress import modal_von_mises
from ffrf_advisor.io import read_body
from ffrf_advisor.samples import N_MODES, SAMPLES, beam_mesh, sample

DIR = Path(__file__).resolve().parent.parent / "sample_bodies"


@pytest.fixture(scope="module")
def beam():
    """(shipped beam, regenerated beam with K)."""
    return read_body(DIR / "beam.ffrf.h5", load_fe=True), sample("beam", keep_stiffness=True)


def _with_modes(body, Phi, stress=None):
    """The body of ``body``'s mesh and eigenvalues with other modes: integrals again by nodal sums."""
    fe = body.fe
    return fe_body(body.name, fe.mesh, fe.Ms, Phi, body.eigenvalues, body.provenance, fe.K,
                   fe.stress_nodal if stress is None else stress)


def _failed(comparison) -> set[str]:
    return {f.quantity for f in comparison.failed()}


def test_regenerated_beam_equals_the_shipped_one(beam):
    shipped, made = beam
    result = compare_modal_bodies(made, shipped, made.fe.K)
    assert result.ok, result.summary()


@pytest.mark.slow
@pytest.mark.parametrize("name", [n for n in SAMPLES if n != "beam"])
def test_regenerating_reproduces_the_shipped_body(name):
    made = sample(name, keep_stiffness=True)
    result = compare_modal_bodies(made, read_body(DIR / f"{name}.ffrf.h5", load_fe=True), made.fe.K)
    assert result.ok, result.summary()


@pytest.mark.parametrize("mode", range(N_MODES))
def test_flipping_the_sign_of_any_mode_passes(beam, mode):
    shipped, made = beam
    Phi = np.array(shipped.fe.Phi)
    Phi[:, :, mode] *= -1
    flipped = _with_modes(shipped, Phi)
    assert np.abs(flipped.integrals.Ibar[:, :, mode] + shipped.integrals.Ibar[:, :, mode]).max() < 1e-12
    result = compare_modal_bodies(flipped, shipped, made.fe.K)
    assert result.ok, result.summary()


def test_perturbing_the_mesh_by_a_thousandth_fails(beam):
    shipped, reference = beam
    mesh = beam_mesh()
    stretched = Mesh(mesh.points * np.array([1.0, 1.0, 1.001]), dict(mesh.cells))
    made = modal_body(stretched, STEEL, N_MODES, name="beam")
    result = compare_modal_bodies(made, shipped, reference.fe.K)
    assert {"eigenvalues / accuracy", "points / L"} <= _failed(result)


def test_a_stiffer_material_on_the_same_mesh_fails(beam):
    shipped, reference = beam
    stiffer = modal_body(beam_mesh(), replace(STEEL, E=STEEL.E * 1.001), N_MODES, name="beam")
    assert _failed(compare_modal_bodies(stiffer, shipped, reference.fe.K)) == {"eigenvalues / accuracy"}


def test_dropping_a_mode_fails(beam):
    shipped, made = beam
    fe = shipped.fe
    fewer = fe_body("beam", fe.mesh, fe.Ms, fe.Phi[:, :, 1:], shipped.eigenvalues[1:], shipped.provenance)
    assert not compare_modal_bodies(fewer, shipped, made.fe.K).ok


def test_mixing_two_modes_of_different_frequency_fails(beam):
    shipped, made = beam
    c, s = np.cos(0.3), np.sin(0.3)
    Phi = np.array(shipped.fe.Phi)
    Phi[:, :, [0, 1]] = Phi[:, :, [0, 1]] @ np.array([[c, -s], [s, c]])
    mixed = _with_modes(shipped, Phi, modal_von_mises(shipped.fe.mesh, STEEL, Phi))
    assert "residual / eigenpair limit" in _failed(compare_modal_bodies(mixed, shipped, made.fe.K))


def test_rotating_a_degenerate_pair_passes_and_a_split_pair_does_not():
    """A square bar bends alike in its two planes: each bending pair is exactly degenerate."""
    body = modal_body(box_mesh([20.0, 20.0, 400.0], [1, 1, 16], "hexahedron20"), STEEL, 6, name="square")
    pairs = np.flatnonzero(np.diff(body.eigenvalues) < 1e-6 * body.eigenvalues[1:])
    assert len(pairs) >= 2
    p = int(pairs[0])
    c, s = np.cos(0.5), np.sin(0.5)
    Phi = np.array(body.fe.Phi)
    Phi[:, :, [p, p + 1]] = Phi[:, :, [p, p + 1]] @ np.array([[c, -s], [s, c]])
    turned = _with_modes(body, Phi, modal_von_mises(body.fe.mesh, STEEL, Phi))
    result = compare_modal_bodies(turned, body, body.fe.K)
    assert result.ok and (p, p + 1) in result.clusters, result.summary()
    # the same turn of modes p+1, p+2, whose eigenvalues differ, is no eigen-solution any more
    Phi = np.array(body.fe.Phi)
    Phi[:, :, [p + 1, p + 2]] = Phi[:, :, [p + 1, p + 2]] @ np.array([[c, -s], [s, c]])
    split = _with_modes(body, Phi, modal_von_mises(body.fe.mesh, STEEL, Phi))
    assert not compare_modal_bodies(split, body, body.fe.K).ok


def test_sign_rule_does_not_tie_on_a_symmetric_body():
    """On a doubly symmetric block "largest entry positive" ties (entries of opposite sign, equal size,
    at mirror nodes), while the reference field decides every mode by a clear margin."""
    from ffrf_advisor.fe.assembly import full_mass
    from ffrf_advisor.fe.modal import SIGN_FIELDS, SIGN_MIN
    body = modal_body(box_mesh([200.0, 60.0, 40.0], [6, 2, 2], "hexahedron20"), STEEL, 10, name="block")
    X, M, S = body.fe.mesh.points, full_mass(body.fe.Ms), body.fe.Phi.reshape(-1, body.nf)
    top = np.sort(np.abs(S), axis=0)[::-1]
    assert np.any(np.abs(top[0] - top[1]) < 1e-9 * top[0])  # a tie for the old rule
    xi = (X - X.mean(axis=0)) / np.ptp(X, axis=0).max()
    a, b = SIGN_FIELDS[0]
    g = np.cos(2 * np.pi * xi @ a.T + b).reshape(-1)
    c = (M @ g) @ S / np.sqrt(g @ (M @ g))
    assert np.all(c > 1e3 * SIGN_MIN)


@pytest.mark.parametrize("threads", ["1", pytest.param("2", marks=pytest.mark.slow)])  # CI runs both
def test_regeneration_passes_with_one_and_two_blas_threads(threads, tmp_path):
    out = tmp_path / "beam.ffrf.h5"
    env = {**os.environ, "OPENBLAS_NUM_THREADS": threads, "OMP_NUM_THREADS": threads}
    subprocess.run([sys.executable, "-m", "ffrf_advisor", "sample", "beam", "-o", str(out)], env=env, check=True,
                   capture_output=True)
    made = read_body(out, load_fe=True)
    result = compare_modal_bodies(made, read_body(DIR / "beam.ffrf.h5", load_fe=True),
                                  sample("beam", keep_stiffness=True).fe.K)
    assert result.ok, result.summary()
