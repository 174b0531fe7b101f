"""A report as a multi-page PDF with matplotlib's PDF backend: what `pip install` alone provides (no
system libraries, unlike HTML-to-PDF converters that need Cairo/Pango or a browser), fonts embedded.
Text pages are set in a monospaced font so that tables stay aligned; each figure gets its own page."""
from __future__ import annotations

import textwrap
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.backends.backend_pdf import PdfPages  # noqa: E402

from .document import Document, Section  # noqa: E402

A4 = (8.27, 11.69)  # inches, portrait
COLUMNS = 100  # characters of a text line at FONT_SIZE on A4
LINES = 88  # text lines per page
FONT_SIZE = 6.8
PDF_DPI = 110  # of the rasterised 3-D pictures


def _table(header, rows) -> list[str]:
    """Columns as wide as their longest entry (each cut at 60); the last column wraps under itself, or, when
    that leaves it under 40 characters, goes stacked below its row (indented), as the console does."""
    cells = [[str(c) for c in header]] + [[str(c) for c in r] for r in rows]
    widths = [min(60, max(len(r[i]) for r in cells)) for i in range(len(header) - 1)]
    lead_width = sum(widths) + 2 * len(widths)
    stacked = COLUMNS - lead_width < 40
    lines = []
    for k, row in enumerate(cells):
        lead = "  ".join(c[:w].ljust(w) for c, w in zip(row, widths))
        if stacked:
            lines.append(lead.rstrip())
            lines += textwrap.wrap(row[-1], COLUMNS - 4, initial_indent="    ", subsequent_indent="    ")
        else:
            tail = textwrap.wrap(row[-1], COLUMNS - lead_width) or [""]
            lines.append(f"{lead}  {tail[0]}".rstrip())
            lines += [" " * lead_width + t for t in tail[1:]]
        if k == 0:
            lines.append("-" * min(COLUMNS, max(len(line) for line in lines)))
    return lines


def _text(section: Section) -> list[str]:
    lines = [section.title, "=" * len(section.title)]
    for kind, data in section.blocks:
        if kind == "fields":
            width = max(len(k) for k, _ in data)
            for k, v in data:
                wrapped = textwrap.wrap(str(v), COLUMNS - width - 2) or [""]
                lines += [f"{k:<{width}}  {wrapped[0]}"] + [" " * (width + 2) + w for w in wrapped[1:]]
        elif kind == "table":
            lines += _table(*data)
        elif kind == "items":
            for item in data:
                lines += textwrap.wrap(str(item), COLUMNS, initial_indent="- ", subsequent_indent="  ")
        lines.append("")
    return lines


def _text_pages(pdf: PdfPages, lines: list[str]) -> None:
    for start in range(0, len(lines), LINES):
        fig = plt.figure(figsize=A4)
        fig.text(0.05, 0.97, "\n".join(lines[start:start + LINES]), family="monospace", size=FONT_SIZE, va="top")
        pdf.savefig(fig)
        plt.close(fig)


def _figure_page(pdf: PdfPages, title: str, item) -> None:
    if isinstance(item, Path):
        fig, ax = plt.subplots(figsize=(A4[1], A4[0]))
        ax.imshow(mpimg.imread(item))
        ax.set_axis_off()
        ax.set_title(title)
    else:
        fig = item()
        for ax in fig.axes:
            ax.set_rasterized(ax.name == "3d")  # thousands of mesh faces: an image, not vectors
    pdf.savefig(fig, bbox_inches="tight", dpi=PDF_DPI)
    plt.close(fig)


def write(doc: Document, path) -> int:
    """Write the document to ``path`` (a temporary of io.atomic); returns the number of pages."""
    with PdfPages(path, metadata={"Title": doc.title, "Creator": dict(doc.meta)["tool"],
                                  "CreationDate": None}) as pdf:
        lines = [doc.title, "  ".join(f"{k}: {v}" for k, v in doc.meta), ""]
        for section in doc.sections:
            lines += _text(section)
            figures = [data for kind, data in section.blocks if kind == "figure"]
            if figures:
                _text_pages(pdf, lines)
                lines = []
                for title, item in figures:
                    _figure_page(pdf, title, item)
        if lines:
            _text_pages(pdf, lines)
        return pdf.get_pagecount()
