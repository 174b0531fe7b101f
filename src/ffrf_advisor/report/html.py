"""A report as one self-contained HTML file (Jinja2, autoescaped): charts as inline SVG, 3-D pictures and
verification images as embedded PNG; no script, no external reference."""
from __future__ import annotations

import base64
import io
import re
from pathlib import Path

import matplotlib.pyplot as plt
from jinja2 import Environment, PackageLoader, select_autoescape
from markupsafe import Markup

from .document import Document

PNG_DPI = 90
_SVG_START = re.compile(r"<svg\b")
_METADATA = re.compile(r"<metadata>.*?</metadata>\s*", re.S)


def _svg(fig) -> str:
    """The figure's SVG element alone (no XML prolog, DOCTYPE or metadata); text as text (small files)."""
    buf = io.StringIO()
    with plt.rc_context({"svg.fonttype": "none", "svg.hashsalt": "ffrf"}):
        fig.savefig(buf, format="svg", bbox_inches="tight", metadata={"Date": None})
    text = buf.getvalue()
    return _METADATA.sub("", text[_SVG_START.search(text).start():])


def _png(data: bytes) -> str:
    return f'<img alt="" src="data:image/png;base64,{base64.b64encode(data).decode()}">'


def figure_html(item) -> Markup:
    """A matplotlib figure (3-D ones as PNG: their SVG is large) or a PNG file, as markup we made ourselves."""
    if isinstance(item, Path):
        return Markup(_png(item.read_bytes()))
    three_d = any(ax.name == "3d" for ax in item.axes)
    if three_d:
        buf = io.BytesIO()
        item.savefig(buf, format="png", dpi=PNG_DPI, bbox_inches="tight")
        html = _png(buf.getvalue())
    else:
        html = _svg(item)
    plt.close(item)
    return Markup(html)


def render(doc: Document) -> str:
    env = Environment(loader=PackageLoader("ffrf_advisor.report", "templates"),
                      autoescape=select_autoescape(default=True, default_for_string=True))
    return env.get_template("report.html.j2").render(doc=doc, figure=figure_html)
