"""Issue 49 in the ANSYS reader: result sets' mode numbers unique and consecutive in the set table and the solution
headers, each set's TIMFRQ against the time table, rigid modes told by their shapes and counted against the .full's
D constraints. The example is ansys-mapdl-reader's (tests/test_ansys.py)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

reader = pytest.importorskip("ansys.mapdl.reader", reason="the ANSYS reader's optional extra (pip install '.[ansys]')")

from ffrf_advisor.errors import BodyFileError  # noqa: E402
from ffrf_advisor.fe.mesh import Mesh  # noqa: E402
from ffrf_advisor.fe.assembly import stiffness_matrix  # noqa: E402
from ffrf_advisor.io import ansys, ansys_fe, ansys_files  # noqa: E402

from .test_ansys import _with_rigid_modes, job  # noqa: E402,F401  (job: the fixture)


@pytest.fixture
def result(job):  # noqa: F811
    r = reader.read_binary(str(job))
    return job, r, np.asarray(r.time_values, float)


def test_the_examples_sets_pass(result):
    ansys_files.check_sets(*result)


@pytest.mark.parametrize("substeps", [[1, 2, 2, 4, 5, 6], [1, 2, 3, 5, 6, 7], [2, 3, 4, 5, 6, 7]])
def test_a_set_table_that_files_a_mode_under_another_number_is_refused(result, substeps):
    rst, r, f = result
    r._resultheader["ls_table"] = np.column_stack([np.ones(6, int), substeps, substeps])
    with pytest.raises(BodyFileError, match=r"result set table \(substeps: mode numbers\): expected unique "
                                            "consecutive mode numbers from 1"):
        ansys_files.check_sets(rst, r, f)


def test_a_solution_header_with_another_mode_number_is_refused(result, monkeypatch):
    rst, r, f = result
    header = r._solution_header
    monkeypatch.setattr(r, "_solution_header", lambda i: {**header(i), "iter": 3 if i == 3 else header(i)["iter"]})
    with pytest.raises(BodyFileError, match=r"solution headers \(substeps: mode numbers\)"):
        ansys_files.check_sets(rst, r, f)


def test_a_solution_headers_frequency_other_than_the_time_tables_is_named(result, monkeypatch):
    rst, r, f = result
    info = r.solution_info
    monkeypatch.setattr(r, "solution_info", lambda i: {**info(i), "timfrq": info(i)["timfrq"] * (2 if i == 4 else 1)})
    with pytest.raises(BodyFileError, match=r"solution headers TIMFRQ: expected .* of the time table's frequencies, "
                                            r"17285\.7 Hz for mode 5, got 34571\.41 Hz"):
        ansys_files.check_sets(rst, r, f)


def test_the_example_warns_that_its_run_has_no_rigid_mode_where_the_full_holds_dofs(job):  # noqa: F811
    notes = ansys.read(job).provenance.notes
    assert "rigid modes (shapes spanned by rigid motions) dropped: none (63 DOFs held by D in job.full)" in notes
    assert "warning: 0 rigid modes instead of six (modes none): the run is constrained" in notes


@pytest.fixture
def free_run(job):  # noqa: F811
    """The example as a free run: the free K, no DOF held, the six rigid modes first."""
    run = ansys.parse(job)
    material, _ = ansys_fe.material_of(run, 1.0, 1.0)
    free = stiffness_matrix(Mesh(run.points, run.cells), material, 2)
    return job, replace(_with_rigid_modes(run), K=free, constrained=np.zeros_like(run.constrained))


def test_a_free_run_drops_its_six_rigid_modes_by_name_without_a_warning(free_run):
    job, run = free_run
    notes = ansys.body_of(job, run).provenance.notes
    assert any(n.startswith("rigid modes (shapes spanned by rigid motions) dropped: 1, 2, 3, 4, 5, 6") for n in notes)
    assert not any("warning" in n for n in notes)


def test_a_free_run_without_its_rigid_modes_is_refused(free_run):
    job, run = free_run
    keep = np.r_[0:5, 6:len(run.eigenvalues)]
    cut = replace(run, eigenvalues=run.eigenvalues[keep], modes=run.modes[:, :, keep],
                  corner_stress={t: s[..., keep] for t, s in run.corner_stress.items()})
    with pytest.raises(BodyFileError, match=r"NSL \(mode shapes\): expected 6 rigid modes \(no DOF held in job\.full: "
                                            r"a free run\), got 5"):
        ansys.body_of(job, cut)


def test_a_flexible_mode_at_zero_frequency_is_refused_not_dropped_as_rigid(free_run):
    """The issue's damaged exponent: an eigenvalue so small the old threshold dropped its mode as rigid, silently."""
    job, run = free_run
    run.eigenvalues[8] *= 1e-80
    with pytest.raises(BodyFileError, match=r"NSL \(mode shapes\): expected a rigid-body shape at zero frequency .*"
                                            "got mode 9"):
        ansys.body_of(job, run)


def test_a_rigid_shape_with_a_frequency_is_refused(free_run):
    job, run = free_run
    run.eigenvalues[0] = run.eigenvalues[6]
    with pytest.raises(BodyFileError, match=r"expected a zero frequency for a rigid-body shape, got mode 1"):
        ansys.body_of(job, run)


def test_a_damaged_mode_number_in_the_files_solution_header_is_one_line_through_the_cli(job):  # noqa: F811
    """Set 4's solution header says substep 3: word 7 of its record (2 words of record header, then pv3num,
    nelm, nnod, mask, itime, iter), at the set's pointer of the result header."""
    from typer.testing import CliRunner

    from ffrf_advisor.cli import app

    word = 4 * (int(reader.read_binary(str(job))._resultheader["rpointers"][3]) + 7)
    data = bytearray(job.read_bytes())
    assert int.from_bytes(data[word:word + 4], "little") == 4
    data[word:word + 4] = (3).to_bytes(4, "little")
    job.write_bytes(bytes(data))
    result = CliRunner().invoke(app, ["info", str(job)])
    assert result.exit_code == 2 and "solution headers (substeps: mode numbers)" in result.output
    assert "1, 2, 3, 3, 5, 6" in result.output and len(result.output.strip().splitlines()) == 1
