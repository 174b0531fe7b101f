"""report.console.fitted_table draws its tables line by line (``_boxed``) as rich's Table draws them: the same
bytes as rich's own rendering of the same table, plain and on a colour terminal, at any width."""
from __future__ import annotations

import io

import pytest
from rich.console import Console
from rich.table import Table

from ffrf_advisor.report import console as rc

ROWS = [["1", "106.2", "5.3178e-01", "stress", "[green]pass[/green]"],
        ["2", "211.5", "1.3412e-01", "scaled (stress)", "[red]FAIL[/red]"],
        ["10", "1.002e+04", "7.0295e-02", "q_cap", "pass"]]
HEADERS = ["mode", f"f {rc._unit('Hz')}", f"q_max {rc._unit('sqrt(t) mm')}", "governs", "check"]  # units as the tool
# escapes them
TITLE = "maximum modal coordinates (theory 6; q_cap 1, sigma_allow 500 N/mm^2), a title longer than the table"


def _console(width: int, terminal: bool) -> Console:
    return Console(file=io.StringIO(), width=width, force_terminal=terminal, color_system="truecolor" if terminal
                   else None, emoji=False, highlight=False)


def _by_rich(width: int, terminal: bool, rows, title: str = TITLE) -> str:
    """The table as rich renders it: fitted_table's widths and justification, each column one cell of its values."""
    console = _console(width, terminal)
    plain = [rc._plain(h) for h in HEADERS]
    text = [[rc._plain(v) for v in r] for r in rows]
    widths = rc._widths(text, plain, None, whole=True)
    if sum(widths) + 3 * len(HEADERS) + 1 > width:
        widths = rc._widths(text, plain, None, whole=False)
    t = Table(title=title)
    for h, w in zip(HEADERS, widths):
        t.add_column(h, justify="left" if h == "governs" else "right", width=w)
    t.add_row(*("\n".join(column) for column in zip(*rows)))
    console.print(t)
    return console.file.getvalue()


@pytest.mark.parametrize("terminal", [False, True], ids=["plain", "colour"])
@pytest.mark.parametrize("width", [62, 80, 120])
@pytest.mark.parametrize("rows", [ROWS, [r[:4] + ["pass"] for r in ROWS], [r[:3] + ["Größe", "ok"] for r in ROWS]],
                         ids=["markup", "plain values", "non-ascii"])
def test_fitted_tables_are_rich_tables_byte_for_byte(width, terminal, rows):
    """Headers wrapped at blanks and aligned to the bottom (62 and 80 columns), whole (120), the title wrapped and
    centred, values with markup (colours on a terminal) or wider in bytes than in cells."""
    console = _console(width, terminal)
    rc.fitted_table(console, TITLE, HEADERS, rows, left=("governs",))
    assert console.file.getvalue() == _by_rich(width, terminal, rows)


def test_a_table_without_a_title_has_no_title_line():
    console = _console(80, False)
    rc.fitted_table(console, "", HEADERS, ROWS, left=("governs",))
    assert console.file.getvalue() == _by_rich(80, False, ROWS, title="")
