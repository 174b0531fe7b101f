"""Write a report document by the output's suffix: .html (report.html) or .pdf (report.pdf), atomically."""
from __future__ import annotations

from pathlib import Path

from ..errors import FFRFError
from ..io.atomic import atomic_path, refuse_inputs
from . import html, pdf
from .document import Document

SUFFIXES = (".html", ".htm", ".pdf")


def check_target(path: Path, inputs: list[Path]) -> None:
    """A report goes to .html/.htm/.pdf, never onto one of its own inputs."""
    if path.suffix.lower() not in SUFFIXES:
        raise FFRFError(f"{path}: expected a report file ending in {', '.join(SUFFIXES)}")
    refuse_inputs(path, inputs, "is an input of this run; refusing to write the report over it")


def write(doc: Document, path: Path, overwrite: bool) -> None:
    with atomic_path(path, overwrite) as tmp:
        if path.suffix.lower() == ".pdf":
            pdf.write(doc, tmp)
        else:
            tmp.write_text(html.render(doc), encoding="utf-8")
