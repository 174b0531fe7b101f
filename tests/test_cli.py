"""The command line through typer's runner and as a real process."""
from __future__ import annotations

import copyreg
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import h5py
from typer.testing import CliRunner

from ffrf_advisor import __version__
from ffrf_advisor.body import ModalFE
from ffrf_advisor.cli import app
from ffrf_advisor.errors import BodyFileError, FFRFError
from ffrf_advisor.invariants import shape_integrals
from ffrf_advisor.io import write_body

SAMPLE = Path(__file__).resolve().parent.parent / "sample_bodies" / "beam.ffrf.h5"
runner = CliRunner()


def test_version_and_help():
    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0 and __version__ in result.output
    result = runner.invoke(app, ["--help"])
    assert result.exit_code == 0 and "info" in result.output


def test_info_on_the_shipped_beam():
    result = runner.invoke(app, ["info", str(SAMPLE)], env={"COLUMNS": "160"})
    assert result.exit_code == 0, result.output
    assert "6.280000e-03 t" in result.output  # rho * V = 7.85e-9 * 40 * 20 * 1000
    assert "106.19" in result.output  # first bending frequency
    assert "FAIL" not in result.output


def test_bad_input_is_one_line_with_exit_2(tmp_path):
    junk = tmp_path / "junk.ffrf.h5"
    junk.write_text("not hdf5")
    for target in (junk, tmp_path / "missing.ffrf.h5", tmp_path / "body.xyz"):
        proc = subprocess.run([sys.executable, "-m", "ffrf_advisor", "info", str(target)],
                              capture_output=True, text=True)
        assert proc.returncode == 2
        assert "Traceback" not in proc.stderr
        assert len(proc.stderr.strip().splitlines()) == 1 and str(target) in proc.stderr


def test_unknown_version_through_the_cli(tmp_path):
    path = tmp_path / "beam.ffrf.h5"
    path.write_bytes(SAMPLE.read_bytes())
    with h5py.File(path, "r+") as f:
        f.attrs["version"] = 7
    result = runner.invoke(app, ["info", str(path)])
    assert result.exit_code == 2 and "@version" in result.output


def _foreign_exception(text):  # a reducer's function, as tblib registers for every exception class
    return RuntimeError(text)


def test_reader_errors_survive_a_package_that_registers_reducers_for_exceptions(tmp_path, monkeypatch):
    """Importing Dask distributed installs tblib's reducers for every exception class; the reading child must
    still send errors the parent reads (found when test_verify's distributed sweep ran before this file)."""
    for cls in (ValueError, OSError, KeyError, FFRFError, BodyFileError):
        monkeypatch.setitem(copyreg.dispatch_table, cls, lambda e: (_foreign_exception, (str(e),)))
    test_unknown_version_through_the_cli(tmp_path)


def test_failed_assumptions_are_reported_with_their_caveat(tmp_path, block_body):
    fe = block_body.fe
    Phi = fe.Phi * 1.05
    bad = replace(block_body, integrals=shape_integrals(fe.mesh.points, fe.Ms, Phi),
                  fe=ModalFE(fe.mesh, fe.Ms, Phi, None))
    path = tmp_path / "bad.ffrf.h5"
    write_body(bad, path)
    result = runner.invoke(app, ["info", str(path)], env={"COLUMNS": "200"})
    assert result.exit_code == 0
    text = " ".join(result.output.split())  # however the console wraps it
    assert "FAIL" in text and "mass-normalised modes" in text
    assert "no stiffness matrix" in text


def test_names_and_notes_from_a_file_are_sanitised_and_cut(tmp_path):
    """A body named with a terminal escape and rich markup, with a 100 kB note and 500 notes: info and analyze
    print neither escape nor markup, and a bounded amount of it (the rendering stays fast)."""
    from dataclasses import replace

    from ffrf_advisor.io import read_body, write_body
    body = read_body(SAMPLE)
    evil = replace(body, name="\x1b[31m[bold]evil\x07", provenance=body.provenance.__class__(
        source="x" * 5000, notes=("n" * 100_000,) + tuple(f"note {i}" for i in range(500))))
    path = tmp_path / "evil.ffrf.h5"
    write_body(evil, path)
    for command in ("info", "analyze"):
        result = runner.invoke(app, [command, str(path)], env={"COLUMNS": "100"})
        assert result.exit_code == 0, result.output
        assert "\x1b" not in result.stdout and "\x07" not in result.stdout
        assert "[bold]evil" in result.stdout  # shown literally, not as markup
        assert len(result.stdout) < 60_000
    assert "more notes" in runner.invoke(app, ["info", str(path)]).stdout


def test_formats_are_aligned_and_info_reads_the_com_against_its_round_off():
    text = runner.invoke(app, ["formats"], env={"COLUMNS": "80"}).stdout
    lines = text.split("\n\n")[0].splitlines()  # the formats; then the element types by reader
    assert len({line.index(" read") for line in lines}) == 1, lines  # one column, whatever the suffixes
    assert "SOLID187" in text and "C3D10" in text and max(map(len, text.splitlines())) <= 80
    info = runner.invoke(app, ["info", str(SAMPLE)]).stdout
    com = next(line for line in info.splitlines() if "|CoM| / size" in line)
    assert "round-off" in com and float(com.split("= ")[1].split()[0]) < 1e-12
