"""Nastran SOL 103 OP2 files (issue 16): real result files from ../shared/data/nastran (read-only inputs)."""
from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.spatial.transform import Rotation
from typer.testing import CliRunner

pytest.importorskip("pyNastran", reason="the Nastran reader's optional extra (pip install '.[nastran]')")

from ffrf_advisor.analysis import Options, analyze  # noqa: E402
from ffrf_advisor.cli import app  # noqa: E402
from ffrf_advisor.errors import FFRFError  # noqa: E402
from ffrf_advisor.guidelines import Situation  # noqa: E402
from ffrf_advisor.io import nastran, nastran_dmig, nastran_mass, nastran_solids, read_body, write_body  # noqa: E402

from .fuzz_readers import counted, mutate  # noqa: E402

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "nastran"
BEAM = DATA / "beam_modes_m1.op2"
MULTI = DATA / "modes_elements.op2"
SAMPLE = Path(__file__).resolve().parents[1] / "sample_bodies" / "beam.ffrf.h5"
FLOAT32 = 2e-7  # the OP2 holds modes in float32: a sum of their squares is good to a few 6e-8
PUNCH = 1e-9  # DMIG terms are punched with 11 significant digits (D-format, 16-character fields)
GPWG = 1e-6  # Nastran prints the grid point weight generator's output with 7 digits
runner = CliRunner()
needs_data = pytest.mark.skipif(not BEAM.is_file(), reason=f"the shared Nastran files are not at {DATA}")


@pytest.fixture(scope="module")
def beam():
    return nastran.parse(BEAM)


@needs_data
def test_the_assembled_6dof_mass_reproduces_nastrans_generalised_masses(beam):
    run, mass, _ = beam
    assert np.abs(nastran_mass.generalized_mass_error(run, mass)).max() < FLOAT32
    translations_only = replace(mass, J=np.zeros_like(mass.J))
    lost = -nastran_mass.generalized_mass_error(run, translations_only)
    assert lost.max() == pytest.approx(1.0, abs=FLOAT32)  # the torsion mode has only rotary inertia
    bending = lost[lost < 0.5]
    assert 0.005 < bending[bending > 1e-6].min() and bending.max() < 0.23  # 0.6 % to 22 %, as measured
    share = nastran_mass.rotary_share(run, mass)
    assert int(np.argmax(share)) == int(np.argmax(lost)) and share.max() == pytest.approx(1.0, abs=FLOAT32)


@needs_data
def test_mass_cg_and_inertia_equal_nastrans_grid_point_weight_generator(beam):
    run, mass, _ = beam
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
                               np.r_[np.zeros(6), body.sigma_max * np.sqrt(genmass)], {"CHEXA": 80},
                               np.concatenate([np.zeros((n, 6)), fe.stress_nodal * np.sqrt(genmass)], axis=1))
    mass = nastran_mass.NodalMass(fe.Ms, np.zeros((n, 3, 3)), np.zeros((0, 3)), np.zeros(0, np.int64), [])
    return run, mass


def test_a_free_free_run_gives_the_bodys_invariants_and_advice():
    body = replace(read_body(SAMPLE, load_fe=True), geometric=None, static_centrifugal=None)  # an OP2 has neither
    genmass = np.random.default_rng(5).uniform(0.001, 0.1, body.nf)  # Nastran's generalised masses are not 1
    back = nastran.body_of("synthetic.op2", *_free_free_run(body, genmass))
    assert np.allclose(back.I0, body.I0, rtol=1e-12) and np.allclose(back.eigenvalues, body.eigenvalues)
    assert np.allclose(np.abs(back.W1), np.abs(body.W1), atol=1e-10 * np.abs(body.W1).max())
    assert np.allclose(back.sigma_max, body.sigma_max, rtol=1e-12)
    assert np.allclose(back.fe.stress_nodal, body.fe.stress_nodal, rtol=1e-12)  # scaled like the modes
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


def _write_op2(path, points, lam, T, R=None, body=None, frame=None, deck=None, clamped=None) -> None:
    """A SOL 103 run as Nastran writes it, with pyNastran's OP2 writer: GRIDs (with ``frame`` as every grid's CD,
    the modes given in it), the CHEXA20 solid of ``body`` if given (PSOLID, MAT1 with rho), eigenvalues ``lam``
    and translations ``T`` and rotations ``R`` (n, 3, nm) in basic, float32. With ``deck`` the geometry goes
    to that input deck instead of the OP2. ``clamped``: a grid held by an SPC1 (a clamped run's model)."""
    from cpylog import SimpleLogger
    from pyNastran.op2.op2_geom import OP2Geom
    from pyNastran.op2.tables.oug.oug_eigenvectors import RealEigenvectorArray

    n, _, nm = T.shape
    model = OP2Geom(log=SimpleLogger(level="critical"))
    model.set_mode("msc")
    F = np.eye(3) if frame is None else frame
    if frame is not None:
        model.add_cord2r(7, [0.0, 0.0, 0.0], F[:, 2], F[:, 0])
    for i, x in enumerate(points):
        model.add_grid(i + 1, x, cd=0 if frame is None else 7)
    if clamped is not None:
        model.add_spc1(1, "123456", [clamped])
    if body is not None:
        model.add_mat1(1, body.fe.material.E, None, body.fe.material.nu, rho=body.fe.material.rho)
        model.add_psolid(1, 1)
        for e, conn in enumerate(body.fe.mesh.cells["hexahedron20"]):
            nastran_order = np.empty(20, int)
            nastran_order[nastran_solids.TO_VTK["hexahedron20"]] = conn + 1  # the reader's map, inverted
            model.add_chexa(e + 1, 1, nastran_order.tolist())
    data = np.zeros((nm, n, 6), np.float32)
    data[:, :, :3] = np.einsum("ba,ibp->pia", F, T)  # CD components F^T u
    if R is not None:
        data[:, :, 3:] = np.einsum("ba,ibp->pia", F, R)
    ev = RealEigenvectorArray.add_modal_case("OUGV1", np.column_stack([np.arange(1, n + 1), np.ones(n, int)]), data,
                                             1, np.arange(1, nm + 1), lam, np.sqrt(np.abs(lam)) / (2 * np.pi))
    ev.table_code, ev.device_code, ev.approach_code = 7, 1, 21  # eigenvectors, as Nastran writes them
    if deck is not None:
        model.write_bdf(str(deck))
        model = OP2Geom(log=SimpleLogger(level="critical"))
        model.set_mode("msc")
    model.eigenvectors[1] = ev
    model.write_op2(str(path), post=-1, endian=b"<")


def _write_punch(path, matrices: dict, frame=None) -> None:
    """Symmetric 6n x 6n matrices in basic as DMIG (IFO 6, lower triangle, real double) in each grid's CD
    ``frame``, the way PARAM,EXTOUT,DMIGPCH punches them."""
    from cpylog import SimpleLogger
    from pyNastran.bdf.bdf import BDF

    model = BDF(log=SimpleLogger(level="critical"))
    for name, A in matrices.items():
        n = A.shape[0] // 6
        T = sp.kron(sp.eye_array(n), sp.kron(sp.eye_array(2), np.eye(3) if frame is None else frame))
        A = sp.tril(sp.coo_array(T.T @ A @ T)).tocoo()  # CD components: T^T A T
        keep = A.data != 0
        label = lambda k: (int(k // 6 + 1), int(k % 6 + 1))  # noqa: E731
        model.add_dmig(name, 6, 2, 0, 0, 0, [label(c) for c in A.col[keep]], [label(r) for r in A.row[keep]],
                       A.data[keep].tolist())
    model.write_bdf(str(path), write_header=False, size=16, is_double=True)


def _sample_op2(body, path, frame=None, deck=None) -> None:
    """The body as a free-free SOL 103 run: six rigid modes, then its modes, mass-normalised."""
    from ffrf_advisor.fe.modal import rigid_modes

    n = body.fe.mesh.n_nodes
    T = np.concatenate([rigid_modes(body.fe.mesh.points).reshape(n, 3, 6), body.fe.Phi], axis=2)
    _write_op2(path, body.fe.mesh.points, np.r_[np.zeros(6), body.eigenvalues], T, body=body, frame=frame,
               deck=deck)


def test_a_sample_written_as_op2_by_pynastran_reads_back_with_its_invariants_and_advice(tmp_path):
    body = replace(read_body(SAMPLE, load_fe=True), geometric=None, static_centrifugal=None)
    path = tmp_path / "beam.op2"
    _sample_op2(body, path)
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
    mass = nastran_mass.NodalMass(None, np.zeros((2, 3, 3)), np.array([[2.0, 0.0, 0.0]]), np.array([0]), [])
    points, T, R = nastran_mass.modes_with_extra_nodes(run, mass)
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


def test_a_sample_with_its_mass_punched_as_dmig_in_turned_frames_reads_back_with_its_invariants(tmp_path):
    body = replace(read_body(SAMPLE, load_fe=True), geometric=None, static_centrifugal=None)
    frame = Rotation.from_rotvec([0.3, -0.5, 0.8]).as_matrix()  # every grid's CD: modes and DMIG in it
    path = tmp_path / "beam.op2"
    _sample_op2(body, path, frame)
    n = body.fe.mesh.n_nodes
    M = nastran_dmig.nodal_matrix(nastran_mass.NodalMass(body.fe.Ms, np.zeros((n, 3, 3)), np.zeros((0, 3)),
                                                         np.zeros(0, np.int64), []), body.fe.mesh.points)
    _write_punch(tmp_path / "beam.pch", {"MAAX": M}, frame)
    back = read_body(path)
    notes = " ".join(back.provenance.notes)
    assert "DMIG MAAX of beam.pch" in notes and back.provenance.mass_matrix == "consistent"
    assert back.mass == pytest.approx(body.mass, rel=PUNCH)
    assert np.allclose(back.I0, body.I0, atol=FLOAT32 * np.abs(body.I0).max())  # OP2 grids are float32 too
    assert np.allclose(back.eigenvalues, body.eigenvalues, rtol=1e-6)
    assert np.allclose(np.abs(back.W1), np.abs(body.W1), atol=1e-6 * np.abs(body.W1).max())  # float32 modes
    assert np.allclose(back.integrals.modal_mass(), np.eye(body.nf), atol=FLOAT32 * 5)
    options = Options(situation=Situation(w_op=300.0))
    assert analyze(back, options).advice.terms == analyze(body, options).advice.terms


def _space_frame(n: int = 8, length: float = 700.0):
    """A free straight 3-D beam of n nodes (Euler-Bernoulli elements, 6 DOFs a node), its lumped mass with
    the rotary inertia of the cross-section, turned off the axes: points, K and M (6n x 6n) in basic."""
    E, G, A, Iy, Iz, It, rho = 2.1e5, 8.1e4, 120.0, 900.0, 1600.0, 2000.0, 7.85e-9
    h = length / (n - 1)
    k = np.zeros((12, 12))
    k[np.ix_([0, 6], [0, 6])] = E * A / h * np.array([[1, -1], [-1, 1]])
    k[np.ix_([3, 9], [3, 9])] = G * It / h * np.array([[1, -1], [-1, 1]])
    for dofs, EI, s in (([1, 5, 7, 11], E * Iz, 1), ([2, 4, 8, 10], E * Iy, -1)):
        k[np.ix_(dofs, dofs)] = EI / h**3 * np.array([[12, s * 6 * h, -12, s * 6 * h],
                                                      [s * 6 * h, 4 * h * h, -s * 6 * h, 2 * h * h],
                                                      [-12, -s * 6 * h, 12, -s * 6 * h],
                                                      [s * 6 * h, 2 * h * h, -s * 6 * h, 4 * h * h]])
    K = np.zeros((6 * n, 6 * n))
    for e in range(n - 1):
        K[6 * e:6 * e + 12, 6 * e:6 * e + 12] += k
    m = np.zeros((n, 6))
    for e in range(n - 1):  # half of each element at each end: mass, and rho I h / 2 about each axis
        m[e:e + 2] += rho * h / 2 * np.array([A, A, A, It, Iy, Iz])
    Q = Rotation.from_rotvec([0.4, 0.2, -0.7]).as_matrix()
    T = np.kron(np.eye(2 * n), Q)
    points = (np.arange(n)[:, None] * [h, 0, 0] + [10.0, -20.0, 5.0]) @ Q.T
    return points, T @ K @ T.T, T @ np.diag(m.ravel()) @ T.T


def _clamped_run(points, K, M, count: int):
    """The lowest ``count`` modes with node 0 clamped, as a run (mass-normalised, T and R (n, 3, count))."""
    free = np.arange(6, K.shape[0])
    lam, V = sla.eigh(K[np.ix_(free, free)], M[np.ix_(free, free)], subset_by_index=[0, count - 1])
    modes = np.zeros((K.shape[0], count))
    modes[free] = V
    modes = modes.reshape(len(points), 6, count)
    return nastran.NastranModes(np.arange(1, len(points) + 1), points, lam, np.ones(count), modes[:, :3],
                                modes[:, 3:], None, {})


def test_the_space_frame_stiffness_has_the_six_rigid_modes_in_its_null_space():
    points, K, M = _space_frame()
    assert nastran_dmig.free_body_residual(sp.csr_array(K), points) < 1e-13  # the test model itself is right


def _frame_body(run, K, M):
    mats = nastran_dmig.Matrices("frame.pch", sp.csr_array(M), sp.csr_array(K))
    mass = nastran_dmig.nodal_form(mats.M, run.points, "frame.pch")
    return nastran.body_of("frame.op2", run, mass, mats)


def test_a_clamped_basis_that_spans_the_free_body_gives_its_free_modes_exactly():
    points, K, M = _space_frame()
    run = _clamped_run(points, K, M, K.shape[0] - 6)  # all clamped modes + the rigid modes span every DOF
    body = _frame_body(run, K, M)
    free = sla.eigh(K, M, eigvals_only=True)[6:]
    assert np.allclose(body.eigenvalues, free, rtol=1e-9)  # eigh's round-off on a 48-DOF problem
    assert np.allclose(body.integrals.modal_mass(), np.eye(body.nf), atol=1e-10)  # translations + rotary (3b)
    assert "not free-free (0 of 42 modes rigid)" in " ".join(body.provenance.notes)


def test_a_few_clamped_modes_give_ritz_values_above_the_free_eigenvalues():
    points, K, M = _space_frame()
    body = _frame_body(_clamped_run(points, K, M, 10), K, M)
    free = sla.eigh(K, M, eigvals_only=True)[6:16]
    assert body.nf == 10 and np.all(body.eigenvalues >= free * (1 - 1e-12))  # Poincare: Ritz values bound above
    assert body.eigenvalues[0] < 1.2 * free[0]  # and a cantilever basis still finds the first bending


def test_the_matrices_of_a_constrained_model_are_refused_naming_the_punch():
    points, K, M = _space_frame()
    K[:6], K[:, :6] = 0.0, 0.0  # a constrained run's a-set lacks the clamped DOFs
    with pytest.raises(FFRFError, match=r"frame\.pch: DMIG KAAX: expected the stiffness of the free body"):
        _frame_body(_clamped_run(points, K, M, 5), K, M)


def _rigid_inertia(M: np.ndarray, points: np.ndarray) -> tuple[float, np.ndarray]:
    """Mass and principal moments of a 6-DOF mass from its rigid-body modes about the CoM (independent of the
    nodal form): the CoM is where the translation-rotation block of R^T M R vanishes."""
    R = nastran_dmig.rigid_modes_6(points)
    A = R.T @ M @ R
    m = np.trace(A[:3, :3]) / 3
    c_tilde = -A[:3, 3:] / m  # A_tr(c) = A_tr(0) + m c~
    c = np.array([c_tilde[2, 1], c_tilde[0, 2], c_tilde[1, 0]])
    Rc = nastran_dmig.rigid_modes_6(points - c)[:, 3:]
    return m, np.linalg.eigvalsh(Rc.T @ M @ Rc)


def test_a_mass_off_its_grid_in_maax_becomes_a_node_that_moves_with_it_exactly():
    points, K, M = _space_frame()
    m, arm = 5 * M[0, 0], np.array([0.0, 30.0, 0.0])  # a point mass 30 mm off node 3: u = u_3 + theta_3 x arm
    L = np.column_stack([np.eye(3), -np.cross(np.eye(3), arm)])  # (3 x 6): its velocity from node 3's six
    M[18:24, 18:24] += m * L.T @ L
    body = _frame_body(_clamped_run(points, K, M, K.shape[0] - 6), K, M)
    warnings = [n for n in body.provenance.notes if "warning" in n]
    assert "1 grids' mass off the grid" in " ".join(body.provenance.notes)
    assert warnings == ["warning: 0 rigid modes instead of six (modes none): the run is constrained"]  # the clamp's
    mass, moments = _rigid_inertia(M, points)
    assert body.mass == pytest.approx(mass, rel=1e-13)
    assert np.allclose(np.linalg.eigvalsh(body.I0), moments, rtol=1e-12)
    assert np.allclose(body.integrals.modal_mass(), np.eye(body.nf), atol=1e-10)  # the extra node's kinematics


def test_a_mass_with_couplings_the_body_model_cannot_hold_is_reported():
    points, K, M = _space_frame()
    mu = 2 * M[0, 0]  # the first element's mass, made consistent along basic x only: [[2, 1], [1, 2]] mu / 6
    M[0, 0] += -mu / 6
    M[6, 6] += -mu / 6
    M[0, 6] = M[6, 0] = mu / 6
    body = _frame_body(_clamped_run(points, K, M, K.shape[0] - 6), K, M)
    assert any("warning: it couples DOFs" in note for note in body.provenance.notes)


def test_a_clamped_run_with_the_free_bodys_punched_matrices_is_analysed_through_the_files(tmp_path):
    points, K, M = _space_frame()
    run = _clamped_run(points, K, M, 12)
    _write_op2(tmp_path / "frame.op2", points, run.eigenvalues, run.T, run.R, clamped=1)
    refused = runner.invoke(app, ["info", str(tmp_path / "frame.op2")])
    assert refused.exit_code == 2 and "MAAX and KAAX beside it" in refused.output
    _write_punch(tmp_path / "frame.pch", {"MAAX": sp.csr_array(M), "KAAX": sp.csr_array(K)})
    back = read_body(tmp_path / "frame.op2")
    as_written = replace(run, points=run.points.astype(np.float32), T=run.T.astype(np.float32),
                         R=run.R.astype(np.float32))  # the OP2 holds grids and modes in float32
    lam_max = sla.eigh(K, M, eigvals_only=True)[-1]  # punched K to 1e-11 moves a Ritz value by ~1e-11 lam_max
    assert np.allclose(back.eigenvalues, _frame_body(as_written, K, M).eigenvalues, rtol=0, atol=PUNCH * lam_max)
    result = runner.invoke(app, ["analyze", str(tmp_path / "frame.op2"), "--speed", "10rad/s"])
    assert result.exit_code == 0, result.output


def test_damaged_punch_files_end_in_one_line(tmp_path):
    points, K, M = _space_frame()
    run = _clamped_run(points, K, M, 12)
    _write_op2(tmp_path / "frame.op2", points, run.eigenvalues, run.T, run.R, clamped=1)
    _write_punch(tmp_path / "clean.pch", {"MAAX": sp.csr_array(M), "KAAX": sp.csr_array(K)})
    data, rng, refused = (tmp_path / "clean.pch").read_bytes(), np.random.default_rng(12), 0
    for _ in range(12):
        (tmp_path / "frame.pch").write_bytes(mutate(data, rng))
        result = runner.invoke(app, ["analyze", str(tmp_path / "frame.op2"), "--speed", "1rad/s"])
        assert result.exit_code in (0, 2) and "Traceback" not in result.output, result.output
        if result.exit_code == 2:
            refused += 1
            assert len(result.output.strip().splitlines()) == 1 and "frame.pch" in result.output, result.output
    assert refused > 0


@pytest.mark.slow
def test_a_punch_beside_an_op2_survives_hundreds_of_damaged_copies(tmp_path):
    """Issue 23, item 18: the Nastran reader with the fuzzer's classes beyond the OP2's own bytes: the free
    body's MAAX/KAAX punch beside a clamped run, damaged (hostile numbers make it indefinite or NaN), counted
    by the harness; only valid bodies and one-line errors pass."""
    points, K, M = _space_frame()
    run = _clamped_run(points, K, M, 12)
    _write_op2(tmp_path / "frame.op2", points, run.eigenvalues, run.T, run.R, clamped=1)
    _write_punch(tmp_path / "frame.pch", {"MAAX": sp.csr_array(M), "KAAX": sp.csr_array(K)})
    done = subprocess.run([sys.executable, str(Path(__file__).parent / "fuzz_readers.py"), str(tmp_path / "frame.pch"),
                           str(PUNCH_CASES), "20261124", json.dumps({"_read": "frame.op2"})],
                          capture_output=True, text=True, timeout=1800)
    counts = counted(done, PUNCH_CASES)
    assert counts["one_line_error"] > 0 and counts["valid"] > 0, counts


PUNCH_CASES = 80  # about 0.5 s each


def _rows(table, eid: int, nid: int) -> np.ndarray:
    """The rows (nm, k, columns) of element eid at grid nid (0: centroid) in a pyNastran stress table."""
    return np.asarray(table.data, dtype=float)[:, (table.element_node[:, 0] == eid) & (table.element_node[:, 1] == nid)]


@needs_data
def test_nodal_von_mises_averages_corner_values_of_the_elements_at_a_grid():
    m = nastran._load(MULTI)
    run = nastran._modes(MULTI, m)
    s, at = m.op2_results.stress, {int(g): i for i, g in enumerate(run.grids)}
    quad8, tria6, beam = (next(iter(getattr(s, t).values()))
                          for t in ("cquad8_stress", "ctria6_stress", "cbeam_stress"))
    vm = -1  # the von Mises column of shells
    grid60 = (np.abs(_rows(quad8, 60, 60)[:, :, vm]).max(axis=1)
              + np.abs(_rows(tria6, 61, 60)[:, :, vm]).max(axis=1)) / 2
    assert np.allclose(run.stress_nodal[at[60]], grid60, rtol=1e-12)  # CQUAD8 60 and CTRIA6 61, two fibres each
    fibre = [beam.get_headers().index(h) for h in ("smax", "smin")]
    assert np.allclose(run.stress_nodal[at[26]], np.abs(_rows(beam, 12, 26)[:, 0, fibre]).max(axis=1))  # CBEAM end
    bar = next(iter(s.cbar_stress.values()))
    b = [bar.get_headers().index(h) for h in ("smaxb", "sminb")]
    assert m.elements[13].node_ids[1] == 27
    assert np.allclose(run.stress_nodal[at[27]], np.abs(np.asarray(bar.data, float)[:, 0, b]).max(axis=1))  # CBAR end B
    assert np.allclose(run.sigma_max, run.stress_nodal.max(axis=0))


def test_an_op2_without_geometry_takes_it_from_the_input_deck_beside_it(tmp_path):
    body = replace(read_body(SAMPLE, load_fe=True), geometric=None, static_centrifugal=None)
    path = tmp_path / "beam.op2"
    deck = tmp_path / "beam.bdf"
    _sample_op2(body, path, deck=deck)
    deck.write_text("SOL 103\nCEND\n" + deck.read_text())  # pyNastran writes no executive control
    back = read_body(path)
    assert np.allclose(back.I0, body.I0, rtol=1e-6) and np.allclose(back.eigenvalues, body.eigenvalues, rtol=1e-6)
    full = deck.read_text()
    deck.write_text(full.split("BEGIN BULK\n")[1])  # bulk data only, as a file an input deck includes
    assert np.allclose(read_body(path).I0, back.I0, rtol=1e-12)
    deck.write_text(full)
    deck.write_text(deck.read_text().replace("BEGIN BULK\n", "BEGIN BULK\nINCLUDE 'geom.inc'\n"))
    result = runner.invoke(app, ["info", str(path)])
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1
    assert "beam.bdf: file: expected an input deck pyNastran can read with its INCLUDE files" in result.output
    deck.unlink()
    result = runner.invoke(app, ["info", str(path)])
    assert result.exit_code == 2 and "or an input deck beside it" in result.output


def test_a_deck_read_beside_an_op2_writes_no_file_where_the_tool_runs(tmp_path, monkeypatch):
    """pyNastran's read_bdf dumps the deck into the working directory: pyNastran_crash.bdf on a missing INCLUDE,
    pyNastran_dump.bdf when the deck says ``$pyNastran: dumplines=True``. The reader writes neither, and a file
    of that name there stays as it was."""
    body = replace(read_body(SAMPLE, load_fe=True), geometric=None, static_centrifugal=None)
    (tmp_path / "job").mkdir()
    path, deck = tmp_path / "job" / "beam.op2", tmp_path / "job" / "beam.bdf"
    _sample_op2(body, path, deck=deck)
    full = "SOL 103\nCEND\n" + deck.read_text()
    deck.write_text(full.replace("BEGIN BULK\n", "BEGIN BULK\nINCLUDE 'geom.inc'\n"))
    monkeypatch.chdir(tmp_path)
    for mine in (None, b"the user's own file\n"):
        if mine is not None:
            (tmp_path / "pyNastran_crash.bdf").write_bytes(mine)
        before = sorted(tmp_path.rglob("*"))
        result = runner.invoke(app, ["info", str(path)])
        assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1
        assert "beam.bdf: file: expected an input deck pyNastran can read with its INCLUDE files" in result.output
        assert sorted(tmp_path.rglob("*")) == before
    assert (tmp_path / "pyNastran_crash.bdf").read_bytes() == mine
    deck.write_text("$pyNastran: dumplines=True\n" + full)
    assert np.allclose(read_body(path).I0, body.I0, rtol=1e-6)
    assert sorted(tmp_path.rglob("*")) == before
