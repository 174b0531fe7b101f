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
    return _report(d, body)


def test_html_parses_and_carries_the_level_and_every_figure(beam_html):
    page = _parse(beam_html)
    text = " ".join(page.text)
    assert f"Verdict for {HOSTILE}: level IV" in text and "operating point" in text and "gyro0" in text and "SHA-256" in text
    assert page.tags.count("figure") == FIGURES
    assert page.tags.count("svg") + page.tags.count("img") >= FIGURES
    for title in ("Fig. 3", "Fig. 5", "Fig. 7", "Fig. 8", "Fig. 10", "Campbell", "at q_max"):
        assert title in text, title


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


@pytest.mark.slow
def test_the_pdf_opens_with_its_pages_and_its_first_page_is_not_blank(tmp_path):
    import pypdf

    from ffrf_advisor.analysis import Options, analyze
    from ffrf_advisor.guidelines import Situation
    from ffrf_advisor.io import read_body
    from ffrf_advisor.report import document, pdf

    a = analyze(read_body(BEAM, load_fe=True), Options(situation=Situation(w_op=1.0)))
    path = tmp_path / "r.pdf"
    pages = pdf.write(document.single(a, str(BEAM)), path)
    reader = pypdf.PdfReader(path)
    assert len(reader.pages) == pages >= FIGURES + 1  # every figure on its page, the text before them
    assert "level IV" in reader.pages[0].extract_text()
    if shutil.which("pdftoppm") is None:
        pytest.skip("pdftoppm (Debian poppler-utils) is not installed: the page was not rendered")
    subprocess.run(["pdftoppm", "-png", "-r", "50", "-f", "1", "-l", "1", str(path), str(tmp_path / "page")],
                   check=True, timeout=60)
    from PIL import Image

    pixels = np.asarray(Image.open(next(tmp_path.glob("page*.png"))).convert("L"))
    assert (pixels < 200).mean() > 0.005


@pytest.mark.slow
def test_a_verification_is_run_or_passed_in(tmp_path):
    from ffrf_advisor.fe.build import modal_body
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
