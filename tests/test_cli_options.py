"""One option set on every command that analyses a body (issue 25): the same names, defaults, types and help;
the same options give the same level in `analyze` and `settings`; -h, --quiet and plain metavars."""
from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
import typer.main
from typer.testing import CliRunner

from ffrf_advisor.cli import app
from ffrf_advisor.cli_options import ANALYSIS_OPTIONS

SAMPLES = Path(__file__).resolve().parent.parent / "sample_bodies"
ANALYSING = ("analyze", "gate", "compare", "settings", "verify", "simulate", "report")
runner = CliRunner()


def _option_set(command: str) -> dict:
    """name -> (flags, default, type, help) of the command's analysis options, as click sees them."""
    group = typer.main.get_command(app)
    params = group.get_command(None, command).params
    return {p.name: (tuple(p.opts + p.secondary_opts), p.default, str(p.type_descriptor.annotation), p.help)
            for p in params if p.name in ANALYSIS_OPTIONS}


def test_every_analysing_command_has_the_same_analysis_options():
    first = _option_set(ANALYSING[0])
    assert set(first) == set(ANALYSIS_OPTIONS)
    for command in ANALYSING[1:]:
        assert _option_set(command) == first, command


def test_settings_and_analyze_give_the_same_level_for_the_same_options():
    """The conrod at 30 rad/s with --sigma-allow 400 (settings could not take the option before)."""
    for extra in ([], ["--sigma-allow", "400"], ["--sigma-allow", "400", "--spin-axis", "2", "--q-cap", "0.5"]):
        args = [str(SAMPLES / "conrod.ffrf.h5"), "--speed", "30rad/s", *extra, "--json"]
        analysed = json.loads(runner.invoke(app, ["analyze", *args]).stdout)
        settings = json.loads(runner.invoke(app, ["settings", *args]).stdout)
        assert (settings["level"], settings["terms"]) == (analysed["level"], analysed["terms"]), extra


@pytest.mark.parametrize("command", ["info", *ANALYSING, "sample", "convert", "augment", "schema"])
def test_h_is_help_and_metavars_are_plain(command):
    result = runner.invoke(app, [command, "-h"], env={"COLUMNS": "100"})
    assert result.exit_code == 0 and result.stdout.startswith(f"Usage: root {command} [OPTIONS]")
    assert not any(mark in result.stdout for mark in ("<str>", "<float>", "<int", "<path>", "<list", "{")), \
        result.stdout
    assert "--quiet" in result.stdout


def test_quiet_silences_notes_but_not_errors():
    args = ["analyze", str(SAMPLES / "beam.ffrf.h5"), "--speed", "300"]
    loud, quiet = runner.invoke(app, args), runner.invoke(app, [*args, "--quiet"])
    assert "note: speed 300 has no unit" in loud.stderr and "note:" not in quiet.stderr
    assert quiet.stdout == loud.stdout and "warning: principal axis 3" in quiet.stderr  # warnings stay, on stderr
    assert loud.stderr.replace(quiet.stderr, "").startswith("note: speed 300 has no unit")
    bad = runner.invoke(app, [*args[:2], "--speed", "fast", "-q"])
    assert bad.exit_code == 2 and bad.stderr.startswith("error: ")


def test_a_config_file_in_the_working_directory_is_named(tmp_path, monkeypatch):
    """Issue 25: an ffrf-advisor.toml beside the user changes the advice; the headline and the JSON say so."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "ffrf-advisor.toml").write_text('speed = "200rad/s"\n')
    args = ["analyze", str(SAMPLES / "conrod.ffrf.h5")]
    text = runner.invoke(app, args, env={"COLUMNS": "200"}).stdout
    assert "200 rad/s" in text and "options from ffrf-advisor.toml" in text
    data = json.loads(runner.invoke(app, [*args, "--json"]).stdout)
    assert data["situation"]["config"] == "ffrf-advisor.toml" and data["decided_by"] in text
    (tmp_path / "ffrf-advisor.toml").unlink()
    assert json.loads(runner.invoke(app, [*args, "--json"]).stdout)["situation"]["config"] is None


@pytest.mark.parametrize("text, found", [
    ('[tool.ffrf-advisor]\nspeed = "200rad/s"\n', {"speed": "200rad/s"}),
    ('[tool."\\u0066frf-advisor"]\nspeed = "200rad/s"\n', {"speed": "200rad/s"}),  # the key through an escape
    ('tool.ffrf-advisor.speed = "200rad/s"\n', {"speed": "200rad/s"}),  # dotted
    ('[tool]\nffrf-advisor = { speed = "200rad/s" }\n', {"speed": "200rad/s"}),
    ('tool = { "ffrf-advisor" = { speed = "200rad/s" } }\n', {"speed": "200rad/s"}),
    ('[ "tool" . \'ffrf-advisor\' ]\nspeed = "200rad/s"\n', {"speed": "200rad/s"}),
    ('[project]\nname = "x"\n', {}),
    ('[project\nname = "ffrf-advisor"  # not TOML, and no table of this tool in it: not parsed\n', {}),
    ('[project]\ndependencies = ["ffrf-advisor"]\n[project.scripts]\nffrf-advisor = "x"\n[tool.pytest]\nx = [\n', {}),
])
def test_a_pyproject_toml_is_parsed_only_where_it_can_hold_the_table(tmp_path, text, found):
    """[tool.ffrf-advisor] of pyproject.toml, however its key is written; a pyproject.toml that cannot hold the
    table (situation.TOOL_TABLE: "ffrf-advisor" elsewhere, other tools' tables) is not parsed; one that can and
    is not TOML is refused."""
    from ffrf_advisor.errors import FFRFError
    from ffrf_advisor.situation import load_config
    (tmp_path / "pyproject.toml").write_text(text)
    assert load_config(cwd=tmp_path)[0] == found
    (tmp_path / "pyproject.toml").write_text("[project\n[tool.ffrf-advisor]\n")
    with pytest.raises(FFRFError, match="expected readable TOML"):
        load_config(cwd=tmp_path)


def test_verify_tells_its_progress_once_per_step_up_to_the_total():
    """The progress of verify (issue 25): every run and study is told once; the count ends at the total."""
    from ffrf_advisor.analysis import Options, analyze
    from ffrf_advisor.guidelines import Situation
    from ffrf_advisor.io import read_body
    from ffrf_advisor.verify.scenes import SceneOptions
    from ffrf_advisor.verify.study import run_study
    a = analyze(read_body(SAMPLES / "conrod.ffrf.h5"), Options(situation=Situation(w_op=30.0)))
    told = []
    run_study(a, ["free-spin"], repeats=1, scene_options=SceneOptions(axis=1), quick=True,
              progress=lambda label, done, total: told.append((label, done, total)))
    totals = {total for *_, total in told}
    assert len(totals) == 1 and [done for _, done, _ in told] == list(range(1, totals.pop() + 1))
    assert told[0][0] == "reference free-spin (axis 1)"


def _numbers(cell: str) -> list[float]:
    return [float(x) for x in cell.split()]


@pytest.mark.parametrize("columns", ["80", pytest.param("120", marks=pytest.mark.slow)])
def test_every_value_stands_under_its_label_at_80_and_120_columns(columns):
    """Issue 25: the compare table and analyze's q_max table read back from the text (COLUMNS=80, 120) give the
    numbers of --json, each under its body and label (3 and 5 significant digits printed: rel 5e-3, 5e-5)."""
    from .text_tables import read_table
    bodies = [str(SAMPLES / f"{n}.ffrf.h5") for n in ("beam", "conrod", "genstruct1", "genstruct2")]
    args = ["compare", *bodies, "--speed", "1rad/s"]
    data = json.loads(runner.invoke(app, [*args, "--json"]).stdout)
    table = {row["quantity"]: row for row in read_table(runner.invoke(app, args, env={"COLUMNS": columns}).stdout,
                                                         "comparison (first")}
    shown = data["shown_modes"]
    for b in data["bodies"]:
        assert _numbers(table["mass [t]"][b["name"]]) == pytest.approx([b["mass"]], rel=5e-3)
        assert _numbers(table["f [Hz]"][b["name"]]) == pytest.approx(b["frequencies"][:shown], rel=5e-3)
        assert _numbers(table["q_max [sqrt(t) mm]"][b["name"]]) == pytest.approx(b["q_max"][:shown], rel=5e-3)
        norms = [b["norms"][k] for k in ("I0", "W1", "W2", "W3")]
        assert _numbers(table["|I0| |W1| |W2| |W3|"][b["name"]]) == pytest.approx(norms, rel=5e-3)
        assert table["level"][b["name"]] == b["level"]
    analyze = ["analyze", bodies[0], "--speed", "300rad/s"]
    amp = json.loads(runner.invoke(app, [*analyze, "--json"]).stdout)["amplitudes"]
    rows = read_table(runner.invoke(app, analyze, env={"COLUMNS": columns}).stdout, "maximum modal coordinates")
    assert [float(r["q_max [sqrt(t) mm]"]) for r in rows] == pytest.approx(amp["q_max"], rel=5e-5)
    assert [r["governs"] for r in rows] == amp["governs"]
    assert [float(r["sigma / sigma_allow"]) for r in rows] == pytest.approx(amp["stress_utilisation"], rel=5e-3)


def test_gate_ends_with_a_summary_line_and_names_the_deciding_rule():
    bodies = [str(SAMPLES / "beam.ffrf.h5"), str(SAMPLES / "conrod.ffrf.h5")]
    result = runner.invoke(app, ["gate", *bodies, "--max-level", "I", "--speed", "300rad/s"], env={"COLUMNS": "200"})
    lines = result.stdout.splitlines()
    assert result.exit_code == 1 and lines[-1] == "gate FAILED: 2 bodies, 0 within level I, 2 above it, 0 unreadable"
    assert sum(line.strip().startswith("decided by: ") for line in lines) == 2 and "warning" not in result.stdout


def test_the_q_max_table_is_stacked_per_mode_where_a_table_does_not_fit():
    """Below the width the columns need (COLUMNS=60), one block per mode: every q_max still printed whole."""
    analyze = ["analyze", str(SAMPLES / "beam.ffrf.h5"), "--speed", "300rad/s"]
    amp = json.loads(runner.invoke(app, [*analyze, "--json"]).stdout)["amplitudes"]
    text = runner.invoke(app, analyze, env={"COLUMNS": "60"}).stdout
    block = text[text.index("maximum modal coordinates"):text.index("significance per axis")]
    assert "┃" not in block and all(f"mode {p + 1}:" in block for p in range(len(amp["q_max"])))
    q_max = re.findall(r"q_max\s+\[sqrt\(t\)\s+mm\]\s+(\S+);", block)
    assert [float(v) for v in q_max] == pytest.approx(amp["q_max"], rel=5e-5)


@pytest.mark.parametrize("columns", ["60", "80"])
def test_each_candidate_set_shows_its_predicted_errors_whole(columns):
    """The candidates of analyze read back from the text give --json's predicted errors (2 significant digits:
    rel 5e-2; inf where JSON has null), each under its set: a table at 80 columns, one block per set at 60,
    where the table's columns no longer fit (no value cut to an ellipsis)."""
    from .text_tables import read_table
    analyze = ["analyze", str(SAMPLES / "beam.ffrf.h5"), "--speed", "300rad/s"]
    sets = {c["label"]: c for c in json.loads(runner.invoke(app, [*analyze, "--json"]).stdout)["candidates"]}
    text = runner.invoke(app, analyze, env={"COLUMNS": columns}).stdout
    title = "predicted response errors per term set"
    if columns == "80":
        shown = {r["set"]: r for r in read_table(text, title)}
    else:
        block = text[text.index(title):text.index("maximum modal coordinates")]
        assert "┃" not in block and "…" not in block
        shown = {m[0]: dict(re.findall(r"(\w+) (\S+?)(?:;|$)", " ".join(m[1].split())))
                 for m in re.findall(r"^set (\S+):\n((?: {4}.*\n)+)", block, re.M)}
    assert set(shown) == set(sets)
    for label, c in sets.items():
        for kind, value in c["errors"].items():
            assert float(shown[label][kind]) == (pytest.approx(value, rel=5e-2, abs=1e-300) if value is not None
                                                 else float("inf"))
        assert shown[label]["ok"].startswith("yes" if c["adequate"] else "no")


@pytest.mark.parametrize("command", [["info"], ["analyze", "--speed", "3000rpm"]])
def test_no_value_is_cut_at_60_columns(command):
    """Every table of info and analyze (modes, checks, candidates, q_max, significance, magnitudes, basis) is
    a table where it fits and one block per row where it does not: no line beyond the width, no value cut to an
    ellipsis (rich cut the carbody's dI_L to '3.277e-…' and a check's name at 60 columns)."""
    from .text_tables import fits
    text = runner.invoke(app, [command[0], str(SAMPLES / "carbody.ffrf.h5"), *command[1:]],
                         env={"COLUMNS": "60"}).stdout
    assert fits(text, 60)
    assert "free_surface_translation" in text or command[0] != "info"


def test_compare_folds_a_long_quantity_label_at_60_columns():
    """Four bodies at 60 columns: the quantity labels fold inside their cell (rich cut 'centrifugal ratio' to
    'centrifu…'), no line beyond the width."""
    from .text_tables import fits
    bodies = [str(SAMPLES / f"{n}.ffrf.h5") for n in ("beam", "plate", "conrod", "carbody")]
    text = runner.invoke(app, ["compare", *bodies, "--speed", "1rad/s"], env={"COLUMNS": "60"}).stdout
    assert fits(text, 60)
