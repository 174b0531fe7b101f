"""The ffrf-advisor command line: thin wiring of readers, analyses and reports."""
from __future__ import annotations

import functools
import sys
from pathlib import Path

import typer
from rich.console import Console

from . import __version__
from .checks import run_checks
from .errors import FFRFError
from .io import read_body
from .report.console import body_summary

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="Which FFRF inertia terms does a flexible body need? Advice with evidence.")
out = Console()
err = Console(stderr=True)

EXIT_BAD_INPUT = 2


def handles_errors(fn):
    """Report FFRFError (bad input) as one line on stderr with exit code 2, no traceback."""
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except FFRFError as e:
            err.print(f"error: {e}", markup=False, highlight=False, soft_wrap=True)
            raise typer.Exit(EXIT_BAD_INPUT) from None
    return wrapper


def _version(value: bool):
    if value:
        out.print(f"ffrf-advisor {__version__}")
        raise typer.Exit()


@app.callback()
def main(version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                      help="Print the version and exit.")):
    """ffrf-advisor: guideline advisor for flexible bodies in the floating frame of reference."""


@app.command()
@handles_errors
def info(body: Path = typer.Argument(..., help="Body file (.ffrf.h5).")):
    """Mass, CoM, I0, eigenfrequencies, modal stress and the checks of theory section 4."""
    b = read_body(body)
    body_summary(out, b, run_checks(b))


def run() -> None:  # console-script entry point
    sys.exit(app())
