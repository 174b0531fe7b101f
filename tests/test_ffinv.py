"""Adams-style invariants: the I1..I9 mapping against brute-force nodal sums, and the .ffinv files."""
from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from scipy.linalg import expm
from typer.testing import CliRunner

from ffrf_advisor.adams import from_adams, to_adams, w3_from_I9
from ffrf_advisor.analysis import Options, analyze
from ffrf_advisor.cli import app
from ffrf_advisor.errors import BodyFileError
from ffrf_advisor.fe_body import modal_body
from ffrf_advisor.fe.material import STEEL
from ffrf_advisor.fe.mesh import Box, box_union_mesh
from ffrf_advisor.guidelines import Situation
from ffrf_advisor.io import read_body, write_body
from ffrf_advisor.io.ffinv import _jsonable, document

runner = CliRunner()


def _skew(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


@pytest.fixture(scope="module")
def lumped_body():
    """A lumped-mass (HRZ) asymmetric body: Adams' own nodal-sum setting."""
    boxes = [Box((0, 0, 0), (200, 40, 30)), Box((0, 40, 0), (40, 160, 30)), Box((160, 0, 30), (200, 40, 90))]
    return modal_body(box_union_mesh(boxes, 40.0, "hexahedron20"), STEEL, 4, lumping="hrz")


def test_invariants_equal_their_definitions_as_nodal_sums(lumped_body):
    fe = lumped_body.fe
    m, X, Phi = fe.Ms.diagonal(), fe.mesh.points, fe.Phi
    nf = Phi.shape[2]
    inv = to_adams(lumped_body.integrals)
    I7 = sum(m[p] * _skew(X[p]).T @ _skew(X[p]) for p in range(len(m)))
    I8 = np.array([sum(m[p] * _skew(X[p]) @ _skew(Phi[p, :, j]) for p in range(len(m))) for j in range(nf)])
    I9 = np.array([[sum(m[p] * _skew(Phi[p, :, i]) @ _skew(Phi[p, :, j]) for p in range(len(m)))
                    for j in range(nf)] for i in range(nf)])
    I5 = np.array([np.array([sum(m[p] * np.cross(Phi[p, :, j], Phi[p, :, i]) for p in range(len(m)))
                             for i in range(nf)]).T for j in range(nf)])
    assert np.abs(inv["I7"] - I7).max() < 1e-12 * np.abs(I7).max()
    assert np.abs(inv["I8"] - I8).max() < 1e-12 * np.abs(I8).max()
    assert np.abs(inv["I9"] - I9).max() < 1e-12
    assert np.abs(inv["I5"] - I5).max() < 1e-12
    assert np.abs(inv["I6"] - np.eye(nf)).max() < 1e-12
    assert np.abs(w3_from_I9(I9).reshape(3 * nf, nf) - lumped_body.W3).max() < 1e-12


def test_mapping_back_gives_the_papers_matrices_in_both_I8_signs(lumped_body):
    nf = lumped_body.nf
    for sign in ("adams", "mbdyn"):
        J = from_adams(to_adams(lumped_body.integrals, sign), nf, sign)
        for name in ("I0", "W1", "W2", "W3"):
            ref = getattr(lumped_body.integrals, name)()
            assert np.abs(getattr(J, name)() - ref).max() <= 1e-13 * np.abs(ref).max(), (sign, name)


@pytest.fixture(scope="module")
def beam(request):
    from pathlib import Path
    return read_body(Path(__file__).resolve().parent.parent / "sample_bodies" / "beam.ffrf.h5", load_fe=True)


def _same_body_and_advice(a, b):
    for name in ("I0", "W1", "W2", "W3"):
        ref = getattr(b, name)
        assert np.abs(getattr(a, name) - ref).max() <= 1e-12 * np.abs(ref).max(), name
    assert np.abs(a.eigenvalues / b.eigenvalues - 1).max() < 1e-12
    opts = Options(situation=Situation(w_op=300.0, rules="thresholds"))
    ra, rb = analyze(a, opts), analyze(b, opts)
    # an invariants file carries no geometric stiffness (theory 9): the same advice but for geo_stiff
    assert a.geometric is None and "geo_stiff" in rb.advice.terms
    assert ra.advice.level == rb.advice.level
    assert ra.advice.terms == tuple(t for t in rb.advice.terms if t != "geo_stiff")
    assert np.abs(ra.significance.dI_Q - rb.significance.dI_Q).max() < 1e-12


@pytest.mark.parametrize("suffix", [".ffinv.json", ".ffinv.h5"])
@pytest.mark.parametrize("sign", ["adams", "mbdyn"])
def test_fe_body_to_invariants_file_and_back(tmp_path, beam, suffix, sign):
    path = tmp_path / f"beam{suffix}"
    write_body(beam, path, I8_sign=sign)
    back = read_body(path)
    _same_body_and_advice(back, beam)
    assert back.provenance.mass_matrix == "consistent"
    assert np.array_equal(back.sigma_max, beam.sigma_max)


def _write(path, doc):
    path.write_text(json.dumps(_jsonable(doc)))
    return path


def test_file_in_another_frame_is_transformed_and_says_so(tmp_path, beam):
    c = np.array([120.0, -40.0, 75.0])
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    Q = expm(0.4 * _skew(axis))  # a CAD frame near the principal one: axis labels are kept
    moved = replace(beam, integrals=beam.integrals.shifted(-c).rotated(Q), fe=None)
    doc = document(moved)
    doc["frame"] = {"origin": "lbrf", "axes": "lbrf"}
    back = read_body(_write(tmp_path / "moved.ffinv.json", doc))
    _same_body_and_advice(back, beam)
    assert any("transformed from the file's frame" in n for n in back.provenance.notes)


def test_without_I9_the_quadratic_and_coupling_measures_are_not_evaluable(tmp_path, beam):
    doc = document(beam)
    del doc["I9"], doc["I5"]
    body = read_body(_write(tmp_path / "partial.ffinv.json", doc))
    assert body.W2 is None and body.W3 is None
    result = analyze(body, Options(situation=Situation(w_op=300.0, rules="thresholds")))
    sig = result.significance
    assert set(sig.not_evaluable) == {"dI_Q", "dI_fT", "dI_Tf", "coriolis_ratio", "centrifugal_ratio", "s_crit"}
    assert np.abs(sig.dI_L - analyze(beam).significance.dI_L).max() < 1e-12
    dI_Q = next(r for r in result.advice.rules if r.name == "dI_Q")
    assert dI_Q.fired is None and "not evaluable" in dI_Q.reason
    assert any("decided without dI_Q" in w for w in result.advice.warnings)
    cli = runner.invoke(app, ["analyze", str(tmp_path / "partial.ffinv.json"), "--speed", "300"],
                        env={"COLUMNS": "200"})
    assert cli.exit_code == 0 and "not evaluable" in cli.output


def test_with_I5_but_without_I9_coupling_is_evaluable(tmp_path, beam):
    doc = document(beam)
    del doc["I9"]
    body = read_body(_write(tmp_path / "i5.ffinv.json", doc))
    assert body.W2 is None and np.abs(body.W3 - beam.W3).max() <= 1e-12 * np.abs(beam.W3).max()
    sig = analyze(body).significance
    assert sig.dI_fT is not None and sig.dI_Q is None


def _broken(doc, key, value):
    doc = dict(doc)
    if value is KeyError:
        del doc[key]
    else:
        doc[key] = value
    return doc


@pytest.mark.parametrize("key, mutate, expected", [
    ("I8", lambda d: d["I8"][:, :2, :], "shape"),
    ("I7", KeyError, "required key"),
    ("I7", lambda d: d["I7"] + np.triu(np.ones((3, 3)), 1) * d["I7"].max(), "symmetric"),
    ("I6", lambda d: d["I6"] * 1.2, "identity"),
    ("I8", lambda d: np.where(np.arange(3)[None, :, None] == 1, np.nan, d["I8"]), "finite"),
    ("I9", lambda d: np.swapaxes(d["I9"], 2, 3) * -1, "I9"),
    ("eigenvalues", lambda d: -d["eigenvalues"], "positive"),
    ("n_modes", lambda d: "four", "positive integer"),
])
def test_broken_files_give_one_line_errors_naming_the_key(tmp_path, beam, key, mutate, expected):
    doc = document(beam)
    value = mutate if mutate is KeyError else mutate(doc)
    path = _write(tmp_path / "broken.ffinv.json", _broken(doc, key, value))
    with pytest.raises(BodyFileError, match=expected) as info:
        read_body(path)
    assert key in str(info.value)
    cli = runner.invoke(app, ["info", str(path)])
    assert cli.exit_code == 2 and key in cli.output and len(cli.output.strip().splitlines()) == 1


def test_gate_shows_that_a_pass_was_decided_without_measures(tmp_path, beam):
    """An invariants file without I9 and I5 passes --max-level II, and its text and JUnit say why it may be
    too low (issue 12)."""
    import xml.etree.ElementTree as ET
    doc = document(beam)
    del doc["I9"], doc["I5"]
    partial = _write(tmp_path / "partial.ffinv.json", doc)
    junit = tmp_path / "gate.xml"
    result = runner.invoke(app, ["gate", str(partial), "--max-level", "II", "--speed", "0", "--junit", str(junit)],
                           env={"COLUMNS": "200"})
    assert result.exit_code == 0 and "ok" in result.output
    assert "warning: decided without dI_Q" in result.output
    case = next(ET.parse(junit).getroot().iter("testcase"))
    assert case.find("failure") is None and "decided without dI_Q" in case.find("system-out").text


def test_duplicate_keys_and_a_boolean_version_are_refused(tmp_path, beam):
    doc = document(beam)
    path = _write(tmp_path / "dup.ffinv.json", doc)
    text = path.read_text()
    path.write_text(text.replace('"n_modes"', '"n_modes": 3, "n_modes"', 1))
    with pytest.raises(BodyFileError, match="duplicate key 'n_modes'"):
        read_body(path)
    doc["version"] = True
    with pytest.raises(BodyFileError, match="version"):
        read_body(_write(tmp_path / "bool.ffinv.json", doc))


def test_directories_and_fifos_are_not_bodies(tmp_path):
    import os
    folder = tmp_path / "dir.ffinv.json"
    folder.mkdir()
    fifo = tmp_path / "fifo.ffinv.json"
    os.mkfifo(fifo)
    for path, kind in ((folder, "a directory"), (fifo, "special file")):
        result = runner.invoke(app, ["info", str(path)])
        assert result.exit_code == 2 and kind in result.output and len(result.output.strip().splitlines()) == 1


@pytest.mark.parametrize("suffix", [".ffinv.json", ".ffinv.h5"])
def test_convert_keeps_the_body_name(tmp_path, beam, suffix):
    path = tmp_path / f"renamed{suffix}"
    write_body(beam, path)
    assert read_body(path).name == "beam"
