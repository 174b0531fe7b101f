"""A report as one self-contained HTML file (Jinja2, autoescaped): a contents list, charts as inline SVG, 3-D
pictures and verification images as embedded PNG; no script, no external reference. Its print stylesheet
(templates/print.css, under @media print) makes the A4 pages of report.pdf (pdf.py) and of a browser's print."""
from __future__ import annotations

import base64
import hashlib
import io
import re
from pathlib import Path

import matplotlib.pyplot as plt
from jinja2 import Environment, PackageLoader, select_autoescape
from markupsafe import Markup
from PIL import Image

from .document import Document

PNG_DPI = 90
_SVG_START = re.compile(r"<svg\b")
_METADATA = re.compile(r"<metadata>.*?</metadata>\s*", re.S)
_ID = re.compile(r'\sid="([^"]*)"')
_REFERENCE = re.compile(r"#([^\s\"')]+)")


def _svg(fig) -> str:
    """The figure's SVG element alone (no XML prolog, DOCTYPE or metadata); text as text (small files). Only the
    ids something refers to stay (markers, clip paths), prefixed by a hash of the figure: matplotlib names every
    group (figure_1, axes_1, line2d_1...) alike in every figure, ids the page would hold many times."""
    buf = io.StringIO()
    with plt.rc_context({"svg.fonttype": "none", "svg.hashsalt": "ffrf"}):
        fig.savefig(buf, format="svg", bbox_inches="tight", metadata={"Date": None})
    text = buf.getvalue()
    svg = _METADATA.sub("", text[_SVG_START.search(text).start():])
    ids = set(_ID.findall(svg)) & set(_REFERENCE.findall(svg))
    prefix = "f" + hashlib.sha256(svg.encode()).hexdigest()[:8] + "-"
    svg = _ID.sub(lambda m: f' id="{prefix}{m.group(1)}"' if m.group(1) in ids else "", svg)
    return _REFERENCE.sub(lambda m: f"#{prefix}{m.group(1)}" if m.group(1) in ids else m.group(0), svg)


def _png(source) -> str:
    """An <img> of a PNG (a file or bytes), reduced to 256 colours (plots use few: a third of the bytes)."""
    image = Image.open(source if isinstance(source, Path) else io.BytesIO(source)).convert("RGB")
    buf = io.BytesIO()
    image.quantize(256, method=Image.Quantize.MEDIANCUT).save(buf, format="png", optimize=True)
    return f'<img alt="" src="data:image/png;base64,{base64.b64encode(buf.getvalue()).decode()}">'


def figure_html(item) -> Markup:
    """A figure (made now by ``item()``; 3-D ones as PNG: their SVG is large) or a PNG file, as markup we made
    ourselves."""
    if isinstance(item, Path):
        return Markup(_png(item))
    fig = item()
    if any(ax.name == "3d" for ax in fig.axes):
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=PNG_DPI, bbox_inches="tight")
        html = _png(buf.getvalue())
    else:
        html = _svg(fig)
    plt.close(fig)
    return Markup(html)


def render(doc: Document) -> str:
    env = Environment(loader=PackageLoader("ffrf_advisor.report", "templates"),
                      autoescape=select_autoescape(default=True, default_for_string=True))
    return env.get_template("report.html.j2").render(doc=doc, figure=figure_html)
