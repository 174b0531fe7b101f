"""meshio meshes with mode fields, `convert` between every format, and `settings --solver adams`."""
from __future__ import annotations

import json
from pathlib import Path

import meshio
import numpy as np
import pytest
import scipy.sparse as sp
from typer.testing import CliRunner

from ffrf_advisor.cli import app
from ffrf_advisor.errors import BodyFileError
from ffrf_advisor.fe.material import STEEL
from ffrf_advisor.io import read_body

SAMPLES = Path(__file__).resolve().parent.parent / "sample_bodies"
runner = CliRunner()


@pytest.fixture(scope="module")
def beam():
    return read_body(SAMPLES / "beam.ffrf.h5", load_fe=True)


def _mesh_file(path: Path, body, extra_cells=(), stress=True, scale=None) -> Path:
    """The body's mesh and modes as a meshio file: modes scaled by ``scale`` (not mass-normalised), moved."""
    fe, nf = body.fe, body.nf
    scale = np.arange(3.0, 3.0 + nf) if scale is None else scale
    point_data = {f"mode_{p + 1}": fe.Phi[:, :, p] * scale[p] for p in range(nf)}
    if stress:
        point_data.update({f"von_mises_{p + 1}": fe.stress_nodal[:, p] * scale[p] for p in range(nf)})
    cells = [(t, c) for t, c in fe.mesh.cells.items()] + list(extra_cells)
    meshio.write(path, meshio.Mesh(fe.mesh.points + [10.0, 20.0, 30.0], cells, point_data=point_data))
    return path


@pytest.mark.parametrize("suffix", [".vtu", ".xdmf", ".vtk"])
def test_meshio_mesh_with_modes_gives_the_same_body(tmp_path, beam, suffix):
    quads = [] if suffix == ".xdmf" else [("quad", np.array([[0, 1, 2, 3]]))]  # a face: no mass, named
    path = _mesh_file(tmp_path / f"beam{suffix}", beam, extra_cells=quads)
    body = read_body(path, eigenvalues=beam.eigenvalues, density=STEEL.rho)
    assert bool(quads) == ("cells without mass of their own: 1 quad" in " ".join(body.provenance.notes))
    for name in ("I0", "W1", "W2", "W3"):
        ref = getattr(beam, name)
        assert np.abs(getattr(body, name) - ref).max() <= 1e-12 * np.abs(ref).max(), name
    assert np.abs(body.sigma_max / beam.sigma_max - 1).max() < 1e-12  # stress rescaled with the modes


def test_meshio_errors_name_the_field(tmp_path, beam):
    path = _mesh_file(tmp_path / "beam.vtu", beam)
    with pytest.raises(BodyFileError, match="field_data/eigenvalues"):
        read_body(path, density=STEEL.rho)
    with pytest.raises(BodyFileError, match="eigenvalues: expected 16 finite"):
        read_body(path, eigenvalues=[1.0, 2.0], density=STEEL.rho)
    wedge = meshio.Mesh(np.random.default_rng(1).random((18, 3)), [("wedge18", np.arange(18)[None])],
                        point_data={"mode_1": np.ones((18, 3))})
    meshio.write(tmp_path / "wedge.vtu", wedge)
    with pytest.raises(BodyFileError, match="cells/wedge18: expected cell types the reader carries .*got wedge18"):
        read_body(tmp_path / "wedge.vtu", eigenvalues=[1.0], density=1.0)
    tet = meshio.Mesh(np.eye(4, 3), [("tetra", np.array([[0, 1, 2, 3]]))], point_data={"mode_1": np.ones((4, 3))})
    meshio.write(tmp_path / "tet.vtu", tet)  # its nodes in the wrong order: det J < 0
    with pytest.raises(BodyFileError, match=r"cells: expected solid cells of positive volume .*element 0 \(tetra\)"):
        read_body(tmp_path / "tet.vtu", eigenvalues=[1.0], density=1.0)


def test_info_and_convert_take_eigenvalues_and_density_for_meshes(tmp_path, beam):
    path = _mesh_file(tmp_path / "beam.vtu", beam)
    lam = tmp_path / "eigenvalues.txt"
    lam.write_text("\n".join(repr(float(x)) for x in beam.eigenvalues))
    opts = ["--eigenvalues", str(lam), "--density", repr(STEEL.rho)]
    assert runner.invoke(app, ["info", str(path), *opts]).exit_code == 0
    out = tmp_path / "beam.ffrf.h5"
    result = runner.invoke(app, ["convert", str(path), str(out), *opts])
    assert result.exit_code == 0, result.output
    assert np.abs(read_body(out).W2 - beam.W2).max() < 1e-12
    wrong = runner.invoke(app, ["info", str(SAMPLES / "beam.ffrf.h5"), "--density", "1"])
    assert wrong.exit_code == 2 and "meshio meshes only" in wrong.output
    wrong = runner.invoke(app, ["analyze", str(SAMPLES / "beam.ffrf.h5"), "--units", "SI"])
    assert wrong.exit_code == 2 and "--units apply to ANSYS results (.rst) only" in wrong.output
    simulated = runner.invoke(app, ["simulate", str(path), *opts, "--t-end", "1e-4", "--json"])
    assert simulated.exit_code == 0, simulated.output  # issue 23, item 12: simulate and verify take them too
    assert runner.invoke(app, ["simulate", str(path), "--t-end", "1e-4"]).exit_code == 2


def test_a_density_in_the_wrong_unit_is_named(tmp_path, beam):
    """Issue 25: --density 7850 (kg/m^3) for a t-mm mesh makes the body 10^12 too heavy; info and analyze name
    the likely mix-up, the right density gives no such warning, and the units assumed are stated."""
    path = _mesh_file(tmp_path / "beam.vtu", beam)
    lam = ",".join(repr(float(x)) for x in beam.eigenvalues)
    for density, wrong in (("7850", True), (repr(STEEL.rho), False)):
        got = json.loads(runner.invoke(app, ["info", str(path), "--eigenvalues", lam, "--density", density,
                                             "--json"]).stdout)
        named = [w for w in got["warnings"] if w.startswith("implausible density")]
        assert bool(named) is wrong and all("a density in kg/m^3 read as t/mm^3?" in w for w in named)
    text = runner.invoke(app, ["info", str(path), "--eigenvalues", lam, "--density", "7850"], env={"COLUMNS": "300"})
    assert "units t-mm-N-s assumed (a meshio file states none)" in text.stdout and "a density in kg/m^3" in text.stdout
    analysed = json.loads(runner.invoke(app, ["analyze", str(path), "--eigenvalues", lam, "--density", "7850",
                                              "--speed", "1rad/s", "--json"]).stdout)
    assert any(w.startswith("implausible density: mass 6.28e+09 t") for w in analysed["warnings"])


def test_sample_refuses_a_bad_target_before_building(tmp_path):
    """Issue 23, item 12: a directory as target was refused only after the FE build (minutes)."""
    result = runner.invoke(app, ["sample", "carbody", "-o", str(tmp_path)])
    assert result.exit_code == 2 and "expected a regular file to write, got a directory" in result.output
    read_only = runner.invoke(app, ["sample", "carbody", "-o", str(tmp_path / "x.xdmf")])  # issue 25
    assert read_only.exit_code == 2 and read_only.stderr == f"error: {tmp_path / 'x.xdmf'}: format meshio can be " \
        "read but not written\n"  # one line, and no step of the FE build reported before it


def test_convert_with_young_and_poisson_computes_the_centrifugal_response(tmp_path, beam):
    """A meshio mesh moved by (10, 20, 30): the body is brought to its principal CoM frame, and --young and
    --poisson give it the same static response and G_kl as the shipped beam (same mesh and material)."""
    path = _mesh_file(tmp_path / "beam.vtu", beam)
    lam = ",".join(repr(float(x)) for x in beam.eigenvalues)
    out = tmp_path / "beam.ffrf.h5"
    opts = ["--eigenvalues", lam, "--density", repr(STEEL.rho)]
    result = runner.invoke(app, ["convert", str(path), str(out), *opts, "--young", repr(STEEL.E),
                                 "--poisson", repr(STEEL.nu)])
    assert result.exit_code == 0, result.output
    body = read_body(out, load_fe=True)
    assert body.fe.material.E == STEEL.E and body.fe.material.rho == STEEL.rho
    assert np.allclose(body.static_centrifugal.sigma, beam.static_centrifugal.sigma, rtol=1e-8)
    s = np.sign(np.einsum("iap,iap->p", body.fe.Phi, beam.fe.Phi))
    assert np.abs(body.geometric * np.outer(s, s) - beam.geometric).max() <= 1e-8 * np.abs(beam.geometric).max()
    half = runner.invoke(app, ["convert", str(path), str(tmp_path / "x.ffrf.h5"), *opts, "--young", "2e5"])
    assert half.exit_code == 2 and "--young/--poisson" in half.output


def test_convert_round_trip_and_refusal(tmp_path, beam):
    inv = tmp_path / "beam.ffinv.json"
    assert runner.invoke(app, ["convert", str(SAMPLES / "beam.ffrf.h5"), str(inv)]).exit_code == 0
    back = tmp_path / "back.ffrf.h5"
    assert runner.invoke(app, ["convert", str(inv), str(back)]).exit_code == 0
    body = read_body(back)
    assert body.fe is None and np.abs(body.W3 - beam.W3).max() <= 1e-12 * np.abs(beam.W3).max()
    before = inv.read_bytes()
    again = runner.invoke(app, ["convert", str(back), str(inv)])
    assert again.exit_code == 2 and "refusing to overwrite" in again.output and inv.read_bytes() == before
    assert runner.invoke(app, ["convert", str(back), str(inv), "--force"]).exit_code == 0
    odd = tmp_path / "beam.data"
    assert runner.invoke(app, ["convert", str(back), str(odd), "--to", "ffinv-h5"]).exit_code == 0
    assert np.abs(read_body(odd, "ffinv-h5").W1 - beam.W1).max() <= 1e-12 * np.abs(beam.W1).max()
    frd = runner.invoke(app, ["convert", str(back), str(tmp_path / "x.frd")])
    assert frd.exit_code == 2 and "read but not written" in frd.output


@pytest.mark.parametrize("body, speed, formulation, pattern", [
    ("conrod", "1", "constant coupling", "T:T:T:T:F:T:T:F:F"),
    ("carbody", "1", "partial coupling", "T:T:T:T:F:T:T:T:F"),
    ("beam", "300", "full coupling", "T:T:T:T:T:T:T:T:T"),
])
def test_settings_for_adams(body, speed, formulation, pattern):
    path = str(SAMPLES / f"{body}.ffrf.h5")
    data = json.loads(runner.invoke(app, ["settings", path, "--solver", "adams", "--speed", speed, "--rules", "thresholds", "--json"]).stdout)
    assert data["formulation"] == formulation and data["invariants"] == pattern
    text = runner.invoke(app, ["settings", path, "--speed", speed, "--rules", "thresholds"], env={"COLUMNS": "200"}).output
    assert f"INVARIANTS={pattern}" in text and data["source"].split(";")[0] in text and "guess" in text
    bad = runner.invoke(app, ["settings", path, "--solver", "simpack"])
    assert bad.exit_code == 2


def test_settings_for_more_solvers_say_what_they_cannot_drop_or_add():
    """RecurDyn Partial (no N4, N6) for an advice without W2 and W3 terms and Full with them; EXUDYN keeps every
    inertia term and cannot add geometric stiffening; Chrono's mapping is tagged a guess; JSON by its schema."""
    import jsonschema
    from ffrf_advisor.schemas import schema
    from ffrf_advisor.solver_settings import SETTINGS
    light, heavy = ("gyro0", "cf1"), ("gyro0", "cf1", "inertia_quad", "cf2", "geo_stiff")
    assert SETTINGS["recurdyn"](light)["setting"] == "Partial" and SETTINGS["recurdyn"](heavy)["setting"] == "Full"
    assert SETTINGS["recurdyn"](light)["cannot_drop"] == ["inertia_lin", "cor1"]
    exudyn = SETTINGS["exudyn"](heavy)
    assert exudyn["cannot_add"] == ["geo_stiff"] and "coupling" in exudyn["cannot_drop"] and exudyn["sure"] == "seen"
    assert SETTINGS["chrono"](light)["sure"] == "guess"
    for solver in SETTINGS:
        result = runner.invoke(app, ["settings", str(SAMPLES / "beam.ffrf.h5"), "--solver", solver, "--speed",
                                     "300rad/s", "--json"])
        assert result.exit_code == 0, result.output
        jsonschema.validate(json.loads(result.stdout), schema("settings"))


def test_vtu_output_reads_back_to_the_same_body(tmp_path, beam):
    """`convert BODY out.vtu` (issue 27): modes, nodal von Mises, the six static centrifugal deflections as
    point data, eigenvalues, frequencies, density, material and units as field data; read back (meshio reader)
    the eigenvalues are the same numbers, the invariants equal to round-off (1e-12 relative; the mass matrix
    is reassembled from the density), the static response to the refactorisation's round-off (1e-10)."""
    out = tmp_path / "beam.vtu"
    result = runner.invoke(app, ["convert", str(SAMPLES / "beam.ffrf.h5"), str(out)])
    assert result.exit_code == 0, result.output
    mesh = meshio.read(out)
    assert {"mode_16", "von_mises_16", "static_w1w1", "static_w2w3"} <= set(mesh.point_data)
    assert mesh.field_data["frequencies_hz"] == pytest.approx(beam.frequencies_hz, rel=1e-15)
    back = read_body(out, load_fe=True)
    assert np.array_equal(back.eigenvalues, beam.eigenvalues)
    for name in ("I", "Ibar", "Sbar"):
        want = getattr(beam.integrals, name)
        assert np.abs(getattr(back.integrals, name) - want).max() <= 1e-12 * np.abs(want).max(), name
    assert np.abs(back.sigma_max - beam.sigma_max).max() <= 1e-12 * beam.sigma_max.max()
    assert back.static_centrifugal.compliance == pytest.approx(beam.static_centrifugal.compliance, rel=1e-10)
    assert "units t-mm-N-s (field data units_si)" in back.provenance.notes[0]
    assert "(field data)" in back.provenance.notes[-1]


def test_vtu_output_refuses_what_a_mesh_cannot_hold(tmp_path, beam):
    """An invariants-only body, a mass matrix that is not one density's plus point masses (a negative one, a
    lumped matrix), and other units in a file."""
    inv = tmp_path / "beam.ffinv.json"
    assert runner.invoke(app, ["convert", str(SAMPLES / "beam.ffrf.h5"), str(inv)]).exit_code == 0
    none = runner.invoke(app, ["convert", str(inv), str(tmp_path / "a.vtu")])
    assert none.exit_code == 2 and "invariants only" in none.output
    from dataclasses import replace
    from ffrf_advisor.io import write_body
    from ffrf_advisor.errors import FFRFError
    lighter = replace(beam, fe=replace(beam.fe, Ms=beam.fe.Ms.tolil()))
    lighter.fe.Ms[0, 0] *= 0.5  # a negative point mass
    with pytest.raises(FFRFError, match="not the consistent mass of a uniform density plus masses on nodes"):
        write_body(replace(lighter, fe=replace(lighter.fe, Ms=lighter.fe.Ms.tocsr())), tmp_path / "b.vtu")
    lumped = replace(beam, fe=replace(beam.fe, Ms=sp.diags_array(np.asarray(beam.fe.Ms.sum(axis=1))).tocsr()))
    with pytest.raises(FFRFError, match="not the consistent mass of a uniform density plus masses on nodes"):
        write_body(lumped, tmp_path / "b.vtu")
    out = tmp_path / "c.vtu"
    assert runner.invoke(app, ["convert", str(SAMPLES / "beam.ffrf.h5"), str(out)]).exit_code == 0
    out.write_text(out.read_text().replace("1000.0 0.001 1.0", "1.0 1.0 1.0"))
    bad = runner.invoke(app, ["info", str(out)])
    assert bad.exit_code == 2 and "field_data/units_si: expected t-mm-N-s" in bad.output
