"""A report vouches only for a verification of its own body, operating point, tolerance and term set (issue 51)."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from ffrf_advisor.cli import app
from ffrf_advisor.errors import FFRFError
from ffrf_advisor.io import sha256
from ffrf_advisor.report.verify_input import check_matches, operating_point

ROOT = Path(__file__).resolve().parents[1]
BEAM = ROOT / "sample_bodies" / "beam.ffrf.h5"
PLATE = ROOT / "sample_bodies" / "plate.ffrf.h5"
runner = CliRunner()


@pytest.fixture(scope="module")
def beam_at_300():
    from ffrf_advisor.analysis import analyze
    from ffrf_advisor.io import read_body
    from ffrf_advisor.situation import Options, Situation
    return analyze(read_body(BEAM), Options(situation=Situation(w_op=300.0)))


def _stated(a, body: Path) -> dict:
    """What `verify --json` states of the body, the operating point, the tolerance and the advice."""
    sit = a.options.situation
    return {"body": {"file": str(body), "sha256": sha256(body)},
            "operating_point": json.loads(json.dumps(operating_point(sit))), "tolerance": sit.tolerance,
            "advice": {"speed_rad_s": sit.w_op, "excitation": sit.excitation, "terms": list(a.advice.terms)}}


def test_a_verification_of_the_reports_body_and_operating_point_is_taken(beam_at_300):
    check_matches(_stated(beam_at_300, BEAM), beam_at_300, sha256(BEAM), Path("v.json"))


@pytest.mark.parametrize("change, word", [
    (lambda d: d["body"].update(sha256=sha256(PLATE), file=str(PLATE)), "body"),
    (lambda d: d["body"].pop("sha256"), "body"),
    (lambda d: d["operating_point"].update(speed_rad_s=100.0), "operating point"),
    (lambda d: d["operating_point"].update(principal_axis=3), "operating point"),
    (lambda d: d.update(tolerance=0.02), "tolerance"),
    (lambda d: d["advice"].update(terms=["gyro0"]), "advised terms"),
])
def test_a_verification_of_anything_else_is_refused_in_one_line(beam_at_300, change, word):
    stated = _stated(beam_at_300, BEAM)
    change(stated)
    with pytest.raises(FFRFError) as e:
        check_matches(stated, beam_at_300, sha256(BEAM), Path("v.json"))
    assert f"--verification {word}" in str(e.value) and "\n" not in str(e.value)


@pytest.mark.slow  # a verification and a report of a small block: about 15 s
def test_report_refuses_a_verification_of_another_body_speed_or_tolerance(tmp_path):
    from ffrf_advisor.fe.material import STEEL
    from ffrf_advisor.fe.mesh import box_mesh
    from ffrf_advisor.fe_body import modal_body
    from ffrf_advisor.io import write_body

    body, other = tmp_path / "small.ffrf.h5", tmp_path / "other.ffrf.h5"
    write_body(modal_body(box_mesh([60.0, 20.0, 10.0], [3, 1, 1], "hexahedron20"), STEEL, 4, name="small"), body)
    write_body(modal_body(box_mesh([70.0, 20.0, 10.0], [3, 1, 1], "hexahedron20"), STEEL, 4, name="other"), other)
    done = runner.invoke(app, ["verify", str(body), "--scene", "free-spin", "--repeat", "1", "--speed", "1rad/s",
                               "--quick", "--json"])
    assert done.exit_code == 0, done.output
    (tmp_path / "v.json").write_text(done.stdout)
    out = tmp_path / "r.html"
    for target, extra in ((other, []), (body, ["--speed", "2rad/s"]), (body, ["--tolerance", "0.02"])):
        args = ["--speed", "1rad/s", *extra] if "--speed" not in extra else extra
        refused = runner.invoke(app, ["report", str(target), *args, "--verification", str(tmp_path / "v.json"),
                                      "-o", str(out), "--force"])
        assert refused.exit_code == 2 and len(refused.output.strip().splitlines()) == 1, refused.output
        assert "--verification" in refused.output and not out.exists()
    taken = runner.invoke(app, ["report", str(body), "--speed", "1rad/s", "--verification", str(tmp_path / "v.json"),
                                "-o", str(out)])
    assert taken.exit_code == 0, taken.output
    page = out.read_text()
    assert sha256(body) in page and json.loads(done.stdout)["date"] in page
