"""Nodes that carry rotary inertia (theory 3b): I0, modal mass, mean-axis residual, storage, Adams export."""
from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
import scipy.sparse as sp

from ffrf_advisor.adams import to_adams
from ffrf_advisor.centrifugal import static_centrifugal
from ffrf_advisor.body import FlexibleBody, ModalFE, NodalRotary, Provenance
from ffrf_advisor.checks import check_values
from ffrf_advisor.errors import FFRFError
from ffrf_advisor.fe.material import STEEL
from ffrf_advisor.fe.mesh import Mesh
from ffrf_advisor.io import read_body, write_body

M, A, JX, JY, JZ = 2.0e-3, 50.0, 0.7, 0.3, 0.4  # t, mm, t mm^2: a dumbbell of two point masses on the x axis
LAM = np.array([1.0e4, 4.0e4])


def dumbbell(rotary: bool = True) -> FlexibleBody:
    """Masses m at x = -a, +a with rotary inertia diag(JX, JY, JZ) each. Mode 1: torsion about x (rotations
    only: its modal mass is all rotary); mode 2: bending in y, translations +-b and rotations about z."""
    X = np.array([[-A, 0.0, 0.0], [A, 0.0, 0.0]])
    J = np.stack([np.diag([JX, JY, JZ])] * 2)
    c = 1 / np.sqrt(2 * JX)  # 2 JX c^2 = 1
    t, r = 1.0, 1.0 / A  # bending: u_y = +-t b, rotation about z = r b
    b = 1 / np.sqrt(2 * M * t**2 + 2 * JZ * r**2)
    Phi = np.zeros((2, 3, 2))
    Phi[:, 1, 1] = [-t * b, t * b]
    Phi_rot = np.zeros((2, 3, 2))
    Phi_rot[:, 0, 0] = c
    Phi_rot[:, 2, 1] = r * b
    fe = ModalFE(Mesh(X, {}), sp.csr_array(np.diag([M, M])), Phi,
                 rotary=NodalRotary(np.array([0, 1]), J, Phi_rot) if rotary else None)
    return FlexibleBody(name="dumbbell", integrals=fe.integrals(), eigenvalues=LAM,
                        provenance=Provenance(source="test"), fe=fe)


def test_I0_and_the_modal_mass_are_the_analytic_ones_and_the_rotary_part_is_what_dropping_it_loses():
    body, bare = dumbbell(), dumbbell(rotary=False)
    assert np.allclose(body.I0, np.diag([2 * JX, 2 * M * A**2 + 2 * JY, 2 * M * A**2 + 2 * JZ]), rtol=1e-14)
    assert np.allclose(body.I0 - bare.I0, 2 * np.diag([JX, JY, JZ]), rtol=1e-14)
    assert np.allclose(body.integrals.modal_mass(), np.eye(2), atol=1e-14)
    lost = 1 - np.diag(bare.integrals.modal_mass())  # share of each mode's modal mass that is rotary
    b2 = 1 / (2 * M + 2 * JZ / A**2)
    assert lost[0] == pytest.approx(1.0) and lost[1] == pytest.approx(2 * JZ / A**2 * b2, rel=1e-12)
    assert check_values(body)["mass_normalisation"] < 1e-14
    assert check_values(bare)["mass_normalisation"] == pytest.approx(1.0)  # the torsion mode has no mass left


def test_the_mean_axis_residual_counts_the_rotary_part():
    # bending about z: sum m u0~ S = 2 m a t b along z; sum J Phi* = 2 JZ r b along z
    body = dumbbell()
    b = 1 / np.sqrt(2 * M + 2 * JZ / A**2)
    assert body.integrals.mean_axis_residual()[2, 1] == pytest.approx(2 * M * A * b + 2 * JZ * b / A, rel=1e-12)
    assert body.integrals.rotary.mean_axis[2, 1] == pytest.approx(2 * JZ * b / A, rel=1e-12)


def test_a_turned_frame_turns_the_rotary_inertia_with_it():
    body = dumbbell()
    R = np.linalg.qr(np.random.default_rng(3).normal(size=(3, 3)))[0]
    R *= np.sign(np.linalg.det(R))
    turned = replace(body, fe=body.fe.transformed(np.zeros(3), R))
    turned = replace(turned, integrals=turned.fe.integrals())
    assert np.allclose(turned.I0, R.T @ body.I0 @ R, atol=1e-12 * np.abs(body.I0).max())
    assert np.allclose(turned.integrals.modal_mass(), np.eye(2), atol=1e-13)
    assert np.allclose(turned.integrals.I0(), body.integrals.rotated(R).I0(), atol=1e-12)


@pytest.mark.parametrize("suffix", [".ffrf.h5", ".ffinv.json", ".ffinv.h5"])
def test_files_keep_the_rotary_parts_and_the_invariants_export_them(tmp_path, suffix):
    body = dumbbell()
    path = tmp_path / f"d{suffix}"
    write_body(body, path)
    back = read_body(path, load_fe=True)
    assert np.allclose(back.I0, body.I0, rtol=1e-13)
    assert np.allclose(back.integrals.modal_mass(), np.eye(2), atol=1e-13)
    assert np.allclose(back.integrals.mean_axis_residual(), body.integrals.mean_axis_residual(), atol=1e-13)
    inv = to_adams(body.integrals)
    assert np.allclose(inv["I7"], body.I0) and np.allclose(inv["I6"], np.eye(2))
    assert np.allclose(inv["nodal_rotary_inertia_sum"], 2 * np.diag([JX, JY, JZ]))
    if suffix == ".ffrf.h5":
        assert back.fe.rotary is not None and np.array_equal(back.fe.rotary.J, body.fe.rotary.J)
        assert np.array_equal(read_body(path).integrals.rotary.J, body.integrals.rotary.J)  # the cached sums
    if suffix == ".ffinv.json":
        doc = json.loads(path.read_text())
        assert np.allclose(np.array(doc["I6"]) + 0.5 * np.einsum("ijkk->ij", np.array(doc["I9"])),
                           np.array(doc["rotary_I6"]))


def test_sorting_modes_keeps_each_mode_with_its_rotations():
    body = dumbbell()
    swapped = body.with_modes([1, 0])
    assert np.allclose(swapped.integrals.modal_mass(), np.eye(2), atol=1e-14)
    assert np.array_equal(swapped.fe.rotary.Phi[:, :, 0], body.fe.rotary.Phi[:, :, 1])


def test_the_static_centrifugal_response_refuses_rotary_nodes_by_name():
    body = dumbbell()
    with pytest.raises(FFRFError, match="2 nodes with rotary inertia"):
        static_centrifugal(body.fe, STEEL)
