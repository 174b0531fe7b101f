"""Bodies must be physically possible, cached or not (issue 23, item 3): positive mass, I0 positive definite
with the triangle inequality of its principal moments, a cache that agrees with the nodal data."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from ffrf_advisor.cli import app
from ffrf_advisor.io import h5_checksums
from ffrf_advisor.io import read_body, write_body

SAMPLE = Path(__file__).resolve().parent.parent / "sample_bodies" / "beam.ffrf.h5"
runner = CliRunner()


def _one_line(result, field: str) -> None:
    """Exit 2 and one line naming the field (gate: one ERROR line per body below its operating point)."""
    assert result.exit_code == 2, result.output
    text = " ".join(result.output.split())
    assert field in text and "Traceback" not in text
    if not result.output.startswith("operating point"):
        assert len(result.output.strip().splitlines()) == 1, result.output


@pytest.fixture
def beam(tmp_path) -> Path:
    path = tmp_path / "beam.ffrf.h5"
    shutil.copy(SAMPLE, path)
    return path


def test_an_indefinite_cached_inertia_is_refused_by_every_command(beam):
    """A cached invariants/I of diag(1, -5, 1) was what info printed while analyze recomputed from the nodes."""
    with h5py.File(beam, "r+") as f:
        I = f["invariants/I"][...]
        f["invariants/I"][...] = np.diag([1.0, -5.0, 1.0]) * np.abs(I).max()
    for command in (["info"], ["analyze"], ["gate", "--max-level", "IV", "--speed", "0rad/s"], ["compare"]):
        _one_line(runner.invoke(app, [command[0], str(beam), *command[1:]]), "invariants")


def test_a_cache_that_disagrees_with_the_nodal_data_is_an_error(beam, tmp_path):
    """Wherever the nodal data are read: by convert, and by analyze of a file without its nodal summary (it
    streams them). With both caches analyze and info read neither (issue 24, item 3): the cache alone is a
    possible body."""
    with h5py.File(beam, "r+") as f:
        f["invariants/I"][...] *= 1.01  # still a possible body, but not this mesh's
    for command in ("info", "analyze"):  # the cache's own checksum (format 4) catches the edit
        _one_line(runner.invoke(app, [command, str(beam)]), "invariants_sha256")
    with h5py.File(beam, "r+") as f:
        h5_checksums.stamp_cache(f)  # a cache written with its checksums, yet not from this mesh
    _one_line(runner.invoke(app, ["convert", str(beam), str(tmp_path / "out.ffrf.h5")]), "invariants/I")
    assert runner.invoke(app, ["info", str(beam)]).exit_code == 0
    assert runner.invoke(app, ["analyze", str(beam)]).exit_code == 0
    with h5py.File(beam, "r+") as f:
        del f["nodal_summary"]
    _one_line(runner.invoke(app, ["analyze", str(beam)]), "invariants/I")


@pytest.mark.parametrize("I7", [[1.0, -5.0, 1.0], [1.0, 1.0, 3.0], [0.0, 1.0, 1.0]])
def test_an_invariants_file_with_an_impossible_I7_is_refused(tmp_path, I7):
    """I7 = diag(1, -5, 1) passed gate --max-level I; (1, 1, 3) breaks the triangle inequality, (0, 1, 1) is a
    line of point masses (no body)."""
    body = read_body(SAMPLE)
    path = tmp_path / "b.ffinv.json"
    write_body(body, path)
    doc = json.loads(path.read_text())
    scale = np.trace(np.asarray(doc["I7"], float)) / 3
    doc["I7"] = (np.diag(I7) * scale).tolist()
    doc["I2"] = [0.0, 0.0, 0.0]  # about the CoM: I0 = I7
    path.write_text(json.dumps(doc))
    _one_line(runner.invoke(app, ["gate", str(path), "--max-level", "I", "--speed", "0rad/s"]), "I")


def test_a_thin_plate_on_the_triangle_inequality_is_possible():
    """I3 = I1 + I2 holds for a plate to its rounding: the tolerance lets it through."""
    assert runner.invoke(app, ["info", str(SAMPLE.parent / "plate.ffrf.h5")]).exit_code == 0


def _without_cache(f) -> None:
    for name in ("geometric_stiffness", "invariants", "static_centrifugal"):
        del f[name]


def test_a_body_without_modes_is_one_line_naming_the_eigenvalues(beam):
    """Item 9: a body with 0 modes gave ZeroDivisionError."""
    with h5py.File(beam, "r+") as f:
        _without_cache(f)
        del f["stress"]
        Phi = f["modes/Phi"][:, :, :0]
        del f["modes/Phi"], f["modes/eigenvalues"]
        f["modes/Phi"], f["modes/eigenvalues"] = Phi, np.zeros(0)
    _one_line(runner.invoke(app, ["analyze", str(beam)]), "modes/eigenvalues: expected at least one flexible mode")


@pytest.mark.parametrize("values, said", [(5e-324 * np.arange(1, 17), "from 1e-150"),
                                          (np.r_[1e-12, np.full(15, 1e4)], "a nearly rigid mode")])
def test_denormal_and_nearly_rigid_eigenvalues_are_refused(beam, values, said):
    """Item 9: denormal eigenvalues ended in an overflow far from the file; a mode 1e-16 of the largest
    eigenvalue is a rigid mode (as the Nastran reader separates them, 1e-10), not a flexible one."""
    with h5py.File(beam, "r+") as f:
        _without_cache(f)
        f["modes/eigenvalues"][...] = values
        h5_checksums.stamp_cache(f)  # written with its checksums: the eigenvalues' own check is under test
    _one_line(runner.invoke(app, ["analyze", str(beam)]), said)


def test_a_native_body_in_its_mesh_frame_is_transformed_by_convert(tmp_path):
    """Item 17: an .ffrf.h5 written in its mesh frame (CoM at a corner, axes turned) fails com_offset and
    principal_axes; the warning names the fix, and `convert --transform` moves the frame to the CoM and the
    principal axes: the checks pass, the frequencies and principal moments stay (to round-off)."""
    from dataclasses import replace

    from ffrf_advisor.checks import run_checks
    from ffrf_advisor.fe_body import modal_body
    from ffrf_advisor.fe.material import STEEL
    from ffrf_advisor.fe.mesh import box_mesh

    body = modal_body(box_mesh([60.0, 20.0, 10.0], [3, 1, 1], "hexahedron20"), STEEL, 4, name="small")
    t = 0.3
    R = np.array([[np.cos(t), 0, np.sin(t)], [0, 1, 0], [-np.sin(t), 0, np.cos(t)]])
    fe = body.fe.transformed(np.array([30.0, 10.0, 5.0]), R)
    skewed = replace(body, fe=fe, integrals=fe.integrals(), static_centrifugal=None, geometric=None)
    path, out = tmp_path / "mesh_frame.ffrf.h5", tmp_path / "principal.ffrf.h5"
    write_body(skewed, path)
    failed = {c.name for c in run_checks(read_body(path)) if not c.passed}
    assert failed == {"com_offset", "principal_axes"}
    info = runner.invoke(app, ["info", str(path)])
    assert "convert BODY OUT --transform" in " ".join(info.output.split())
    assert runner.invoke(app, ["convert", str(path), str(out), "--transform"]).exit_code == 0
    moved = read_body(out)
    assert all(c.passed for c in run_checks(moved))
    assert np.allclose(moved.eigenvalues, body.eigenvalues, rtol=1e-12)
    assert np.allclose(np.linalg.eigvalsh(moved.I0), np.linalg.eigvalsh(body.I0), rtol=1e-10)
    assert any("transformed from the file's frame" in n for n in moved.provenance.notes)
