"""Hostile surroundings counted (issue 23, "fuzzing that would have caught these"): every command that reads
a config file against config files that are devices, FIFOs, directories, links, huge or garbage; every writer
against targets that are its inputs (by name, hard link, symbolic link, another spelling) or not regular
files. Each run's outcome is counted (valid result, one-line error, multi-line message, traceback, hang); only
the first two pass, and nothing the user owns changes.
"""
from __future__ import annotations

import os
import shutil
import signal
from collections import Counter
from pathlib import Path

import pytest
from typer.testing import CliRunner

from ffrf_advisor.cli import app

SAMPLES = Path(__file__).resolve().parent.parent / "sample_bodies"
CASE_SECONDS = 60
runner = CliRunner()


class Hang(BaseException):
    """A run past CASE_SECONDS (a FIFO opened for reading blocks until a writer comes)."""


def _alarm(*_):
    raise Hang


def outcome(args: list[str]) -> str:
    """One CLI run, in this process, classified."""
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(CASE_SECONDS)
    try:
        result = runner.invoke(app, [str(a) for a in args])
    except Hang:
        return "hang"
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    lines = result.output.strip().splitlines()
    if result.exception is not None and not isinstance(result.exception, SystemExit) or "Traceback" in result.output:
        return "traceback"
    if result.exit_code == 0:
        return "valid"
    return "one_line_error" if result.exit_code == 2 and len(lines) == 1 else "multi_line"


def _configs(d: Path) -> dict[str, Path]:
    """Config files no user means: each kind of non-regular file, a huge one, garbage, hostile values."""
    made = {"fifo": d / "fifo.toml", "directory": d / "dir.toml", "big": d / "big.toml", "binary": d / "bin.toml",
            "nested": d / "nested.toml", "nan": d / "nan.toml", "huge": d / "huge.toml", "types": d / "types.toml",
            "link_to_fifo": d / "link.toml", "dangling": d / "dangling.toml"}
    os.mkfifo(made["fifo"])
    made["directory"].mkdir()
    made["big"].write_text("# " + "x" * (1 << 20) + "\n")
    made["binary"].write_bytes(bytes(range(256)) * 8)
    made["nested"].write_text("a = " + "[" * 5000 + "]" * 5000 + "\n")
    made["nan"].write_text("speed = 'nan rad/s'\nq_cap = nan\nsigma_allow = inf\n")
    made["huge"].write_text("speed = '1e308rad/s'\nq_cap = 1e308\ntolerance = 1e-320\n")
    made["types"].write_text("speed = true\nconnection = 3\nn_ratio = [1, 2]\nthreshold = {x = 1}\n")
    made["link_to_fifo"].symlink_to(made["fifo"])
    made["dangling"].symlink_to(d / "missing.toml")
    return {**made, "dev_zero": Path("/dev/zero"), "dev_null": Path("/dev/null")}


@pytest.mark.slow
def test_every_config_reading_command_against_hostile_config_files(tmp_path):
    body = tmp_path / "conrod.ffrf.h5"
    shutil.copy(SAMPLES / "conrod.ffrf.h5", body)
    before = body.read_bytes()
    commands = [["analyze", body, "--speed", "30rad/s"], ["gate", body, "--max-level", "IV", "--speed", "0"],
                ["compare", body, body, "--speed", "30rad/s"], ["settings", body, "--speed", "30rad/s"],
                ["simulate", body, "--t-end", "1e-4"]]
    counts, failed = Counter(), []
    for kind, config in _configs(tmp_path).items():
        for command in commands:
            got = outcome([*command, "--config", config])
            counts[got] += 1
            if got not in ("valid", "one_line_error"):
                failed.append((kind, command[0], got))
    assert not failed and counts["one_line_error"] >= 8 * len(commands), (failed, counts)
    assert body.read_bytes() == before


def _targets(d: Path, body: Path, config: Path) -> dict[str, Path]:
    """Output targets that are an input of the run or not a regular file."""
    made = {"hard_link": d / "hard.ffrf.h5", "symlink": d / "sym.ffrf.h5", "fifo": d / "fifo.h5",
            "directory": d / "dir.h5", "missing_dir": d / "no" / "out.h5"}
    os.link(body, made["hard_link"])
    made["symlink"].symlink_to(body)
    os.mkfifo(made["fifo"])
    made["directory"].mkdir()
    return {**made, "body": body, "respelt": d / "." / ".." / d.name / body.name, "config": config,
            "dev_null": Path("/dev/null")}


@pytest.mark.slow
def test_every_writer_against_targets_that_are_inputs_or_not_files(tmp_path):
    body, config = tmp_path / "beam.ffrf.h5", tmp_path / "run.toml"
    shutil.copy(SAMPLES / "beam.ffrf.h5", body)
    config.write_text("speed = '100rad/s'\n")
    owned = {p: p.read_bytes() for p in (body, config)}
    writers = [["simulate", body, "--t-end", "1e-4", "--config", config, "-o", "{t}", "--force"],
               ["convert", body, "{t}", "--force"],
               ["augment", body, "-o", "{t}", "--force"],
               ["report", body, "--config", config, "-o", "{t}", "--force"],
               ["gate", body, "--max-level", "IV", "--config", config, "--junit", "{t}"],
               ["sample", "beam", "-o", "{t}", "--force"]]
    counts, failed = Counter(), []
    for kind, target in _targets(tmp_path, body, config).items():
        for writer in writers:
            inputs = [a for a in writer[1:] if isinstance(a, Path)]
            if kind in ("body", "hard_link", "respelt", "config") and (config if kind == "config" else body) not in inputs:
                continue  # not an input of this command: --force may replace it (sample reads no body)
            got = outcome([str(a).replace("{t}", str(target)) for a in writer])
            counts[got] += 1
            if got != "one_line_error":  # every one of these targets must be refused
                failed.append((kind, writer[0], got))
    assert not failed, (failed, counts)
    assert all(p.read_bytes() == data for p, data in owned.items())
    assert (tmp_path / "fifo.h5").is_fifo() and (tmp_path / "dir.h5").is_dir() and not list(tmp_path.glob(".*tmp"))
