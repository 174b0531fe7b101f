"""The glossary of theory.md (shipped in the package; docs/theory.md is the same file): term ids, levels and
printed quantities, looked up by name for `ffrf-advisor explain`."""
from __future__ import annotations

import re
from dataclasses import dataclass
from functools import cache
from importlib.resources import files

GLOSSARY_HEADING = "## Glossary: "
NAME = re.compile(r"`([^`]+)`")


@dataclass(frozen=True)
class Entry:
    """One glossary row: the names it defines, its table's heading and its cells by column."""

    names: tuple[str, ...]
    table: str
    cells: tuple[tuple[str, str], ...]

    def text(self) -> str:
        """The entry as lines: the names, then each further column as 'column: value'."""
        lines = [", ".join(self.names) + f"  ({self.table})"]
        lines += [f"  {column}: {value}" for column, value in self.cells[1:] if value]
        return "\n".join(lines)


def theory_text() -> str:
    return files("ffrf_advisor").joinpath("theory.md").read_text(encoding="utf-8")


def _rows(lines: list[str]) -> list[list[str]]:
    """The cells of a markdown table's lines (header first, the separator dropped)."""
    rows = [[c.strip() for c in line.strip().strip("|").split("|")] for line in lines]
    return [r for r in rows if not all(set(c) <= set("-: ") for c in r)]


def _names(cell: str) -> tuple[str, ...]:
    """The names a first cell defines: its code spans (`q_max`, `governs`), else its text (a level: IV)."""
    found = [n.split("(")[0].strip() for n in NAME.findall(cell)]
    return tuple(n for n in found if not n.startswith(".")) or (cell,)  # '..._paper': a suffix, not a name


@cache
def entries() -> tuple[Entry, ...]:
    """Every row of every table under a '## Glossary: ...' heading of theory.md."""
    out, table, block = [], None, []
    for line in theory_text().splitlines() + [""]:
        if line.startswith("## "):
            table = line[len(GLOSSARY_HEADING):] if line.startswith(GLOSSARY_HEADING) else None
        if table and line.startswith("|"):
            block.append(line)
            continue
        if block:
            header, *body = _rows(block)
            out += [Entry(_names(r[0]), table, tuple(zip(header, r))) for r in body if len(r) == len(header)]
            block = []
    return tuple(out)


def lookup(name: str) -> list[Entry]:
    """The entries that define ``name`` (case as written; a level in Roman numerals either case)."""
    key = name.strip().strip("`")
    return [e for e in entries() if key in e.names or key.upper() in e.names]


def known_names() -> list[str]:
    return sorted({n for e in entries() for n in e.names}, key=str.lower)
