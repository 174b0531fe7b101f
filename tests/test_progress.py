"""Progress on stderr (issue 25): drawn on a terminal, silent off one and under --quiet; gate reports each body."""
from __future__ import annotations

import io
from pathlib import Path

from rich.console import Console

from ffrf_advisor.analysis import Options
from ffrf_advisor.gate import run_gate
from ffrf_advisor.report.progress import busy, step_bar

SAMPLES = Path(__file__).resolve().parents[1] / "sample_bodies"


def _console(terminal: bool, quiet: bool = False) -> tuple[Console, io.StringIO]:
    stream = io.StringIO()
    return Console(file=stream, force_terminal=terminal, quiet=quiet, width=80), stream


def test_the_step_bar_is_drawn_on_a_terminal_with_its_label_and_count():
    console, stream = _console(terminal=True)
    with step_bar(console, after_s=0.0) as step:
        step("scene 1", 1, 4)
        step("scene 2", 2, 4)
    assert "scene 2" in stream.getvalue() and "50%" in stream.getvalue()


def test_no_progress_off_a_terminal_or_when_quiet():
    for console, stream in (_console(terminal=False), _console(terminal=True, quiet=True)):
        with step_bar(console, after_s=0.0) as step, busy(console, "writing"):
            assert step is None
        assert stream.getvalue() == ""


def test_gate_reports_each_body_done_out_of_all():
    paths = [str(SAMPLES / f"{n}.ffrf.h5") for n in ("beam", "conrod", "beam")]
    seen = []
    results = run_gate(paths, Options(), "IV", 1, progress=lambda label, done, total: seen.append((label, done,
                                                                                                    total)))
    assert seen == [(p, k + 1, 3) for k, p in enumerate(paths)] and [r["file"] for r in results] == paths
