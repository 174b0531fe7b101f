"""Hostile option values (issue 23, items 4 and 9, and the property test): any float for any numeric option gives
a valid result without NaN or a one-line error with exit 2, never a traceback, a NaN in JSON or a numpy warning."""
from __future__ import annotations

import json
import math
import os
import shutil
import warnings
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from ffrf_advisor.cli import app
from ffrf_advisor.situation import THRESHOLDS

BEAM = Path(__file__).resolve().parent.parent / "sample_bodies" / "beam.ffrf.h5"
runner = CliRunner()

FLOATS = st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                   st.sampled_from([1e308, -1e308, 5e-324, 2.2e-308, 0.0, -0.0, 1e154, 1e-154]))
OPTIONS = ("--speed", "--sigma-allow", "--q-cap", "--deflection-cap", "--f-sys", "--tolerance", "--q-max")


def _strict(text: str) -> dict:
    """JSON that refuses NaN and infinities (which json.dumps would write as invalid tokens)."""
    def bad(token):
        raise ValueError(f"non-finite number {token} in the JSON")
    return json.loads(text, parse_constant=bad)


def _invoke(args: list[str]):
    """The CLI in-process; a Python warning on the way (numpy, scipy) fails the test: none may reach the user."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = runner.invoke(app, args)
    assert not caught, (args, [str(w.message) for w in caught])
    return result


def _outcome(args: list[str]) -> str:
    result = _invoke(["analyze", str(BEAM), "--rules", "thresholds", *args, "--json"])
    text = result.output
    assert "Traceback" not in text and "Warning" not in text, (args, text[-2000:])
    if result.exit_code == 0:
        _strict(text)
        return "valid"
    assert result.exit_code == 2 and len(text.strip().splitlines()) == 1, (args, result.exit_code, text[-2000:])
    return "error"


def test_a_huge_finite_q_max_is_one_line_naming_the_option():
    """Item 4: --q-max 1e308 for every mode gave 30 RuntimeWarning lines, NaN in the JSON and a rule flipped."""
    result = runner.invoke(app, ["analyze", str(BEAM), "--speed", "30rad/s", "--q-max", ",".join(["1e308"] * 16)])
    assert result.exit_code == 2 and result.output.startswith("error: --q-max: mode 1")
    assert len(result.output.strip().splitlines()) == 1


def test_a_huge_finite_speed_is_one_line_naming_the_option():
    """Item 9: --speed 1e308rad/s gave 'unexpected OverflowError'."""
    result = runner.invoke(app, ["analyze", str(BEAM), "--speed", "1e308rad/s"])
    assert result.exit_code == 2 and result.output.startswith("error: --speed 1e+308 rad/s: expected at most")


@pytest.mark.parametrize("args", [["analyze"], ["analyze", str(BEAM), "--bogus"], ["analyze", str(BEAM), "--n-ratio", "x"],
                                  ["gate", str(BEAM)]])
def test_usage_errors_are_one_line_with_exit_2(args):
    """Item 9: typer's usage errors were three lines and a box."""
    result = runner.invoke(app, args)
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1, result.output
    assert result.output.startswith("error: ") and f"see `ffrf-advisor {args[0]} --help`" in result.output


@pytest.mark.slow  # a minute: a few hundred analyses of the beam
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(option=st.sampled_from(OPTIONS + tuple(f"--threshold {name}" for name in THRESHOLDS)), value=FLOATS)
def test_any_float_for_any_numeric_option_is_a_valid_result_or_one_line(option, value):
    text = repr(value) if math.isfinite(value) else str(value)
    if option == "--q-max":
        args = [option, ",".join([text] * 16)]
    elif option.startswith("--threshold"):
        args = ["--threshold", f"{option.split()[1]}={text}"]
    elif option == "--speed":
        args = [option, f"{text}rad/s"]
    else:
        args = [option, text]
    _outcome(args + (["--speed", "30rad/s"] if option != "--speed" else []))


SIMULATE = ("--damping", "--t-end", "--step", "--rtol", "--atol", "--output-step", "--omega0", "--q0")


@pytest.mark.slow  # a minute: short simulations of the beam
@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(option=st.sampled_from(SIMULATE), value=FLOATS, integrator=st.sampled_from(["dop853", "rk4"]))
def test_any_float_for_any_numeric_simulate_option_is_a_result_or_one_line(option, value, integrator):
    """simulate: a valid run (JSON without NaN), a one-line error (exit 2), or a failed integration said in one
    line (exit 3); never a hang (the work is bounded), a traceback or a numpy warning."""
    text = repr(value) if math.isfinite(value) else str(value)
    text = ",".join([text] * (3 if option == "--omega0" else 16 if option == "--q0" else 1))
    base = {"--t-end": "2e-4", "--step": "1e-6"}
    args = [option, text] + [a for k, v in base.items() if k != option for a in (k, v)]
    result = _invoke(["simulate", str(BEAM), "--integrator", integrator, *args, "--json"])
    out = result.output
    assert "Traceback" not in out and "Warning" not in out, (args, out[-2000:])
    if result.exit_code == 0:
        _strict(out)
    else:
        assert result.exit_code in (2, 3) and len(out.strip().splitlines()) == 1, (args, result.exit_code, out[-2000:])


def _one_line_exit_2(args: list[str], *words: str) -> None:
    result = _invoke([str(a) for a in args])
    lines = result.output.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1 and all(w in lines[0] for w in words), (args, result.output)


@pytest.mark.parametrize("option, text, words", [
    ("--q0", "0.04,0.02", ("--q0", "16 numbers", "got 2")),  # padded with zeros: the deflection bound saw 2 modes
    ("--q0", ",".join(["0.01"] * 17), ("--q0", "16 numbers", "got 17")),
    ("--qd0", "1", ("--qd0", "16 numbers")),
    ("--omega0", "1,2", ("--omega0", "3 numbers", "got 2")),  # was (1, 2, 0)
    ("--omega0", "1,2,3,4", ("--omega0", "3 numbers", "got 4")),
    ("--q0", ",".join(["nan"] * 16), ("--q0", "finite numbers")),
])
def test_option_lists_of_another_length_than_they_describe_are_one_line(tmp_path, option, text, words):
    """A list shorter or longer than the modes (or than three components) is refused in one line, with how
    many it takes, by simulate and export alike (cli._start)."""
    for command in ("simulate", "export"):
        extra = (["--t-end", "1e-4", "--json"] if command == "simulate"
                 else ["-o", tmp_path / "out", "--speed", "30rad/s"])
        _one_line_exit_2([command, BEAM, option, text, *extra], *words)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("value", ["inf", "-inf", "nan", "Infinity"])
def test_non_finite_numbers_are_refused_for_every_float_option(value):
    """--f-max inf wrote Infinity into modes --json and nan was ignored: every float option refuses them at
    parsing (cli_params), before any body is read."""
    _one_line_exit_2(["modes", BEAM, "--speed", "30rad/s", "--f-max", value, "--json"], "--f-max",
                     "expected a finite number")
    _one_line_exit_2(["simulate", BEAM, "--t-end", value], "--t-end", "expected a finite number")


def test_a_config_path_that_is_not_a_regular_file_is_named_in_one_line(tmp_path, monkeypatch):
    """A FIFO named pyproject.toml in the working directory was skipped silently (and opening it would block):
    refused before it is opened, like ffrf-advisor.toml and --config."""
    os.mkfifo(tmp_path / "pyproject.toml")
    monkeypatch.chdir(tmp_path)
    _one_line_exit_2(["analyze", BEAM, "--speed", "30rad/s"], "pyproject.toml", "regular file", "FIFO")


@pytest.mark.skipif(not (hasattr(os, "geteuid") and os.geteuid() == 0 and shutil.which("setpriv")),
                    reason="needs root to run the CLI as another user (root writes in read-only folders)")
@pytest.mark.parametrize("command", ["convert", "export"])
def test_an_unwritable_output_folder_is_named_in_one_line(tmp_path, command):
    """A read-only folder gave "unexpected PermissionError" naming the temporary file: one line naming the folder,
    before the work. Run as user nobody (setpriv), for whom the folder is read-only."""
    import subprocess
    import sys
    import tempfile
    folder = Path(tempfile.mkdtemp(prefix="ffrf-ro-"))
    try:
        folder.chmod(0o555)
        target = folder / ("out.ffrf.h5" if command == "convert" else "exudyn")
        extra = [target] if command == "convert" else ["-o", target, "--speed", "30rad/s"]
        done = subprocess.run(["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups", sys.executable, "-m",
                               "ffrf_advisor", command, BEAM, *map(str, extra)], capture_output=True, text=True,
                              env={**os.environ, "HOME": str(folder)})
        lines = done.stderr.strip().splitlines()
        assert done.returncode == 2 and len(lines) == 1, done.stderr
        assert str(folder) in lines[0] and "may write in" in lines[0] and ".tmp" not in lines[0], lines
    finally:
        folder.chmod(0o755)
        shutil.rmtree(folder)
