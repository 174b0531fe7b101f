"""Command-line values coerced without pydantic (cli_params, issue 24 item 5): every parameter of the CLI is
covered, bad values get one line naming the option and the value, good ones arrive typed."""
from __future__ import annotations

from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from ffrf_advisor.cli import app
from ffrf_advisor.cli_params import plain_runtime_param

SAMPLES = Path(__file__).resolve().parent.parent / "sample_bodies"
runner = CliRunner()


def _every_parameter():
    group = typer.main.get_command(app)
    ctx = group.make_context("ffrf-advisor", ["info", "x"], resilient_parsing=True)
    for name in group.list_commands(ctx):
        command = group.get_command(ctx, name)
        yield from ((name, p) for p in (*command.params, command.get_help_option(ctx)))
    yield from (("(group)", p) for p in group.get_params(ctx))


def test_every_parameter_is_coerced_without_pydantic():
    """A new option of a type cli_params does not know would make every command import pydantic again."""
    missing = [f"{name} {p.name}: {p.type_descriptor.annotation}" for name, p in _every_parameter()
               if plain_runtime_param(p) is None]
    assert not missing


@pytest.mark.parametrize("args, message", [
    (["gate", "--max-level", "IV", "--jobs", "0"], "Invalid value for '--jobs' / '-j': 0 is not in the range x>=1."),
    (["gate", "--max-level", "IV", "--jobs", "2.5"], "'2.5' is not a valid integer."),
    (["analyze", "--sigma-allow", "abc"], "Invalid value for '--sigma-allow': 'abc' is not a valid number."),
    (["modes", "--f-max", "-1"], "Invalid value for '--f-max': -1.0 is not in the range x>=0.0."),
])
def test_a_bad_value_is_one_line_naming_option_and_value(args, message):
    command, *options = args
    result = runner.invoke(app, [command, str(SAMPLES / "beam.ffrf.h5"), *options])
    assert result.exit_code == 2
    assert result.stderr.count("\n") == 1 and message in result.stderr, result.stderr


def test_values_arrive_typed():
    """Numbers as numbers of the annotated type; several paths as a list (compare's bodies)."""
    beam, conrod = SAMPLES / "beam.ffrf.h5", SAMPLES / "conrod.ffrf.h5"
    for param_name, value in (("jobs", "3"), ("f_max", "2e3")):
        param = next(p for _, p in _every_parameter() if p.name == param_name)
        coerced = plain_runtime_param(param).coerce(value, param=param, ctx=None)
        assert coerced == float(value) and type(coerced) is param.type_descriptor.annotation
    result = runner.invoke(app, ["compare", str(beam), str(conrod), "--speed", "300rad/s", "--json"])
    assert result.exit_code == 0, result.stderr
    assert '"beam"' in result.stdout and '"conrod"' in result.stdout
