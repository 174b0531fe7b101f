"""Issue 49 in the Nastran reader: mode ids unique and consecutive, the LAMA table's eigenvalues against the
eigenvectors' headers, rigid modes told by their shapes and counted against the model's SPC and SUPORT cards."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from typer.testing import CliRunner

pytest.importorskip("pyNastran", reason="the Nastran reader's optional extra (pip install '.[nastran]')")

from ffrf_advisor.cli import app  # noqa: E402
from ffrf_advisor.errors import FFRFError  # noqa: E402
from ffrf_advisor.fe.modal import rigid_modes  # noqa: E402
from ffrf_advisor.io import nastran, nastran_checks, read_body  # noqa: E402

from .test_nastran import BEAM, MULTI, SAMPLE, _write_op2, needs_data  # noqa: E402


@pytest.fixture(scope="module")
def sample():
    return replace(read_body(SAMPLE, load_fe=True), geometric=None, static_centrifugal=None)


@pytest.fixture
def op2(sample, tmp_path):
    """The sample as a free-free SOL 103 OP2 (six rigid modes, then its modes) and its pyNastran model."""
    n = sample.fe.mesh.n_nodes
    T = np.concatenate([rigid_modes(sample.fe.mesh.points).reshape(n, 3, 6), sample.fe.Phi], axis=2)
    path = tmp_path / "beam.op2"
    _write_op2(path, sample.fe.mesh.points, np.r_[np.zeros(6), sample.eigenvalues], T, body=sample)
    return path, nastran._load(path)


def _lama(ev):
    """A LAMA table as Nastran writes it beside the eigenvectors: the same mode ids and float32 eigenvalues."""
    from pyNastran.op2.tables.lama_eigenvalues.lama_objects import RealEigenvalues

    nm = len(ev.modes)
    table = RealEigenvalues("LAMA", "LAMA", nm)
    table.mode[:] = table.extraction_order[:] = np.arange(1, nm + 1)
    table.eigenvalues[:] = ev.eigns
    table.radians[:] = np.sqrt(np.abs(ev.eigns))
    table.cycles[:] = table.radians / (2 * np.pi)
    table.generalized_mass[:] = 1.0
    return table


def test_the_sample_reads_with_its_six_rigid_modes_named_and_no_warning(op2):
    path, m = op2
    notes = read_body(path).provenance.notes
    assert any("rigid modes (shapes spanned by rigid motions) dropped: 1, 2, 3, 4, 5, 6" in n for n in notes)
    assert not any("warning" in n for n in notes)


@pytest.mark.parametrize("ids", [[1, 2, 2, 4], [1, 2, 4, 5], [2, 3, 4, 5]])
def test_eigenvector_mode_ids_that_repeat_skip_or_start_late_are_refused(op2, ids):
    path, m = op2
    ev = next(iter(m.eigenvectors.values()))
    ev.modes = np.r_[ids, np.arange(5, len(ev.modes) + 1)]  # a damaged key files a mode under another id
    with pytest.raises(FFRFError, match="eigenvector mode ids: expected unique consecutive mode numbers from 1"):
        nastran._modes(path, m)


def test_a_lama_table_agreeing_with_the_headers_reads_and_one_damaged_eigenvalue_is_named(op2):
    path, m = op2
    ev = next(iter(m.eigenvectors.values()))
    m.eigenvalues["LAMA"] = _lama(ev)
    assert nastran._modes(path, m).eigenvalues.size == len(ev.modes)  # copies of one float32 agree
    m.eigenvalues["LAMA"].eigenvalues[9] *= 0.25  # the damage, on one copy
    with pytest.raises(FFRFError, match=r"eigenvalue table \(LAMA\): expected sqrt\(lambda\) / \(2 pi\) of the "
                                        r"eigenvectors' headers.* for mode 10"):
        nastran._modes(path, m)
    for column in ("radians", "cycles"):
        m.eigenvalues["LAMA"] = _lama(ev)
        getattr(m.eigenvalues["LAMA"], column)[12] *= 1.001  # 4th digit: 1e-3, beyond 7 digits (1e-5)
        with pytest.raises(FFRFError, match=rf"eigenvalue table \(LAMA\) {column.upper()}: .* for mode 13"):
            nastran._modes(path, m)
    m.eigenvalues["LAMA"] = _lama(ev)
    m.eigenvalues["LAMA"].mode[3] = 3
    with pytest.raises(FFRFError, match=r"eigenvalue table \(LAMA\) mode ids"):
        nastran._modes(path, m)


def _run(op2):
    path, m = op2
    return path, nastran._modes(path, m)


def test_a_rigid_shape_with_a_frequency_is_refused_not_dropped(op2):
    path, run = _run(op2)
    run.eigenvalues[2] = run.eigenvalues[7]  # mode 3 (a translation) given a flexible mode's eigenvalue
    with pytest.raises(FFRFError, match="DISP: expected a zero frequency for a rigid-body shape, got mode 3"):
        nastran_checks.rigid(path, run)


def test_a_flexible_shape_at_zero_frequency_is_refused_not_dropped_as_rigid(op2):
    """The issue's damaged exponent the other way: an eigenvalue so small the old threshold called its mode rigid."""
    path, run = _run(op2)
    run.eigenvalues[8] *= 1e-80
    with pytest.raises(FFRFError, match="DISP: expected a rigid-body shape at zero frequency .*, got mode 9"):
        nastran_checks.rigid(path, run)


def test_a_free_run_with_five_rigid_modes_is_refused_naming_the_constraints(op2):
    path, run = _run(op2)
    run.T[:, :, 5] = run.T[:, :, 7]  # mode 6's shape replaced by a flexible one, its eigenvalue its own
    run.eigenvalues[5] = run.eigenvalues[7]
    with pytest.raises(FFRFError, match=r"DISP: expected 6 rigid modes \(no SPC, SPC1, SPCADD nor grid PS in the "
                                        r"model: a free run\), got 5 \(modes 1, 2, 3, 4, 5\)"):
        nastran_checks.rigid(path, run)


def test_a_run_whose_suport_gives_three_rigid_modes_is_refused_with_six_and_warned_with_three(op2):
    path, run = _run(op2)
    supported = replace(run, rigid_expected=3, constraints="SPC with SUPORT on 3 DOFs")
    with pytest.raises(FFRFError, match=r"expected 3 rigid modes \(SPC with SUPORT on 3 DOFs\), got 6"):
        nastran_checks.rigid(path, supported)
    three = np.r_[0, 1, 2, 6:len(run.eigenvalues)]  # the run of a body held in rotation: translations stay rigid
    held = replace(supported, eigenvalues=run.eigenvalues[three], T=run.T[:, :, three])
    mask, notes = nastran_checks.rigid(path, held)
    assert mask.sum() == 3 and any(n.startswith("warning: 3 rigid modes instead of six (modes 1, 2, 3)")
                                   for n in notes)


def test_the_constraints_of_a_model_come_from_its_spc_suport_and_grid_ps():
    from pyNastran.bdf.bdf import BDF

    model = BDF(debug=None)
    model.add_grid(1, [0.0, 0.0, 0.0])
    model.add_grid(2, [1.0, 0.0, 0.0])
    assert nastran_checks.constraints(model)[0] == 6
    model.add_suport([2], ["123"])
    assert nastran_checks.constraints(model)[0] == 6  # SUPORT alone: a free body's six rigid modes
    model.add_spc1(1, "456", [1])
    assert nastran_checks.constraints(model) == (3, "SPC with SUPORT on 3 DOFs")
    model.suport = []
    assert nastran_checks.constraints(model)[0] is None  # SPC alone: the count is not known, only warned
    other = BDF(debug=None)
    other.add_grid(1, [0.0, 0.0, 0.0], ps="123")
    assert nastran_checks.constraints(other)[0] is None


@needs_data
@pytest.mark.parametrize("path", [BEAM, MULTI])
def test_nastrans_own_files_have_consecutive_mode_ids_and_agreeing_eigenvalue_copies(path):
    m = nastran._load(path)
    table = next(iter(m.eigenvalues.values()))
    assert table is not None and len(table.mode) == len(next(iter(m.eigenvectors.values())).modes)
    nastran_checks.check_tables(path, next(iter(m.eigenvectors.values())), table)  # raises on a disagreement


def test_a_damaged_mode_id_in_the_file_is_one_line_through_the_cli(op2):
    """Mode 3's id written as 2 into the OP2's eigenvector table (pyNastran's writer keeps the ids given)."""
    path, m = op2
    ev = next(iter(m.eigenvectors.values()))
    ev.modes = np.asarray(ev.modes).copy()
    ev.modes[2] = 2
    m.write_op2(str(path), post=-1, endian=b"<")
    assert list(next(iter(nastran._load(path).eigenvectors.values())).modes[:4]) == [1, 2, 2, 4]
    result = CliRunner().invoke(app, ["info", str(path)])
    assert result.exit_code == 2 and "eigenvector mode ids" in result.output and "1, 2, 2, 4" in result.output
    assert len(result.output.strip().splitlines()) == 1
