"""ANSYS MAPDL modal results (issue 27, item 1): the .rst and .full that ansys-mapdl-reader ships, a 1 x 1 x 5 in
titanium bar of 40 SOLID186 whose run holds its first six flexible modes; its .full was written with the
z = 0 face held (63 DOFs: their couplings are not in its K). Other element types and their degenerate forms:
tests/test_ansys_cells.py."""
from __future__ import annotations

import os
import re
import shutil
import signal
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from typer.testing import CliRunner

reader = pytest.importorskip("ansys.mapdl.reader", reason="the ANSYS reader's optional extra (pip install '.[ansys]')")

from ansys.mapdl.reader import _binary_reader, examples  # noqa: E402
from ansys.mapdl.reader.common import two_ints_to_long  # noqa: E402

from ffrf_advisor.checks import apparent_density, density_warnings, run_checks  # noqa: E402
from ffrf_advisor.cli import app  # noqa: E402
from ffrf_advisor.errors import BodyFileError, FFRFError  # noqa: E402
from ffrf_advisor.fe.assembly import stiffness_matrix  # noqa: E402
from ffrf_advisor.fe.mesh import Mesh  # noqa: E402
from ffrf_advisor.fe.modal import rigid_modes  # noqa: E402
from ffrf_advisor.io import ansys, ansys_fe, ansys_files, guard, read_body  # noqa: E402
from ffrf_advisor.units import SI, TMM  # noqa: E402

EXAMPLES = Path(examples.__file__).parent
INCH_MM = 25.4
SLINCH_T = 0.45359237 * 9.80665 / 0.0254 / 1000  # lbf s^2 / in in t: the mass unit of MAPDL's BIN system
UNITS_WORD = 8  # the /UNITS code in the standard header (0 user defined, 1 SI, 4 BIN, 6 MPA)
ROUND_OFF = 1e-12  # sums of products over 963 DOFs in double precision lose ~1e-14; margin 100
NORMALISED = 1e-10  # MAPDL writes M-orthonormal modes in double: Lanczos leaves 3e-12 in this file
LANCZOS = 1e-5  # MAPDL's Block Lanczos leaves |K phi - lambda M phi| / |K phi| up to 9e-7 in this file; margin 10
FLOAT32 = 1e-5  # corner stresses are float32 (6e-8), mixed and unmixed again through six modes
runner = CliRunner()


@pytest.fixture
def job(tmp_path) -> Path:
    """The example's two files under one job name of our own."""
    for suffix in ("rst", "full"):
        shutil.copy(EXAMPLES / f"file.{suffix}", tmp_path / f"job.{suffix}")
    return tmp_path / "job.rst"


@pytest.fixture(scope="module")
def example(tmp_path_factory):
    """The body read from the example, and the file's own data read here with the library alone (file units):
    node numbers, points, elements, the raw modes and frequencies, the .full's M and K and the DOFs it held."""
    d = tmp_path_factory.mktemp("example")
    for suffix in ("rst", "full"):
        shutil.copy(EXAMPLES / f"file.{suffix}", d / f"job.{suffix}")
    body = read_body(d / "job.rst", load_fe=True)
    r = reader.read_binary(str(d / "job.rst"))
    nodes = np.asarray(r.mesh.nnum)
    modes = np.stack([r.nodal_solution(i)[1] for i in range(r.nsets)], axis=-1).reshape(3 * len(nodes), -1)
    M, K, held = _full(d / "job.full", nodes)
    elements = [np.searchsorted(nodes, e[10:]) for e in r.mesh.elem]
    return dict(path=d / "job.rst", body=body, nodes=nodes, X=np.asarray(r.mesh.nodes)[:, :3], modes=modes,
                f=np.asarray(r.time_values), M=M, K=K, held=held, elements=elements,
                dens=r.materials[1]["DENS"])


def _full(path: Path, nodes: np.ndarray):
    """M and K of the .full over DOFs 3 i + c (every stored term, the held DOFs' too) and the held DOFs."""
    f = reader.read_binary(str(path))
    dof = np.asarray(f.load_km(sort=False)[0])
    eq = 3 * np.searchsorted(nodes, dof[:, 0]) + dof[:, 1]
    h, n3 = f._header, 3 * len(nodes)

    def matrix(ptr, name):
        rows, cols, data = _binary_reader.read_array(str(path), h[ptr], two_ints_to_long(h[f"nterm{name}l"],
                                                     h[f"nterm{name}h"]), f.neqn, np.ones(f.neqn, np.int32))
        upper = sp.coo_array((data, (eq[rows], eq[cols])), shape=(n3, n3)).toarray()
        return upper + upper.T - np.diag(np.diag(upper))

    held = np.zeros(n3, bool)
    held[3 * np.searchsorted(nodes, f.const[:, 0]) + f.const[:, 1]] = True
    return matrix("ptrMAS", "M"), matrix("ptrSTF", "K"), held


def _in_file_frame(example) -> np.ndarray:
    """The body's modes turned back to the file's frame and units (3n x nf; a mode is per sqrt(mass), theory 6)."""
    body = example["body"]
    X = np.column_stack([example["X"] * INCH_MM, np.ones(len(example["X"]))])
    R = np.linalg.lstsq(X, body.fe.mesh.points, rcond=None)[0][:3]  # points' = (x - c) R
    Phi = np.einsum("ak,ikp->iap", R, body.fe.Phi)  # v_file = R v_body
    return Phi.reshape(-1, body.nf) * np.sqrt(SLINCH_T)


# ---------------------------------------------------------------- the example read
def test_the_example_reads_in_t_mm_with_every_check_passing(example):
    body = example["body"]
    failed = [c.name for c in run_checks(body) if not c.passed]
    assert failed == [] and density_warnings(body) == ()
    assert body.units == TMM and body.fe.K is not None and body.static_centrifugal is not None
    notes = " ".join(body.provenance.notes)
    assert "units BIN, the one MAPDL system" in notes and "the free K assembled from the elements" in notes
    agree = float(re.search(r"give its mass, centre of mass and second moments within (\S+)", notes).group(1))
    assert agree < ROUND_OFF  # the .full's M and the 40 straight SOLID186 at their density (9.6e-13 measured)


def test_info_and_analyze_read_the_rst(job):
    info = runner.invoke(app, ["info", str(job)])
    assert info.exit_code == 0 and "6 flexible modes" in info.output, info.output
    analyze = runner.invoke(app, ["analyze", str(job), "--speed", "1000rad/s"])
    assert analyze.exit_code == 0 and "job: level" in analyze.output, analyze.output


def test_the_modes_have_unit_modal_mass_with_the_mass_matrix_of_the_full(example):
    M, body = example["M"], example["body"]
    raw = example["modes"]
    assert np.abs(raw.T @ M @ raw - np.eye(raw.shape[1])).max() < NORMALISED  # MAPDL's own normalisation
    Ms = M[0::3, 0::3] * SLINCH_T
    assert np.abs(body.fe.Ms.toarray() - Ms).max() < ROUND_OFF * np.abs(Ms).max()
    Phi = body.fe.Phi.reshape(-1, body.nf)
    assert np.abs(Phi.T @ np.kron(Ms, np.eye(3)) @ Phi - np.eye(body.nf)).max() < NORMALISED


def test_eigenvalues_and_modes_solve_the_full_matrices_where_its_rows_are_whole(example):
    """K phi = lambda M phi on the DOFs of nodes that share no element with a held node (the .full lacks the
    held DOFs' couplings); the body's modes turned back to the file's frame and units."""
    held_nodes = set(np.flatnonzero(example["held"]) // 3)
    touched = {int(i) for e in example["elements"] if held_nodes & set(e.tolist()) for i in e}
    whole = np.repeat([i not in touched for i in range(len(example["nodes"]))], 3)
    assert 0 < whole.sum() < len(whole)
    body, K, M = example["body"], example["K"], example["M"]
    Phi = _in_file_frame(example)
    KPhi = (K @ Phi)[whole]
    residual = np.linalg.norm(KPhi - (M @ Phi)[whole] * body.eigenvalues, axis=0) / np.linalg.norm(KPhi, axis=0)
    assert residual.max() < LANCZOS
    assert np.allclose(body.eigenvalues, (2 * np.pi * example["f"]) ** 2, rtol=ROUND_OFF)
    same = np.abs(np.einsum("ip,ip->p", Phi, M @ example["modes"]))  # |MAC| with the file's modes, unit mass
    assert np.allclose(same, 1, atol=NORMALISED)  # the file's modes, taken as they are


def test_I0_is_the_nodal_sum_of_the_full_mass_and_that_of_the_solid_bar(example):
    body, M, X = example["body"], example["M"], example["X"]
    Ms = M[0::3, 0::3]
    m = Ms.sum()
    c = Ms.sum(axis=0) @ X / m
    S = (X - c).T @ Ms @ (X - c)
    I0 = (np.trace(S) * np.eye(3) - S) * SLINCH_T * INCH_MM**2
    assert body.mass == pytest.approx(m * SLINCH_T, rel=ROUND_OFF)
    assert np.allclose(np.linalg.eigvalsh(body.I0), np.linalg.eigvalsh(I0), rtol=ROUND_OFF)
    a, b, h = np.ptp(X, axis=0)  # the consistent mass integrates x^2 exactly on the straight hexahedra
    bar = example["dens"] * a * b * h
    assert m == pytest.approx(bar, rel=ROUND_OFF)
    box = bar * np.array([a**2 + b**2, a**2 + h**2, b**2 + h**2]) / 12 * SLINCH_T * INCH_MM**2
    assert np.allclose(np.sort(np.diag(body.I0)), np.sort(box), rtol=ROUND_OFF)
    kg_per_m3 = example["dens"] * SLINCH_T / INCH_MM**3 * 1e12  # the solid bar's density is the material's
    assert apparent_density(body) == pytest.approx(kg_per_m3, rel=ROUND_OFF)


# ---------------------------------------------------------------- units
def _with_units_code(job: Path, code: int) -> Path:
    data = np.fromfile(job, "<i4")
    data[UNITS_WORD] = code
    data.tofile(job)
    return job


def test_the_units_option_is_checked_against_the_materials(job, example):
    as_bin = ansys.read(job, units="BIN")
    assert np.allclose(as_bin.I0, example["body"].I0, rtol=ROUND_OFF)
    assert "(the units option)" in as_bin.provenance.notes[1]
    for wrong in ("t-mm-N-s", "SI"):
        with pytest.raises(BodyFileError, match=r"job\.rst: units: expected units under which the materials") as e:
            ansys.read(job, units=wrong)
        assert "\n" not in str(e.value) and "they fit: BIN" in str(e.value)
    with pytest.raises(BodyFileError, match="an MAPDL system"):
        ansys.read(job, units="furlong")
    ok = runner.invoke(app, ["analyze", str(job), "--units", "BIN", "--speed", "100rad/s"])  # the CLI's --units
    wrong = runner.invoke(app, ["info", str(job), "--units", "SI"])
    assert ok.exit_code == 0, ok.output
    assert wrong.exit_code == 2 and len(wrong.output.strip().splitlines()) == 1 and "they fit: BIN" in wrong.output


def test_the_units_record_of_the_file_decides(job, example):
    stated = ansys.read(_with_units_code(job, 4))  # BIN
    assert "(/UNITS of the .rst)" in stated.provenance.notes[1]
    assert np.allclose(stated.I0, example["body"].I0, rtol=ROUND_OFF)
    si = ansys.read(_with_units_code(job, 1))  # the numbers read as kg and m: a bar of 4e-4 kg/m^3
    assert si.units == SI and si.mass == pytest.approx(example["M"][0::3, 0::3].sum(), rel=ROUND_OFF)
    assert "implausible density" in density_warnings(si)[0]
    with pytest.raises(BodyFileError, match=r"job\.rst: /UNITS: expected BIN as the units option says"):
        ansys.read(_with_units_code(job, 6), units="BIN")


# ---------------------------------------------------------------- free K and runs that are not free-free
def _clamped(run, k: int):
    """The run with its modes replaced by the first k modes of the .full's own (held) problem."""
    free = ~run.constrained
    lam, V = spla.eigsh(sp.csc_array(run.K[free][:, free]), k=k, M=sp.csc_array(run.M[free][:, free]), sigma=0)
    modes = np.zeros((len(free), k))
    modes[free] = V
    return replace(run, eigenvalues=lam, modes=modes.reshape(-1, 3, k), corner_stress=None)


def test_a_clamped_run_is_brought_to_free_free_form_with_ritz_values_above_the_free_ones(job, example):
    body = ansys.body_of(job, _clamped(ansys.parse(job), 10))
    assert all(c.passed for c in run_checks(body)) and body.nf == 10
    assert "not free-free (0 of 10 modes rigid" in " ".join(body.provenance.notes)
    free = (2 * np.pi * example["f"]) ** 2  # the file's modes are the free bar's first six (residual 9e-7)
    assert np.all(body.eigenvalues[:6] >= free * (1 - ROUND_OFF))  # Poincare: Ritz values bound from above
    assert body.eigenvalues[0] < 1.01 * free[0]  # and ten cantilever modes find the first bending pair


def test_mixed_modes_come_back_as_the_free_modes_with_their_stresses(job, example):
    """The file's modes mixed (a random rotation plus rigid motion) are no eigenvectors; their Ritz vectors are the
    free modes again, and the stresses combined from the mixed corner tensors are the free modes' own."""
    run = ansys.parse(job)
    rng = np.random.default_rng(27)
    Q = np.linalg.qr(rng.normal(size=(6, 6)))[0]
    rigid = rigid_modes(run.points).reshape(-1, 3, 6) @ rng.normal(size=(6, 6))
    mixed = replace(run, modes=run.modes @ Q + 0.01 * rigid,
                    corner_stress={t: (s.astype(float) @ Q).astype(np.float32) for t, s in run.corner_stress.items()})
    body = ansys.body_of(job, mixed)
    assert "not free-free" in " ".join(body.provenance.notes)
    assert np.allclose(body.eigenvalues, example["body"].eigenvalues, rtol=NORMALISED)  # Lanczos residual^2, 1e-12
    single = [2, 5]  # the pairs 1-2 and 4-5 are double: any rotation within a pair is as good
    before, after = example["body"].fe.stress_nodal[:, single], body.fe.stress_nodal[:, single]
    assert np.abs(after - before).max() < FLOAT32 * before.max()


def test_a_clamped_run_without_the_free_k_is_refused_naming_the_full(job):
    run = replace(_clamped(ansys.parse(job), 6), materials={})  # the elements cannot rebuild the free K
    with pytest.raises(BodyFileError, match=r"job\.full: stiffness matrix: expected the free body's K") as e:
        ansys.body_of(job, run)
    assert "\n" not in str(e.value) and "is not the free body's" in str(e.value)


def _with_rigid_modes(run):
    """The run with the six rigid modes a free run holds before its flexible ones (zero eigenvalue and stress)."""
    rigid = rigid_modes(run.points - run.points.mean(axis=0)).reshape(-1, 3, 6)
    stress = {t: np.concatenate([np.zeros((*s.shape[:3], 6), s.dtype), s], axis=3)
              for t, s in run.corner_stress.items()}
    return replace(run, eigenvalues=np.r_[np.zeros(6), run.eigenvalues],
                   modes=np.concatenate([rigid, run.modes], axis=2), corner_stress=stress)


def test_a_free_k_in_the_full_is_taken_as_it_is(job, example):
    run = ansys.parse(job)
    material, _ = ansys_fe.material_of(run, 1.0, 1.0)
    free = stiffness_matrix(Mesh(run.points, run.cells), material, 2)  # what a free run writes
    body = ansys.body_of(job, replace(_with_rigid_modes(run), K=free, constrained=np.zeros_like(run.constrained)))
    assert "K of job.full: the free body's" in body.provenance.notes[3]
    assert np.allclose(body.eigenvalues, example["body"].eigenvalues, rtol=ROUND_OFF)


# ---------------------------------------------------------------- damaged input, the guarded child, limits
RST_FIELDS = {"kan": 112, "nsets": 113, "ptrDSI": 115, "ptrELM": 118, "ptrNOD": 119, "ptrGEO": 120}
FULL_FIELDS = {"neqn": 106, "numdof": 112, "ntermK": 114, "lumpm": 115, "keyuns": 118, "ptrSTF": 123, "ptrMAS": 131}


def _refused(job: Path, name: str) -> str:
    result = runner.invoke(app, ["info", str(job)])
    assert result.exit_code == 2, result.output
    line = result.output.strip()
    assert "\n" not in line and "Traceback" not in line and name in line, line
    return line


@pytest.mark.parametrize("suffix", ["rst", "full"])
def test_truncated_copies_end_in_one_line_naming_the_file(job, suffix):
    path = job.with_suffix(f".{suffix}")
    data = path.read_bytes()
    for length in (0, 400, 50_000, len(data) // 2):
        path.write_bytes(data[:length])
        _refused(job, path.name)


@pytest.mark.parametrize("suffix,fields", [("rst", RST_FIELDS), ("full", FULL_FIELDS)])
def test_bit_flips_in_the_words_that_size_and_locate_the_data_end_in_one_line(job, suffix, fields):
    """A flip in the data themselves is a valid file with other numbers; flips where the header sizes and
    locates them (the record at word 103) must not read as a body."""
    path = job.with_suffix(f".{suffix}")
    data = path.read_bytes()
    for word in fields.values():
        flipped = bytearray(data)
        flipped[4 * word] ^= 1 << 3
        path.write_bytes(bytes(flipped))
        _refused(job, path.name)


def test_a_missing_full_is_refused_by_name(job):
    job.with_suffix(".full").unlink()
    assert "job.rst: .full: expected job.full beside it" in _refused(job, "job.rst")


def test_the_files_are_read_in_the_guarded_child(job, monkeypatch):
    assert guard.FORK
    monkeypatch.setattr(ansys_files, "load_matrices", lambda *a: os.kill(os.getpid(), signal.SIGSEGV))
    line = _refused(job, "job.full")
    assert "crashed reading it (signal 11, SIGSEGV)" in line


def test_the_memory_limit_holds_in_the_reading_child(job):
    result = runner.invoke(app, ["--max-memory", "3M", "info", str(job)])
    assert result.exit_code == 2 and "\n" not in result.output.strip(), result.output
    assert "memory limit of 3 MiB" in result.output


def test_without_the_library_the_reader_says_which_extra_to_install(job, monkeypatch):
    monkeypatch.setitem(sys.modules, "ansys.mapdl.reader", None)
    monkeypatch.delattr(sys.modules["ansys.mapdl"], "reader")
    with pytest.raises(FFRFError) as e:
        read_body(job)
    assert str(e.value) == "the ANSYS reader needs ansys-mapdl-reader: pip install 'ffrf-advisor[ansys]'"
