"""The docs quote the tool as it is now (issue 25): the generated blocks of docs/samples.md and the README's
example are what scripts/make_docs.py would write, and docs/api.md's example prints what the page says.

A failure here means the tool's output changed: run `python scripts/make_docs.py` and read the diff."""
from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
FIX = "docs out of date: run `python scripts/make_docs.py` and check the diff"


def _load_make_docs():
    spec = importlib.util.spec_from_file_location("make_docs", ROOT / "scripts" / "make_docs.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


make_docs = _load_make_docs()


@pytest.fixture(scope="module")
def samples_blocks():
    return make_docs.samples_blocks()


@pytest.mark.parametrize("marker", ["advice", "rules", "stiff"])
def test_samples_md_says_what_the_tool_says_now(samples_blocks, marker):
    assert make_docs.block(make_docs.SAMPLES_MD.read_text(), marker) == samples_blocks[marker], FIX


def test_samples_md_advice_has_one_row_per_shipped_body_with_its_level(samples_blocks):
    rows = [line for line in samples_blocks["advice"].splitlines() if line.startswith("| ") and "---" not in line]
    names = [row.split("|")[1].strip() for row in rows[1:]]
    assert names == list(make_docs.SAMPLES)
    assert all(re.search(r"\| \*\*(I|II|III|IV)\*\* \|", row) for row in rows[1:])
    assert "round-off" not in samples_blocks["rules"] and "e-1" not in samples_blocks["rules"]  # no noise printed


def test_readme_example_is_what_the_tool_prints_now():
    assert make_docs.block(make_docs.README.read_text(), "example") == make_docs.readme_example(), FIX


def test_readme_example_does_not_depend_on_the_callers_terminal(monkeypatch):
    monkeypatch.setenv("COLUMNS", "200")
    monkeypatch.setenv("FORCE_COLOR", "1")
    monkeypatch.setenv("TTY_COMPATIBLE", "1")
    text = make_docs.readme_example()
    assert "\x1b[" not in text
    lines = text.splitlines()
    assert lines[0] == "    $ ffrf-advisor analyze sample_bodies/beam.ffrf.h5 --speed 300rad/s"
    assert lines[1].startswith("    beam: level ") and max(len(line) for line in lines) <= 4 + 80
    assert str(ROOT) not in text
    assert text == make_docs.block(make_docs.README.read_text(), "example")


def test_replace_block_touches_only_its_block():
    text = "a\n<!-- x:start -->\nold\n<!-- x:end -->\nb\n<!-- y:start -->\nkeep\n<!-- y:end -->\n"
    new = make_docs.replace_block(text, "x", "new 1\nnew 2\n")
    assert new == "a\n<!-- x:start -->\nnew 1\nnew 2\n<!-- x:end -->\nb\n<!-- y:start -->\nkeep\n<!-- y:end -->\n"
    assert make_docs.block(new, "x") == "new 1\nnew 2\n" and make_docs.replace_block(new, "x", "old\n") == text
    with pytest.raises(SystemExit):
        make_docs.replace_block(text, "z", "")


def test_api_example_runs_and_prints_what_the_page_says(monkeypatch, capsys):
    page = (ROOT / "docs" / "api.md").read_text()
    code = re.findall(r"```python\n(.*?)```", page, re.S)[0]
    printed = re.findall(r"```text\n(.*?)```", page, re.S)[0]
    monkeypatch.chdir(ROOT)  # the example reads sample_bodies/beam.ffrf.h5 from the repository root
    namespace = {"__name__": "api_example"}
    exec(compile(code, str(ROOT / "docs" / "api.md"), "exec"), namespace)
    assert capsys.readouterr().out == printed
    assert namespace["a"].advice.level == printed.split()[0]
    assert namespace["v"].verdict.verdict == "agree"


def test_elements_md_has_the_table_formats_prints():
    assert make_docs.block(make_docs.ELEMENTS_MD.read_text(), "elements") == make_docs.elements_blocks()["elements"], FIX
