"""The theory ships with the tool (issue 51, part 2): every "theory N" in src/, README.md and docs/ names a heading
of docs/theory.md, every "NAME.md section N" a heading of that page in docs/, and nothing cites a path outside
the project. docs/theory.md's glossaries say what the code says (term ids, levels, printed measures).

Reference forms read: "theory 7", "theory section 3b", "theory sections 5, 8 and 10", "theory 2-4" (each number
of the range), "theory 4.1", a "#" or a line break between the words, any case."""
from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from ffrf_advisor.predict import TERM_LEVEL
from ffrf_advisor.terms import FULL, IDS, LEVEL_SETS

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
THEORY = DOCS / "theory.md"
SCHEMAS = ROOT / "src" / "ffrf_advisor" / "schemas"
CONTRACT = [str(n) for n in range(1, 13)] + ["3b"]  # the section numbers the existing references rely on

NUMBER = r"\d+[a-z]?(?:\.\d+)*"
LIST = rf"{NUMBER}(?:\s*(?:,|-|–|\band\b|\bor\b|&)\s*{NUMBER})*"
THEORY_REF = re.compile(rf"\btheory(?:[\s#*]+sections?)?[\s#]+({LIST})", re.I)
PAGE_REF = re.compile(rf"\b([\w-]+)\.md(?:'s)?,?\s+sections?\s+({LIST})", re.I)
HEADING = re.compile(r"^(#{1,6})\s+(.+?)\s*$", re.M)
OUTSIDE = re.compile(r"\.\./shared|(?<![\w.~-])/(?:work|home|root|Users)/")
AREAS = ("src", "docs", "README.md")


def numbers(listed: str) -> list[str]:
    """The section numbers of a reference's list: "5, 8 and 10" -> 5, 8, 10; "2-4" -> 2, 3, 4."""
    out = []
    for part in re.split(r"\s*(?:,|\band\b|\bor\b|&)\s*", listed.strip()):
        ends = re.split(r"\s*[-–]\s*", part)
        if len(ends) == 2 and all(e.isdigit() for e in ends):
            out += [str(n) for n in range(int(ends[0]), int(ends[1]) + 1)]
        else:
            out += ends
    return out


def heading_numbers(page: Path) -> set[str]:
    """The numbers that open the headings of a markdown page ("## 7. Title" -> 7, "### 3b. Title" -> 3b)."""
    found = (re.match(rf"({NUMBER})\.?\s", title) for _, title in HEADING.findall(page.read_text()))
    return {m.group(1) for m in found if m}


def text_files(area: str) -> list[Path]:
    """The text files of an area: README.md, or every file under src/ or docs/ that decodes as UTF-8 and holds
    no NUL byte (build and cache folders left out)."""
    top = ROOT / area
    paths = [top] if top.is_file() else sorted(p for p in top.rglob("*") if p.is_file())
    out = []
    for p in paths:
        if "__pycache__" in p.parts or any(part.endswith(".egg-info") for part in p.parts):
            continue
        data = p.read_bytes()
        try:
            data.decode("utf-8")
        except UnicodeDecodeError:
            continue
        if b"\0" not in data:
            out.append(p)
    return out


def unresolved(text: str, where: str) -> list[str]:
    """Every theory or page reference in ``text`` that names no heading, as 'where:line: reference'."""
    theory = heading_numbers(THEORY)
    bad = []
    for m in THEORY_REF.finditer(text):
        line = f"{where}:{text.count(chr(10), 0, m.start()) + 1}: {m.group(0)!r}"
        bad += [f"{line} (no section {n} in docs/theory.md)" for n in numbers(m.group(1)) if n not in theory]
    for m in PAGE_REF.finditer(text):
        page = DOCS / f"{m.group(1)}.md"
        line = f"{where}:{text.count(chr(10), 0, m.start()) + 1}: {m.group(0)!r}"
        if not page.is_file():
            bad.append(f"{line} (docs/ has no {page.name})")
            continue
        have = heading_numbers(page)
        bad += [f"{line} (no section {n} in docs/{page.name})" for n in numbers(m.group(2)) if n not in have]
    return bad


# ------------------------------------------------------------------ the helpers can fail
def test_every_reference_form_is_read():
    text = "see theory sections 5-7 and 3b;\n# theory\n# 12, docs/x.md; Theory section 4. theory.md, section 9"
    assert [n for m in THEORY_REF.finditer(text) for n in numbers(m.group(1))] == ["5", "6", "7", "3b", "12", "4"]
    assert [(m.group(1), numbers(m.group(2))) for m in PAGE_REF.finditer(text)] == [("theory", ["9"])]


def test_a_missing_section_a_missing_page_and_an_outside_path_are_found():
    bad = unresolved("as theory 13 says (theory sections 2, 14); nowhere.md section 1; theory.md section 3c", "x")
    assert len(bad) == 4, bad
    assert "x:1: 'theory 13'" in bad[0] and "section 14" in bad[1] and "no nowhere.md" in bad[2]
    assert "no section 3c" in bad[3]
    assert OUTSIDE.search("(../shared/theory.md)") and OUTSIDE.search("see /work/shared/seeds")
    assert not OUTSIDE.search("docs/theory.md, https://example.org/work/x and ~/work/y")


# ------------------------------------------------------------------ the page itself
def test_theory_keeps_the_contract_numbering_and_unique_headings():
    titles = [title for _, title in HEADING.findall(THEORY.read_text())]
    assert set(CONTRACT) <= heading_numbers(THEORY), sorted(set(CONTRACT) - heading_numbers(THEORY))
    assert len(titles) == len(set(titles)), "MkDocs anchors need unique headings"


def test_theory_cites_the_three_papers_in_full():
    refs = THEORY.read_text().split("\n## References\n", 1)[1]
    for key, doi in (("G", "10.1007/s11044-018-09662-0"), ("N", "10.1007/s11044-019-09716-x"),
                     ("O", "10.1007/s11071-017-3355-y")):
        entry = re.search(rf"\*\*\[{key}\]\*\*(.+?)(?=\n- |\Z)", refs, re.S)
        assert entry and f"doi:{doi}" in entry.group(1) and re.search(r"\(\d{4}\)", entry.group(1)), key


def _table(section: str) -> list[list[str]]:
    """The rows (cells stripped, header and rule left out) of every table in the named '## ' section."""
    body = THEORY.read_text().split(f"\n## {section}\n", 1)[1].split("\n## ", 1)[0]
    rows = [[c.strip() for c in line.strip().strip("|").split("|")] for line in body.splitlines()
            if line.startswith("|") and not line.startswith("|---")]
    return [r for r in rows if r[0] not in ("id", "level", "name")]


def _ids(cell: str) -> set[str]:
    return set(re.findall(r"`(\w+)`", cell))


def test_glossary_names_every_term_id_in_catalogue_order():
    assert [_ids(r[0]).pop() for r in _table("Glossary: term ids")] == list(IDS)


def test_glossary_levels_are_the_code_s_sets_and_term_levels():
    rows = _table("Glossary: levels I-IV")
    sets = {r[0]: (set(FULL) if "full" in _ids(r[1]) else _ids(r[1])) for r in rows[:4]}
    assert sets == {level: set(terms) for level, terms in LEVEL_SETS.items()}
    levels = {t: r[0] for r in rows[4:] for t in _ids(r[1])}
    assert levels == TERM_LEVEL


def test_every_measure_analyze_prints_is_defined():
    schema = json.loads((SCHEMAS / "analyze.json").read_text())["properties"]
    names = [*schema["amplitudes"]["required"], *schema["significance"]["required"],
             *schema["basis_adequacy"]["oneOf"][1]["items"]["required"]]
    text = THEORY.read_text()
    assert [n for n in names if n != "axis" and f"`{n}`" not in text] == []


# ------------------------------------------------------------------ the project's files
@pytest.mark.parametrize("area", AREAS)
def test_every_theory_and_page_reference_resolves(area):
    bad = [b for p in text_files(area) for b in unresolved(p.read_text(), str(p.relative_to(ROOT)))]
    assert bad == [], "\n".join(bad)


@pytest.mark.parametrize("area", AREAS)
def test_nothing_cites_a_path_outside_the_project(area):
    bad = [f"{p.relative_to(ROOT)}:{n}: {line.strip()[:100]}" for p in text_files(area)
           for n, line in enumerate(p.read_text().splitlines(), 1) if OUTSIDE.search(line)]
    assert bad == [], "\n".join(bad)
