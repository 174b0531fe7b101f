"""Write a report document by the output's suffix: .html (report.html) or .pdf (report.pdf), atomically."""
from __future__ import annotations

from pathlib import Path

from ..errors import FFRFError
from ..io.atomic import atomic_path, check_target, refuse_inputs
from . import html, pdf
from .document import Document

SUFFIXES = (".html", ".htm", ".pdf")


def check_report_target(path: Path, inputs: list[Path], overwrite: bool) -> None:
    """A report goes to .html/.htm/.pdf, never onto one of its own inputs, and as any output (check_target);
    a .pdf only where WeasyPrint and Pango can be loaded (said before the analysis, not after)."""
    if path.suffix.lower() not in SUFFIXES:
        raise FFRFError(f"{path}: expected a report file ending in {', '.join(SUFFIXES)}")
    refuse_inputs(path, inputs, "is an input of this run; refusing to write the report over it")
    check_target(path, overwrite)
    if path.suffix.lower() == ".pdf":
        pdf.weasyprint(path)


def write(doc: Document, path: Path, overwrite: bool) -> None:
    with atomic_path(path, overwrite) as tmp:
        if path.suffix.lower() == ".pdf":
            pdf.write(doc, tmp, name=path)
        else:
            tmp.write_text(html.render(doc), encoding="utf-8")
