"""Reports (issue 15): self-contained HTML and multi-page PDF, through the CLI."""
from __future__ import annotations

import json
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from ffrf_advisor.cli import app
from ffrf_advisor.io import h5_checksums
from ffrf_advisor.report.verify_input import PNG_SIGNATURE, figures_beside

ROOT = Path(__file__).resolve().parents[1]
BEAM = ROOT / "sample_bodies" / "beam.ffrf.h5"
PLATE = ROOT / "sample_bodies" / "plate.ffrf.h5"
FIGURES = 7  # Fig. 3, 5, 7, 8, 10 of the paper, the mesh with modes at q_max, the Campbell diagram
runner = CliRunner()
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--hide-scrollbars"]


class Page(HTMLParser):
    """Tags, the attributes that load something, and the text of a page."""

    def __init__(self):
        super().__init__()
        self.tags, self.links, self.text = [], [], []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        self.links += [v for k, v in attrs if k in ("src", "href", "xlink:href", "data", "action") and v]

    def handle_data(self, data):
        self.text.append(data)


def _report(tmp_path, *args, name="r.html"):
    out = tmp_path / name
    result = runner.invoke(app, ["report", *map(str, args), "--speed", "1rad/s", "-o", str(out)])
    assert result.exit_code == 0, result.output
    return out


def _parse(path) -> Page:
    page = Page()
    page.feed(path.read_text(encoding="utf-8"))
    page.close()
    return page


HOSTILE = "<script>alert(1)</script>"


@pytest.fixture(scope="module")
def beam_html(tmp_path_factory):
    """The beam's report, the beam named as an attacker would name it (one report serves every HTML test)."""
    d = tmp_path_factory.mktemp("html")
    body = d / "evil.ffrf.h5"
    shutil.copy(BEAM, body)
    with h5py.File(body, "r+") as f:
        f.attrs["name"] = HOSTILE
        h5_checksums.stamp_cache(f)  # the name edited on purpose: its digest made anew
    return _report(d, body)


def test_html_parses_and_carries_the_level_and_every_figure(beam_html):
    page = _parse(beam_html)
    text = " ".join(page.text)
    assert f"Verdict for {HOSTILE}: level IV" in text and "operating point" in text and "gyro0" in text and "SHA-256" in text
    assert page.tags.count("figure") == FIGURES
    assert page.tags.count("svg") + page.tags.count("img") >= FIGURES
    for title in ("Fig. 3", "Fig. 5", "Fig. 7", "Fig. 8", "Fig. 10", "Campbell", "at q_max"):
        assert title in text, title
    assert "Mode set (theory 12)" in text and "static energy share" in text and "keep: in band" in text


def test_html_references_nothing_outside_itself(beam_html):
    page = _parse(beam_html)
    html = beam_html.read_text(encoding="utf-8")
    assert not {"script", "link", "iframe", "object", "embed"} & set(page.tags)
    assert all(v.startswith(("data:image/png;base64,", "#")) for v in page.links), page.links[:5]
    assert "url(http" not in html and "@import" not in html


def test_a_hostile_body_name_is_escaped(beam_html):
    html = beam_html.read_text(encoding="utf-8")
    assert "<script" not in html.lower() and "&lt;script&gt;alert(1)&lt;/script&gt;" in html


@pytest.mark.slow
def test_a_set_compares_the_bodies_first_then_one_part_each(tmp_path):
    page = _parse(_report(tmp_path, BEAM, PLATE, name="set.html"))
    text = " ".join(page.text)
    assert text.index("Paper figures across bodies") < text.index("Verdict for beam") < text.index("Verdict for plate")
    assert page.tags.count("figure") == 5 + 2 * 2  # the comparison; then mesh and Campbell per body
    first_svg = (tmp_path / "set.html").read_text().split("<svg", 2)[1]
    assert ">beam<" in first_svg and ">plate<" in first_svg  # one series per body in the comparison


def test_the_report_never_overwrites_an_input_or_an_existing_file(tmp_path):
    target = tmp_path / "r.html"
    target.write_text("mine")
    result = runner.invoke(app, ["report", str(BEAM), "-o", str(target)])
    assert result.exit_code == 2 and "--force" in result.output and target.read_text() == "mine"
    result = runner.invoke(app, ["report", str(BEAM), "-o", str(tmp_path / "r.txt")])
    assert result.exit_code == 2 and ".html" in result.output
    copy = tmp_path / "b.ffrf.h5.html"
    shutil.copy(BEAM, copy)
    result = runner.invoke(app, ["report", str(copy), "-o", str(copy), "--force"])
    assert result.exit_code == 2 and "input of this run" in result.output


@pytest.mark.slow  # Chromium's start and a second build of the beam's report: 6 s of a worker
@pytest.mark.skipif(shutil.which("chromium") is None,
                    reason="Chromium is not installed (.ci/run installs the Debian package chromium)")
def test_the_html_renders_in_headless_chromium(beam_html, tmp_path):
    from PIL import Image

    shot = tmp_path / "shot.png"
    done = subprocess.run(["chromium", *CHROMIUM_FLAGS, f"--user-data-dir={tmp_path / 'profile'}",
                           "--enable-logging=stderr", "--v=0", "--window-size=1200,2000", f"--screenshot={shot}",
                           beam_html.as_uri()], capture_output=True, text=True, timeout=120)
    assert shot.is_file(), done.stderr[-2000:]
    console = [line for line in done.stderr.splitlines() if "CONSOLE" in line or "Failed to load" in line]
    assert not console, console
    pixels = np.asarray(Image.open(shot).convert("L"))
    assert (pixels < 200).mean() > 0.01  # text, tables and figures: not a blank page


A4 = (595.28, 841.89)  # pt
PDF_MARGIN = 16 * 72 / 25.4  # left and right page margins of report/templates/print.css, pt


def _a4(reader) -> None:
    sizes = [(float(p.mediabox.width), float(p.mediabox.height)) for p in reader.pages]
    assert all(abs(w - A4[0]) < 1 and abs(h - A4[1]) < 1 for w, h in sizes), sorted(set(sizes))


def _words(text: str) -> set[str]:
    return set(text.split())


def _rendered_pages(path, folder, dpi=30) -> list:
    """Every page of the PDF as a grey-level array (pdftoppm), or a skip naming the Debian package."""
    if shutil.which("pdftoppm") is None:
        pytest.skip("pdftoppm (Debian poppler-utils) is not installed: the pages were not rendered")
    subprocess.run(["pdftoppm", "-png", "-r", str(dpi), str(path), str(folder / "page")], check=True, timeout=120)
    from PIL import Image

    return [np.asarray(Image.open(p).convert("L")) for p in sorted(folder.glob("page*.png"))]


def _needs_pango() -> None:
    """Skip, naming what to install, where WeasyPrint cannot load Pango (.ci/run installs it)."""
    from ffrf_advisor.errors import FFRFError
    from ffrf_advisor.report import pdf

    try:
        pdf.weasyprint(Path("report.pdf"))
    except FFRFError as e:
        pytest.skip(str(e))


def _hide_weasyprint(monkeypatch, error: type[Exception]) -> None:
    """``import weasyprint`` fails as without Pango (OSError from cffi) or without the package (ImportError)."""
    import builtins

    real = builtins.__import__

    def fake(name, *args, **kwargs):
        if name == "weasyprint" or name.startswith("weasyprint."):
            raise error("cannot load library 'libpango-1.0-0': libpango-1.0-0: cannot open shared object file")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", fake)


@pytest.mark.parametrize("error, says", [(OSError, "PDF needs Pango (Debian: apt install libpango-1.0-0 "
                                                    "libpangoft2-1.0-0); the .html report needs nothing"),
                                         (ImportError, "pip install weasyprint")])
def test_a_pdf_without_weasyprint_or_pango_is_refused_in_one_line(tmp_path, monkeypatch, error, says):
    _hide_weasyprint(monkeypatch, error)
    out = tmp_path / "x.pdf"
    result = runner.invoke(app, ["report", str(BEAM), "--speed", "1rad/s", "-o", str(out)])
    assert result.exit_code == 2, result.output
    assert result.output.startswith(f"error: {out}: ") and says in result.output, result.output
    assert result.output.count("\n") == 1 and "Traceback" not in result.output and "-----" not in result.output
    assert not out.exists() and list(tmp_path.iterdir()) == []


ROWS = 60


@pytest.mark.slow  # WeasyPrint typesets four pages: 4 s
def test_a_long_wide_table_breaks_across_a4_pages_with_its_header_on_each(tmp_path):
    """Typesetting alone (no analysis, no figure): 60 rows of a 7-column table with a long last column, as the
    verdict's rules table, fit the page width and repeat their header row on every page they reach."""
    import pypdf

    from ffrf_advisor.report import pdf
    from ffrf_advisor.report.document import Document, Section

    reason = "predicted static error 1 (principal axis 1) > 0.005: needs cf1, inertia_lin, cor1, inertia_quad"
    rows = [(f"row{k:03d}", "gyro0+W1+W2+W3", "0.6361", "0.005", "not evaluated",
             "cf1, inertia_lin, cor1, inertia_quad, cf2", f"{reason} ({k})") for k in range(ROWS)]
    _needs_pango()
    header = ("rule", "measure", "value", "threshold", "outcome", "terms", "reasonheader")
    doc = Document("wide", [Section("Before", [("fields", [("SHA-256", "d7" * 32)])]),
                            Section("The table", [("table", (header, rows))]), Section("After", [("items", ["end"])])],
                   [("tool", "ffrf-advisor test"), ("date", "today")])
    path = tmp_path / "t.pdf"
    pages = pdf.write(doc, path)
    reader = pypdf.PdfReader(path)
    assert len(reader.pages) == pages >= 2
    _a4(reader)
    starts = []  # where each text run starts: never in the right margin or beyond the page

    def visit(text, cm, tm, font, size):
        if text.strip():
            starts.append((tm[4] * cm[0] + tm[5] * cm[2] + cm[4], text))

    texts = [p.extract_text(visitor_text=visit) for p in reader.pages]
    spanned = [k for k, t in enumerate(texts) if "gyro0+W1+W2+W3" in t]
    assert len(spanned) >= 2 and all("reasonheader" in texts[k] for k in spanned)
    assert all(f"row{k:03d}" in "".join(texts) for k in range(ROWS))  # no row lost at a page break
    assert f"page 1 of {pages}" in texts[0] and f"page {pages} of {pages}" in texts[-1]
    assert "Contents" in texts[0] and "The table" in texts[0]
    assert starts and max(x for x, _ in starts) < A4[0] - PDF_MARGIN, max(starts)


@pytest.mark.slow
def test_the_pdf_is_the_html_report_on_numbered_a4_pages_with_contents(tmp_path):
    """The beam's report: the HTML typeset (same words, every section), A4 pages "page N of M", a contents list
    with the sections' page numbers, every page rendered by pdftoppm and none blank, nothing in the side
    margins (tables and figures fit the page)."""
    import pypdf

    from ffrf_advisor.analysis import Options, analyze
    from ffrf_advisor.guidelines import Situation
    from ffrf_advisor.io import read_body
    from ffrf_advisor.report import document, html, pdf

    _needs_pango()
    a = analyze(read_body(BEAM, load_fe=True), Options(situation=Situation(w_op=1.0)))
    doc = document.single(a, str(BEAM))
    text = html.render(doc)
    titles = [s.title for s in doc.sections]
    assert all(f">{t}</h2>" in text for t in titles)
    path = tmp_path / "r.pdf"
    pages = pdf.typeset(text, path)
    reader = pypdf.PdfReader(path)
    assert len(reader.pages) == pages >= 4
    _a4(reader)
    texts = [p.extract_text() for p in reader.pages]
    everything = "\n".join(texts)
    assert "level IV" in texts[0] and all(f"page {k + 1} of {pages}" in t for k, t in enumerate(texts))
    assert texts[0].index("Contents") < texts[0].index("Verdict for beam: level IV")
    for t in titles:  # in the contents with a page number, and on that page
        line = next(line for line in texts[0].splitlines() if line.startswith(t))
        number = int(line.rstrip().rsplit(" ", 1)[1].strip("."))
        assert 1 <= number <= pages and t in texts[number - 1], (t, line)
    missing = _words(_prose(text)) - _words(everything)
    assert not missing, sorted(missing)[:20]
    images = _rendered_pages(path, tmp_path)
    assert len(images) == pages
    for k, pixels in enumerate(images):
        assert (pixels < 200).mean() > 0.01, f"page {k + 1} is blank"
        margin = int(pixels.shape[1] * (PDF_MARGIN - 4) / A4[0])
        assert (pixels[:, :margin] > 240).all() and (pixels[:, -margin:] > 240).all(), f"page {k + 1} overflows"


class Prose(HTMLParser):
    """The text a reader sees of an HTML report but the figures' own lettering (inside <svg>) and the CSS."""

    def __init__(self):
        super().__init__()
        self.skip, self.text = 0, []

    def handle_starttag(self, tag, attrs):
        self.skip += tag in ("svg", "style", "title")

    def handle_endtag(self, tag):
        self.skip -= tag in ("svg", "style", "title")

    def handle_data(self, data):
        if not self.skip:
            self.text.append(data)


def _prose(markup: str) -> str:
    parser = Prose()
    parser.feed(markup)
    parser.close()
    return " ".join(parser.text)


@pytest.mark.slow
def test_a_verification_is_run_or_passed_in(tmp_path):
    from ffrf_advisor.fe_body import modal_body
    from ffrf_advisor.fe.material import STEEL
    from ffrf_advisor.fe.mesh import box_mesh
    from ffrf_advisor.io import write_body

    body = tmp_path / "small.ffrf.h5"  # 4 modes of a 60 x 20 x 10 mm block: a verification in seconds
    write_body(modal_body(box_mesh([60.0, 20.0, 10.0], [3, 1, 1], "hexahedron20"), STEEL, 4, name="small"), body)
    folder = tmp_path / "v"
    done = runner.invoke(app, ["verify", str(body), "--scene", "free-spin", "--repeat", "1", "--speed", "1rad/s",
                               "-o", str(folder), "--json"])
    assert done.exit_code == 0, done.output
    (tmp_path / "v.json").write_text(done.stdout)
    out = tmp_path / "v.html"
    result = runner.invoke(app, ["report", str(body), "--speed", "1rad/s", "--verification",
                                 str(tmp_path / "v.json"), "-o", str(out)])
    assert result.exit_code == 0, result.output
    page = _parse(out)
    text = " ".join(page.text)
    verdict = json.loads(done.stdout)["verdict"]
    assert "Verification by simulation" in text and verdict["text"] in text
    assert page.tags.count("figure") > FIGURES  # the verification's figures too
    outside = tmp_path.parent / f"{tmp_path.name}-outside.png"  # a PNG elsewhere on disk, named by the JSON
    outside.write_bytes(next(folder.glob("*.png")).read_bytes())
    doc = json.loads(done.stdout)
    doc["figures"] += [str(outside), f"../{outside.name}"]
    (tmp_path / "v.json").write_text(json.dumps(doc))
    assert runner.invoke(app, ["report", str(body), "--speed", "1rad/s", "--verification",
                               str(tmp_path / "v.json"), "-o", str(out), "--force"]).exit_code == 0
    assert _parse(out).tags.count("figure") == page.tags.count("figure")
    quick = runner.invoke(app, ["verify", str(body), "--scene", "free-spin", "--repeat", "1", "--speed", "1rad/s",
                                "--quick", "--json"])
    (tmp_path / "q.json").write_text(quick.stdout)  # the studies null: the report says they were left out
    assert runner.invoke(app, ["report", str(body), "--speed", "1rad/s", "--verification", str(tmp_path / "q.json"),
                               "-o", str(out), "--force"]).exit_code == 0
    assert "quick verification: no work-precision, stability or Campbell studies" in " ".join(_parse(out).text)


def test_a_verification_embeds_only_the_pngs_beside_its_json(tmp_path):
    """Item 15: report --verification embedded any PNG the JSON named, and resolved relative paths against the
    working directory."""
    png = PNG_SIGNATURE + b"rest"
    (tmp_path / "v").mkdir()
    (tmp_path / "v" / "campbell.png").write_bytes(png)
    (tmp_path / "elsewhere.png").write_bytes(png)
    (tmp_path / "v" / "fake.png").write_text("not a picture")
    named = ["campbell.png", "other/v/campbell.png", str(tmp_path / "elsewhere.png"), "../elsewhere.png",
             "fake.png", "/etc/passwd"]
    inside = str((tmp_path / "v" / "campbell.png").resolve())
    assert figures_beside(named, tmp_path / "v") == [inside, inside]


def test_an_invariants_file_without_I9_reports_what_it_cannot_draw(tmp_path):
    inv = tmp_path / "b.ffinv.json"
    assert runner.invoke(app, ["convert", str(BEAM), str(inv)]).exit_code == 0
    doc = json.loads(inv.read_text())
    for key in ("I9", "max_von_mises", "max_von_mises_node"):
        doc.pop(key, None)
    inv.write_text(json.dumps(doc))
    text = " ".join(_parse(_report(tmp_path, inv)).text)
    assert "Campbell diagram not drawn" in text and "not evaluable (missing invariants)" in text
