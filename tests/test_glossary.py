"""`explain`'s glossary is theory.md's, shipped in the package (issue 51): every term id, level and printed
quantity the tool names has an entry."""
from __future__ import annotations

import pytest

from ffrf_advisor import glossary
from ffrf_advisor.terms import IDS, LEVEL_SETS


@pytest.mark.parametrize("name", [*IDS, *LEVEL_SETS, "q_max", "s_crit", "dI_L", "dI_Tf", "W3", "r_cf2", "verdict"])
def test_every_name_the_tool_prints_is_explained(name):
    found = glossary.lookup(name)
    assert found and all(name in e.names or name.upper() in e.names for e in found)
    assert all(len(e.text().splitlines()) >= 2 for e in found)  # the name and at least one definition


def test_the_term_entry_says_what_the_term_is():
    (entry,) = glossary.lookup("cf2")
    assert entry.table == "term ids" and "W2" in entry.text() and "negative stiffness" in entry.text()


def test_an_unknown_name_has_no_entry():
    assert glossary.lookup("gyro9") == [] and "gyro0" in glossary.known_names()


def test_the_shipped_theory_is_the_docs_page():
    from pathlib import Path
    docs = Path(__file__).resolve().parents[1] / "docs" / "theory.md"
    assert docs.read_text(encoding="utf-8") == glossary.theory_text()


def test_explain_prints_the_entry_and_refuses_an_unknown_name_in_one_line():
    from typer.testing import CliRunner

    from ffrf_advisor.cli import app
    runner = CliRunner()
    shown = runner.invoke(app, ["explain", "cor_coupling"], env={"COLUMNS": "200"})
    assert shown.exit_code == 0 and "W3" in shown.stdout and "Glossary: term ids" in shown.stdout
    unknown = runner.invoke(app, ["explain", "gyro9"])
    assert unknown.exit_code == 2 and len(unknown.output.strip().splitlines()) == 1
    listed = runner.invoke(app, ["explain"]).stdout
    assert "q_max" in listed and "gyro0" in listed and "..." not in listed
