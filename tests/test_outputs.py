"""Nothing the user owns is lost (issue 23): no command writes over a file it reads, whatever --force says;
config files are regular files of at most 1 MiB."""
from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from ffrf_advisor.cli import app

SAMPLE = Path(__file__).resolve().parent.parent / "sample_bodies" / "beam.ffrf.h5"
runner = CliRunner()


@pytest.fixture
def body(tmp_path) -> Path:
    path = tmp_path / "beam.ffrf.h5"
    shutil.copy(SAMPLE, path)
    return path


def _one_line_refusal(result, path) -> None:
    assert result.exit_code == 2, result.output
    assert len(result.output.strip().splitlines()) == 1 and "is an input of this run" in result.output
    assert str(path) in result.output


@pytest.mark.parametrize("command", [
    ["simulate", "{body}", "--t-end", "1e-4", "-o", "{target}", "--force"],
    ["convert", "{body}", "{target}", "--force"],
    ["augment", "{body}", "-o", "{target}", "--force"],
])
def test_no_command_writes_over_its_input_even_with_force(body, tmp_path, command):
    """simulate -o BODY --force replaced the body with a trajectory (a .ffrf.h5 ends in .h5)."""
    before = body.read_bytes()
    link = tmp_path / "same.ffrf.h5"
    os.link(body, link)  # the same file under another name counts too
    for target in (body, link):
        args = [a.format(body=body, target=target) for a in command]
        _one_line_refusal(runner.invoke(app, args), target)
    assert body.read_bytes() == before


def test_a_config_file_that_is_an_input_is_not_written_either(body, tmp_path):
    cfg = tmp_path / "run.h5"
    cfg.write_text("speed = '100rad/s'\n")
    result = runner.invoke(app, ["simulate", str(body), "--t-end", "1e-4", "--config", str(cfg), "-o", str(cfg),
                                 "--force"])
    _one_line_refusal(result, cfg)
    assert cfg.read_text() == "speed = '100rad/s'\n"


@pytest.mark.parametrize("kind", ["fifo", "directory", "device", "big"])
def test_config_files_are_regular_files_of_at_most_one_mebibyte(tmp_path, kind, monkeypatch):
    """--config /dev/zero grew without bound, a FIFO never returned, a FIFO or directory in the working
    directory was silently ignored."""
    path = tmp_path / "ffrf-advisor.toml"
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "directory":
        path.mkdir()
    elif kind == "device":
        path = Path("/dev/zero")
    else:
        path.write_text("# " + "x" * (1 << 20) + "\n")
    for args in (["--config", str(path)], []):
        if not args and kind == "device":
            continue
        monkeypatch.chdir(tmp_path)
        result = runner.invoke(app, ["analyze", str(SAMPLE), *args])
        assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1, result.output
        assert "config" in result.output and ("regular file" in result.output or "1 MiB" in result.output)


@pytest.mark.parametrize("option", [["--rtol", "nan"], ["--rtol", "inf"], ["--rtol", "1e999"], ["--rtol", "-1"],
                                    ["--atol", "nan"], ["--atol", "0"], ["--atol", "-1"], ["--t-end", "1e308"],
                                    ["--damping", "1e308"], ["--damping", "nan"]])
def test_simulate_refuses_parameters_that_make_it_unbounded(option):
    """Each of these ran until killed or raised 'unexpected ValueError' (issue 23, item 6)."""
    args = ["simulate", str(SAMPLE), "--t-end", "1e-3", *option]
    result = runner.invoke(app, args)
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1, result.output
    assert option[0] in result.output


@pytest.mark.parametrize("integrator", ["radau", "bdf", "lsoda", "rk45", "dop853"])
def test_every_documented_adaptive_integrator_runs(integrator):
    """radau was passed to scipy as RADAU and always failed (issue 23, item 12)."""
    result = runner.invoke(app, ["simulate", str(SAMPLE), "--t-end", "2e-4", "--integrator", integrator,
                                 "--q0", "qmax", "--json"])
    assert result.exit_code == 0, result.output


@pytest.mark.parametrize("line", ["sigma_allow = true", "n_ratio = true", "q_cap = false", "tolerance = true",
                                  "f_sys = true"])
def test_config_booleans_are_not_numbers(tmp_path, line):
    """sigma_allow = true was taken as 1 N/mm^2; n_ratio = true ended in 'unexpected TypeError' (issue 23)."""
    cfg = tmp_path / "c.toml"
    cfg.write_text(line + "\n")
    result = runner.invoke(app, ["analyze", str(SAMPLE), "--config", str(cfg)])
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1, result.output
    assert "expected" in result.output and "unexpected" not in result.output


def test_a_long_or_hostile_name_is_cut_and_defused_before_any_layout(tmp_path):
    """A 200,000-character name made convert take 220 s (rich wrapping one unbroken word); a newline or an ANSI
    escape in a file name split or recoloured gate's line (issue 23, items 10 and 14)."""
    import h5py

    from ffrf_advisor.io import h5_checksums
    body = tmp_path / "long.ffrf.h5"
    shutil.copy(SAMPLE, body)
    with h5py.File(body, "r+") as f:
        f.attrs["name"] = "x" * 200_000
        h5_checksums.stamp_cache(f)  # an attribute edited on purpose: its digest made anew
    result = runner.invoke(app, ["convert", str(body), str(tmp_path / "out.ffrf.h5")])
    assert result.exit_code == 0
    assert "(+199800 characters)" in result.output and len(result.output) < 2000
    odd = tmp_path / "a\nb\x1b[31m.ffrf.h5"
    shutil.copy(SAMPLE, odd)
    gate = runner.invoke(app, ["gate", str(odd), "--max-level", "IV", "--speed", "0rad/s"], env={"COLUMNS": "300"})
    assert gate.exit_code == 0 and "\x1b" not in gate.output
    assert len([line for line in gate.output.splitlines() if line.startswith("ok")]) == 1
