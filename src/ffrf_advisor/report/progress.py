"""Live progress on the terminal: a transient bar for long runs (simulations, verification, gate over many
bodies) and a spinner for one long step; nothing off a terminal or under --quiet. Light to import (rich's
console only, its progress columns when a bar is drawn): a command shows its bar before it imports what it
runs."""
from __future__ import annotations

import time
from contextlib import contextmanager
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rich.console import Console


@contextmanager
def _live_bar(console: Console, after_s: float):
    """``update(completed, total, label)`` drawing a transient bar with the time remaining on ``console`` once a
    run has taken ``after_s``; None off a terminal and under --quiet (a quiet console)."""
    if not console.is_terminal or console.quiet:
        yield None
        return
    start, bar, task = time.perf_counter(), None, None

    def update(completed: float, total: float, label: str) -> None:
        nonlocal bar, task
        if bar is None and time.perf_counter() - start > after_s:
            from rich.progress import BarColumn, Progress, TaskProgressColumn, TextColumn, TimeRemainingColumn
            bar = Progress(TextColumn("{task.description}"), BarColumn(), TaskProgressColumn(),
                           TimeRemainingColumn(), console=console, transient=True)
            bar.start()
            task = bar.add_task(label, total=total)
        if bar is not None:
            bar.update(task, completed=completed, total=total, description=label)

    try:
        yield update
    finally:
        if bar is not None:
            bar.stop()


@contextmanager
def busy(console: Console, label: str):
    """A transient spinner with ``label`` on ``console`` while a single long step runs (writing a report); none
    off a terminal and under --quiet."""
    if not console.is_terminal or console.quiet:
        yield
        return
    with console.status(label):
        yield


@contextmanager
def progress_bar(console: Console, after_s: float = 1.0):
    """A callback ``progress(fraction)`` of a simulation (``_live_bar``), or None."""
    with _live_bar(console, after_s) as update:
        yield None if update is None else (lambda fraction: update(fraction, 1.0, "simulating"))


@contextmanager
def step_bar(console: Console, after_s: float = 1.0):
    """A callback ``step(label, done, total)`` for the steps of a verification and its figures (``_live_bar``;
    the label names the step just finished), or None."""
    with _live_bar(console, after_s) as update:
        yield None if update is None else (lambda label, done, total: update(done, total, label))
