"""`diff` of two body revisions (issue 27, item 6): the same model, a flipped or swapped mode, stale modes."""
from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import jsonschema
import numpy as np
import pytest
from typer.testing import CliRunner

from ffrf_advisor.analysis import Options
from ffrf_advisor.cli import app
from ffrf_advisor.fe.assembly import stiffness_matrix
from ffrf_advisor.fe_body import fe_body, with_centrifugal_response
from ffrf_advisor.guidelines import Situation
from ffrf_advisor.io import read_body, write_body
from ffrf_advisor.revision import diff
from ffrf_advisor.schemas import schema

BEAM = Path(__file__).resolve().parent.parent / "sample_bodies" / "beam.ffrf.h5"
OPTIONS = Options(situation=Situation(w_op=300.0))
TIGHT = 1e-6  # the shipped modes' Rayleigh quotients match their eigenvalues to 2e-9 (ARPACK); rebuilding a
# body recomputes its invariants and frame by nodal sums (round-off)
runner = CliRunner()


@pytest.fixture(scope="module")
def beam():
    return read_body(BEAM, load_fe=True)


def _rebuilt(body, Phi, eigenvalues, K=None):
    """The body from other modes on the same mesh (invariants, frame, static response and G recomputed)."""
    fe = body.fe
    return with_centrifugal_response(fe_body(body.name, fe.mesh, fe.Ms, Phi, eigenvalues, body.provenance, K,
                                             fe.stress_nodal, fe.material))


def test_a_body_against_itself_and_a_mode_sign_flipped_is_the_same_model(beam):
    assert diff(beam, beam, TIGHT, OPTIONS).same
    Phi = beam.fe.Phi.copy()
    Phi[:, :, 3] *= -1
    flipped = diff(beam, _rebuilt(beam, Phi, beam.eigenvalues), TIGHT, OPTIONS)
    assert flipped.same, [c for c in flipped.changes if c.exceeds]


def test_two_modes_swapped_in_order_are_paired_by_their_shapes(beam):
    order = list(range(beam.nf))
    order[3], order[4] = 4, 3
    d = diff(beam, beam.with_modes(order), TIGHT, OPTIONS)
    assert d.same and (3, 4) in [(a, b) for a, b, _ in d.pairs] and d.paired_by.startswith("MAC")


def test_a_stiffer_body_whose_modes_were_not_regenerated_is_found_stale(beam, tmp_path):
    """K scaled by 1.1 with the old modes and eigenvalues: the Rayleigh quotients are 1.1 lambda (a 10 %
    mismatch against the 1 % tolerance), exit 1 with a JUnit failure naming it."""
    K = stiffness_matrix(beam.fe.mesh, beam.fe.material) * 1.1
    stale = _rebuilt(beam, beam.fe.Phi, beam.eigenvalues, K)
    d = diff(beam, stale, 0.01, OPTIONS)
    found = {c.quantity: c for c in d.changes}
    assert found["stale modes (new)"].exceeds and found["stale modes (new)"].difference == pytest.approx(0.1,
                                                                                                        rel=1e-6)
    assert not found["stale modes (old)"].exceeds and not found["frequencies"].exceeds
    path = tmp_path / "stale.ffrf.h5"
    write_body(stale, path)  # since issue 49 every read checks the eigenvalues against a stored K
    result = runner.invoke(app, ["diff", str(BEAM), str(path), "--speed", "300rad/s"], env={"COLUMNS": "250"})
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1
    assert "eigenvalues" in result.output and "stored stiffness K" in result.output


def test_diff_json_follows_its_schema_and_a_changed_mass_is_named(beam, tmp_path):
    heavier = tmp_path / "heavier.ffrf.h5"
    fe = beam.fe
    write_body(with_centrifugal_response(fe_body(beam.name, fe.mesh, fe.Ms * 1.02, beam.fe.Phi / np.sqrt(1.02),
                                                 beam.eigenvalues, beam.provenance, None,
                                                 fe.stress_nodal / np.sqrt(1.02), fe.material)), heavier)
    result = runner.invoke(app, ["diff", str(BEAM), str(heavier), "--speed", "300rad/s", "--json"])
    data = json.loads(result.stdout)
    jsonschema.validate(data, schema("diff"))
    changed = {c["quantity"] for c in data["changes"] if c["exceeds"]}
    assert result.exit_code == 1 and "mass" in changed and "I0" in changed and not data["same"]
    same = runner.invoke(app, ["diff", str(BEAM), str(BEAM), "--speed", "300rad/s"])
    assert same.exit_code == 0 and "the same model" in same.stdout
