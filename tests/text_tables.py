"""Read a rich table back from a command's text output (tests of layouts at a given width)."""
from __future__ import annotations


def read_table(text: str, title: str) -> list[dict[str, str]]:
    """The rows of the table titled ``title`` as {header: cell}, each cell's lines joined by blanks (a value
    wrapped inside its cell reads back whole, one standing under another column's label does not)."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if title in line)
    top = next(i for i in range(start, len(lines)) if lines[i].lstrip().startswith("┏"))
    mid = next(i for i in range(top, len(lines)) if lines[i].lstrip().startswith("┡"))
    end = next(i for i in range(mid, len(lines)) if lines[i].lstrip().startswith("└"))
    assert all(line.rstrip()[-1] in "┓┃┩│┘┤" for line in lines[top:end + 1]), "a table cropped at the right"
    headers = _cells(lines[top + 1:mid], "┃")
    body = lines[mid + 1:end]
    if not any(line.lstrip().startswith("├") for line in body):  # no lines between rows: one line, one row
        return [dict(zip(headers, _cells([line], "│"))) for line in body]
    rows, block = [], []
    for line in body + ["├"]:
        if line.lstrip().startswith("├"):
            rows.append(dict(zip(headers, _cells(block, "│"))))
            block = []
        else:
            block.append(line)
    return rows


def _cells(block: list[str], bar: str) -> list[str]:
    """Cells of a multi-line row: the text between the bars, line by line, joined."""
    split = [line.strip().strip(bar).split(bar) for line in block]
    return [" ".join(part[k].strip() for part in split if part[k].strip()) for k in range(len(split[0]))]


def fits(text: str, width: int) -> bool:
    """Whether every line of ``text`` stays within ``width`` characters and no value is cut to an ellipsis."""
    return "…" not in text and max(map(len, text.splitlines()), default=0) <= width
