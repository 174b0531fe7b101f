"""A report as a PDF: the HTML report (report.html, self-contained) typeset on A4 by WeasyPrint with the print
stylesheet it carries (templates/print.css): numbered pages, a contents list with page numbers, charts as
vector graphics (their inline SVG), tables that break between rows and repeat their header.

WeasyPrint needs Pango (Debian: libpango-1.0-0, libpangoft2-1.0-0); it is imported here, when a PDF is asked
for, never by `--help` or `--version`. Without it a PDF is refused in one line (FFRFError), before any work."""
from __future__ import annotations

import contextlib
import io
from pathlib import Path

from ..errors import FFRFError
from . import html
from .document import Document

NEEDS = "Debian: apt install libpango-1.0-0 libpangoft2-1.0-0"


def weasyprint(target: Path):
    """The weasyprint module, or FFRFError naming ``target`` and what to install (one line, no traceback)."""
    out = io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):  # its multi-line "could not import"
            import weasyprint as wp
    except OSError as e:  # cffi could not load Pango, HarfBuzz, fontconfig...
        raise FFRFError(f"{target}: PDF needs Pango ({NEEDS}); the .html report needs nothing "
                        f"({' '.join(str(e).split())[:160]})") from None
    except ImportError as e:
        raise FFRFError(f"{target}: PDF needs the Python package weasyprint (pip install weasyprint) and Pango "
                        f"({NEEDS}); the .html report needs nothing ({e})") from None
    return wp


def typeset(text: str, path, name: Path | None = None) -> int:
    """Typeset an HTML report (html.render) to a PDF at ``path`` (``name``: the file the user asked for, for
    messages); returns the number of pages. Nothing is fetched: the HTML is self-contained, and any URL but a
    data: URL is refused."""
    wp = weasyprint(Path(name or path))
    document = wp.HTML(string=text, url_fetcher=wp.URLFetcher(allowed_protocols=("data",))).render()
    document.write_pdf(str(path))
    return len(document.pages)


def write(doc: Document, path, name: Path | None = None) -> int:
    """Write the document to ``path`` (a temporary of io.atomic) as its HTML report typeset; returns the number
    of pages."""
    weasyprint(Path(name or path))  # refused before the figures are drawn
    return typeset(html.render(doc), path, name)
