"""Nastran SOL 103 OP2 files (issue 16): real result files from ../shared/data/nastran (read-only inputs)."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

pytest.importorskip("pyNastran", reason="the Nastran reader's optional extra (pip install '.[nastran]')")

from ffrf_advisor.analysis import Options, analyze  # noqa: E402
from ffrf_advisor.cli import app  # noqa: E402
from ffrf_advisor.guidelines import Situation  # noqa: E402
from ffrf_advisor.io import nastran, read_body, write_body  # noqa: E402

from .fuzz_readers import mutate  # noqa: E402

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "nastran"
BEAM = DATA / "beam_modes_m1.op2"
MULTI = DATA / "modes_elements.op2"
SAMPLE = Path(__file__).resolve().parents[1] / "sample_bodies" / "beam.ffrf.h5"
FLOAT32 = 2e-7  # the OP2 holds modes in float32: a sum of their squares is good to a few 6e-8
GPWG = 1e-6  # Nastran prints the grid point weight generator's output with 7 digits
runner = CliRunner()
needs_data = pytest.mark.skipif(not BEAM.is_file(), reason=f"the shared Nastran files are not at {DATA}")


@pytest.fixture(scope="module")
def beam():
    return nastran.parse(BEAM)


@needs_data
def test_the_assembled_6dof_mass_reproduces_nastrans_generalised_masses(beam):
    run, mass = beam
    assert np.abs(nastran.generalized_mass_error(run, mass)).max() < FLOAT32
    translations_only = replace(mass, J=np.zeros_like(mass.J))
    lost = -nastran.generalized_mass_error(run, translations_only)
    assert lost.max() == pytest.approx(1.0, abs=FLOAT32)  # the torsion mode has only rotary inertia
    bending = lost[lost < 0.5]
    assert 0.005 < bending[bending > 1e-6].min() and bending.max() < 0.23  # 0.6 % to 22 %, as measured
    share = nastran.rotary_share(run, mass)
    assert int(np.argmax(share)) == int(np.argmax(lost)) and share.max() == pytest.approx(1.0, abs=FLOAT32)


@needs_data
def test_mass_cg_and_inertia_equal_nastrans_grid_point_weight_generator(beam):
    run, mass = beam
    gpwg = nastran._load(BEAM).grid_point_weight[""]  # Nastran's own PARAM,GRDPNT output
    m = mass.Ms.sum()
    cg = (mass.Ms @ run.points).sum(axis=0) / m
    assert m == pytest.approx(gpwg.mass[0], rel=GPWG)
    assert np.allclose(cg, gpwg.cg[1][0] * np.eye(3)[0], atol=GPWG * gpwg.cg[1][0])
    x = run.points - cg
    I_trans = np.einsum("i,ia,ib->ab", mass.Ms.diagonal(), x, x)
    I0 = np.trace(I_trans) * np.eye(3) - I_trans + mass.J.sum(axis=0)
    assert np.allclose(np.diag(I0), np.diag(gpwg.IS), rtol=GPWG)


@needs_data
@pytest.mark.parametrize("path", [BEAM, MULTI])
def test_constrained_runs_are_refused_in_one_line_naming_why(path):
    result = runner.invoke(app, ["info", str(path)])
    assert result.exit_code == 2 and "Traceback" not in result.output
    line = result.output.strip()
    assert "\n" not in line and "free-free" in line and "constrained" in line


@needs_data
def test_the_multi_element_file_parses_with_its_24_element_types_and_without_scalar_points():
    run = nastran._modes(MULTI, nastran._load(MULTI))
    elements = {t: k for t, k in run.element_types.items() if t != "CONM2"}
    assert len(elements) == 24 and sum(elements.values()) == 46
    assert len(run.grids) == 39 and run.T.shape == (39, 3, 3)  # 42 points of which 3 scalar


def _free_free_run(body, genmass: np.ndarray):
    """A synthetic free-free SOL 103 run of an FE body: six rigid modes, then its modes scaled to ``genmass``."""
    fe = body.fe
    n = fe.mesh.n_nodes
    rigid = np.zeros((n, 3, 6))
    rigid[:, :, :3] = np.eye(3)[None]
    T = np.concatenate([rigid, fe.Phi * np.sqrt(genmass)], axis=2)
    run = nastran.NastranModes(np.arange(1, n + 1), fe.mesh.points, np.r_[np.zeros(6), body.eigenvalues],
                               np.r_[np.ones(6), genmass], T, np.zeros_like(T),
                               np.r_[np.zeros(6), body.sigma_max * np.sqrt(genmass)], {"CHEXA": 80})
    mass = nastran.AssembledMass(fe.Ms, np.zeros((n, 3, 3)), np.zeros((0, 3)), np.zeros(0, np.int64), [])
    return run, mass


def test_a_free_free_run_gives_the_bodys_invariants_and_advice():
    body = replace(read_body(SAMPLE, load_fe=True), geometric=None, static_centrifugal=None)  # an OP2 has neither
    genmass = np.random.default_rng(5).uniform(0.001, 0.1, body.nf)  # Nastran's generalised masses are not 1
    back = nastran.body_of("synthetic.op2", *_free_free_run(body, genmass))
    assert np.allclose(back.I0, body.I0, rtol=1e-12) and np.allclose(back.eigenvalues, body.eigenvalues)
    assert np.allclose(np.abs(back.W1), np.abs(body.W1), atol=1e-10 * np.abs(body.W1).max())
    assert np.allclose(back.sigma_max, body.sigma_max, rtol=1e-12)
    options = Options(situation=Situation(w_op=300.0))
    assert analyze(back, options).advice.terms == analyze(body, options).advice.terms


def test_a_body_from_a_run_is_written_read_and_reported(tmp_path):
    body = replace(read_body(SAMPLE, load_fe=True), geometric=None, static_centrifugal=None)
    run, mass = _free_free_run(body, np.full(body.nf, 0.01))
    rotary = np.zeros((len(run.grids), 3, 3))
    rotary[0] = np.diag([1e-3, 2e-3, 3e-3])  # one node carries a point inertia: its rotations now count
    run.R[0, 2, 6:] = 1e-3
    back = nastran.body_of("synthetic.op2", run, replace(mass, J=rotary))
    path = tmp_path / "n.ffrf.h5"
    write_body(back, path)
    again = read_body(path, load_fe=True)
    assert np.allclose(again.I0, back.I0) and again.fe.rotary is not None
    result = runner.invoke(app, ["report", str(path), "--speed", "1rad/s", "-o", str(tmp_path / "n.html")])
    assert result.exit_code == 0, result.output
    assert "no solid cells to draw" in (tmp_path / "n.html").read_text()


def _write_op2(body, path) -> None:
    """The body as Nastran would write a free-free SOL 103 run of it, with pyNastran's OP2 writer: GRID, CHEXA
    (20 nodes), PSOLID, MAT1 with rho; six rigid modes then its modes, float32, mass-normalised."""
    from cpylog import SimpleLogger
    from pyNastran.op2.op2_geom import OP2Geom
    from pyNastran.op2.tables.oug.oug_eigenvectors import RealEigenvectorArray

    from ffrf_advisor.fe.modal import rigid_modes

    fe, n = body.fe, body.fe.mesh.n_nodes
    model = OP2Geom(log=SimpleLogger(level="critical"))
    model.set_mode("msc")
    for i, x in enumerate(fe.mesh.points):
        model.add_grid(i + 1, x)
    model.add_mat1(1, fe.material.E, None, fe.material.nu, rho=fe.material.rho)
    model.add_psolid(1, 1)
    for e, conn in enumerate(fe.mesh.cells["hexahedron20"]):
        nastran_order = np.empty(20, int)
        nastran_order[nastran.HEX20] = conn + 1  # the reader's map, inverted
        model.add_chexa(e + 1, 1, nastran_order.tolist())
    T = np.concatenate([rigid_modes(fe.mesh.points).reshape(n, 3, 6), fe.Phi], axis=2)
    data = np.zeros((T.shape[2], n, 6), np.float32)
    data[:, :, :3] = np.moveaxis(T, 2, 0)
    lam = np.r_[np.zeros(6), body.eigenvalues]
    ev = RealEigenvectorArray.add_modal_case("OUGV1", np.column_stack([np.arange(1, n + 1), np.ones(n, int)]), data,
                                             1, np.arange(1, len(lam) + 1), lam, np.sqrt(lam) / (2 * np.pi))
    ev.table_code, ev.device_code, ev.approach_code = 7, 1, 21  # eigenvectors, as Nastran writes them
    model.eigenvectors[1] = ev
    model.write_op2(str(path), post=-1, endian=b"<")


def test_a_sample_written_as_op2_by_pynastran_reads_back_with_its_invariants_and_advice(tmp_path):
    body = replace(read_body(SAMPLE, load_fe=True), geometric=None, static_centrifugal=None)
    path = tmp_path / "beam.op2"
    _write_op2(body, path)
    back = read_body(path)
    assert any("CHEXA" in note and "80" in note for note in back.provenance.notes)
    assert np.allclose(back.I0, body.I0, rtol=1e-6) and np.allclose(back.eigenvalues, body.eigenvalues, rtol=1e-6)
    assert np.allclose(np.abs(back.W1), np.abs(body.W1), atol=1e-6 * np.abs(body.W1).max())  # float32 modes
    assert np.allclose(back.integrals.modal_mass(), np.eye(body.nf), atol=1e-6)
    options = Options(situation=Situation(w_op=300.0))
    assert analyze(back, options).advice.terms == analyze(body, options).advice.terms


def test_an_offset_point_mass_moves_rigidly_with_its_grid():
    run = nastran.NastranModes(np.array([1]), np.zeros((1, 3)), np.array([1.0]), np.array([1.0]),
                               np.zeros((1, 3, 1)), np.array([[[0.0], [0.0], [0.01]]]), None, {})
    mass = nastran.AssembledMass(None, np.zeros((2, 3, 3)), np.array([[2.0, 0.0, 0.0]]), np.array([0]), [])
    points, T, R = nastran.modes_with_extra_nodes(run, mass)
    assert np.allclose(points[1], [2, 0, 0]) and np.allclose(T[1, :, 0], [0, 0.02, 0])  # theta_z x (2, 0, 0)
    assert np.allclose(R[1], R[0])


@needs_data
def test_damaged_op2_files_end_in_one_line(tmp_path):
    rng = np.random.default_rng(11)
    data = BEAM.read_bytes()
    for _ in range(12):
        path = tmp_path / "damaged.op2"
        path.write_bytes(mutate(data, rng))
        result = runner.invoke(app, ["analyze", str(path), "--speed", "1rad/s"])
        assert result.exit_code == 2, result.output
        assert len(result.output.strip().splitlines()) == 1 and "Traceback" not in result.output
