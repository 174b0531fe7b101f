"""analyze and gate through the real CLI."""
from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import jsonschema
import numpy as np
import pytest
from typer.testing import CliRunner

from ffrf_advisor.cli import app
from ffrf_advisor.schemas import schema

from .test_cli import SAMPLE

SCHEMA = schema("analyze")
runner = CliRunner()


def test_analyze_json_validates_against_the_schema():
    cases = {("III",): [], ("IV",): ["--speed", "3000rpm", "--connection", "soft"],
             ("I",): ["--q-max", ",".join(["0.05"] * 16)]}  # dI_Q = 0.27 (0.05 / 0.53)^2 = 2.4e-3 < 0.005
    for (level,), args in cases.items():
        result = runner.invoke(app, ["analyze", str(SAMPLE), "--json", "--rules", "thresholds", *args])
        assert result.exit_code == 0, result.output
        data = json.loads(result.stdout)
        jsonschema.validate(data, SCHEMA)
        assert data["level"] == level
    broken = dict(data, level="V")
    try:
        jsonschema.validate(broken, SCHEMA)
        raise AssertionError("schema accepted level V")
    except jsonschema.ValidationError:
        pass


def test_analyze_table_shows_level_first():
    result = runner.invoke(app, ["analyze", str(SAMPLE), "--speed", "100rad/s"], env={"COLUMNS": "200"})
    assert result.exit_code == 0
    assert result.output.splitlines()[0].startswith("beam: level IV")
    assert "evidence per rule" in result.output


def test_config_file_and_bad_options(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "ffrf-advisor.toml").write_text("rules = 'thresholds'\n[thresholds]\ndI_Q = 0.5\ndI_fT = 0.5\n"
                                                "dI_Tf = 0.5\n")
    result = runner.invoke(app, ["analyze", str(SAMPLE), "--json"])
    assert json.loads(result.stdout)["level"] == "I"
    (tmp_path / "ffrf-advisor.toml").write_text("[thresholds]\nbogus = 1\n")
    result = runner.invoke(app, ["analyze", str(SAMPLE)])
    assert result.exit_code == 2 and "bogus" in result.output
    (tmp_path / "ffrf-advisor.toml").unlink()
    (tmp_path / "pyproject.toml").write_text("[tool.ffrf-advisor]\nconnection = 'stiff'\nrules = 'thresholds'\n")
    assert json.loads(runner.invoke(app, ["analyze", str(SAMPLE), "--json"]).stdout)["level"] == "I"
    for bad in (["--speed", "fast"], ["--connection", "glued"], ["--threshold", "nope=1"], ["--q-max", "1,2"]):
        result = runner.invoke(app, ["analyze", str(SAMPLE), *bad])
        assert result.exit_code == 2, bad


def test_gate_exit_codes_and_junit(tmp_path):
    junit = tmp_path / "gate.xml"
    ok = runner.invoke(app, ["gate", *AT_REST, str(SAMPLE), "--max-level", "III", "--junit", str(junit)])
    assert ok.exit_code == 0
    suite = ET.parse(junit).getroot()
    assert suite.get("tests") == "1" and suite.get("failures") == "0"

    over = runner.invoke(app, ["gate", *AT_REST, str(SAMPLE), str(SAMPLE), "--max-level", "II", "--junit", str(junit),
                               "--jobs", "2"])
    assert over.exit_code == 1
    suite = ET.parse(junit).getroot()
    failures = suite.findall("testsuite/testcase/failure")
    assert len(failures) == 2 and "dI_Q" in failures[0].text and "exceeds II" in failures[0].get("message")

    junk = tmp_path / "junk.ffrf.h5"
    junk.write_text("x")
    bad = runner.invoke(app, ["gate", *AT_REST, str(SAMPLE), str(junk), "--max-level", "IV", "--junit", str(junit), "--json"])
    assert bad.exit_code == 2
    assert ET.parse(junit).getroot().get("errors") == "1"
    data = json.loads(bad.stdout)
    assert [b["level"] for b in data["bodies"]] == ["III", None]
    assert runner.invoke(app, ["gate", str(SAMPLE), "--max-level", "V"]).exit_code == 2
    assert runner.invoke(app, ["gate", *AT_REST, str(SAMPLE)]).exit_code == 2  # usage: --max-level missing


AT_REST = ["--speed", "0rad/s", "--rules", "thresholds"]  # gate needs an operating point; these check theory 8's rules
BAD_OPTIONS = [["--threshold", "dI_L=nan"], ["--threshold", "dI_Q=-1"], ["--threshold", "dI_fT=inf"],
               ["--sigma-allow", "nan"], ["--sigma-allow", "0"], ["--q-cap", "-1"], ["--n-ratio", "0"],
               ["--f-sys", "inf"], ["--deflection-cap", "nan"]]
CASES = [("analyze", a) for a in BAD_OPTIONS] + [("gate", a) for a in BAD_OPTIONS if a[0] in ("--threshold", "--f-sys")]


@pytest.mark.parametrize("command, args", CASES)
def test_nan_negative_or_infinite_options_are_rejected_in_one_line(command, args):
    extra = ["--max-level", "IV", "--speed", "0rad/s"] if command == "gate" else []
    result = runner.invoke(app, [command, str(SAMPLE), *extra, *args])
    assert result.exit_code == 2 and ("expected a finite" in result.output or "whole number" in result.output)
    assert len(result.output.strip().splitlines()) == 1


def test_a_nan_threshold_in_a_config_file_is_rejected(tmp_path):
    cfg = tmp_path / "ffrf-advisor.toml"
    cfg.write_text("[thresholds]\ndI_L = nan\n")
    result = runner.invoke(app, ["analyze", str(SAMPLE), "--config", str(cfg)])
    assert result.exit_code == 2 and "thresholds.dI_L" in result.output and "finite" in result.output


def test_an_assumption_failure_is_a_warning_in_analyze_json_and_in_gate_junit(tmp_path):
    """Modes scaled by 1.01 are not mass-normalised (theory section 1, assumption 3): every command that
    analyses the body says so (issue 12)."""
    import xml.etree.ElementTree as ET
    from dataclasses import replace as dc_replace

    from ffrf_advisor.invariants import shape_integrals
    from ffrf_advisor.io import read_body, write_body
    body = read_body(SAMPLE, load_fe=True)
    Phi = body.fe.Phi * 1.01
    bad = dc_replace(body, integrals=shape_integrals(body.fe.mesh.points, body.fe.Ms, Phi),
                     fe=dc_replace(body.fe, Phi=Phi))
    path = tmp_path / "unnormalised.ffrf.h5"
    write_body(bad, path)
    result = runner.invoke(app, ["analyze", str(path), "--json"])
    data = json.loads(result.stdout)
    failed = [c["name"] for c in data["checks"] if not c["passed"]]
    assert "mass_normalisation" in failed and any("mass_normalisation failed" in w for w in data["warnings"])
    junit = tmp_path / "gate.xml"
    gate = runner.invoke(app, ["gate", *AT_REST, str(path), "--max-level", "IV", "--junit", str(junit)])
    assert gate.exit_code == 0
    assert "mass_normalisation failed" in next(ET.parse(junit).getroot().iter("testcase")).find("system-out").text
    good = json.loads(runner.invoke(app, ["analyze", str(SAMPLE), "--json"]).stdout)
    assert all(c["passed"] for c in good["checks"]) and not any("check" in w for w in good["warnings"])


def test_spin_axis_from_the_command_line_and_the_config(tmp_path):
    """1, 2, 3 are principal axes, X,Y,Z a body-frame direction (issue 22)."""
    one = json.loads(runner.invoke(app, ["analyze", str(SAMPLE), "--speed", "200", "--spin-axis", "2",
                                         "--json"]).stdout)
    assert one["situation"]["principal_axis"] == 2 and one["situation"]["spin_axis"] is None
    assert all("principal axis 2" in r["reason"] for r in one["rules"] if r["value"] is not None)
    vector = json.loads(runner.invoke(app, ["analyze", str(SAMPLE), "--speed", "200", "--spin-axis", "0,1,0",
                                            "--json"]).stdout)
    assert vector["situation"]["spin_axis"] == [0.0, 1.0, 0.0]
    assert all("spin axis 0, 1, 0" in r["reason"] for r in vector["rules"] if r["value"] is not None)
    every = json.loads(runner.invoke(app, ["analyze", str(SAMPLE), "--speed", "200", "--json"]).stdout)
    assert every["situation"]["spin_axis"] is None and any("principal axis" in r["reason"] for r in every["rules"])
    cfg = tmp_path / "ffrf-advisor.toml"
    cfg.write_text("spin_axis = [0.0, 0.6, 0.8]\n")
    tilted = json.loads(runner.invoke(app, ["analyze", str(SAMPLE), "--config", str(cfg), "--json"]).stdout)
    assert tilted["situation"]["spin_axis"] == [0.0, 0.6, 0.8]
    bad = runner.invoke(app, ["analyze", str(SAMPLE), "--spin-axis", "4,x"])
    assert bad.exit_code == 2 and "--spin-axis" in bad.output


def _body_with_eigenvalues(tmp_path, name, eigenvalues):
    from dataclasses import replace as dc_replace

    from ffrf_advisor.io import read_body, write_body
    body = read_body(SAMPLE)
    path = tmp_path / f"{name}.ffrf.h5"
    write_body(dc_replace(body, eigenvalues=np.asarray(eigenvalues, float)), path)
    return path


@pytest.mark.parametrize("command", ["info", "analyze", "settings", "compare"])
def test_non_positive_eigenvalues_are_one_line_and_exit_2_in_every_command(tmp_path, command):
    from ffrf_advisor.io import read_body
    lam = np.array(read_body(SAMPLE).eigenvalues)
    lam[3] = -lam[3]
    path = _body_with_eigenvalues(tmp_path, "negative", lam)
    result = runner.invoke(app, [command, str(path)])
    assert result.exit_code == 2 and "eigenvalues" in result.output and "mode 4" in result.output
    assert len(result.output.strip().splitlines()) == 1 and "Traceback" not in result.output


def test_unsorted_modes_are_sorted_with_everything_per_mode_and_said_so(tmp_path):
    from ffrf_advisor.io import read_body
    body = read_body(SAMPLE)
    order = np.arange(body.nf)[::-1]
    path = tmp_path / "reversed.ffrf.h5"
    from ffrf_advisor.io import write_body
    write_body(body.with_modes(order), path)
    back = read_body(path)
    assert np.array_equal(back.eigenvalues, body.eigenvalues)
    assert np.allclose(back.integrals.Sbar, body.integrals.Sbar, rtol=0, atol=1e-15)
    assert np.allclose(back.sigma_max, body.sigma_max, rtol=0, atol=0)
    assert any("sorted by eigenvalue" in n for n in back.provenance.notes)


def test_gate_reports_every_body_of_a_mix_of_good_and_broken_ones(tmp_path):
    import xml.etree.ElementTree as ET

    from ffrf_advisor.io import read_body
    lam = np.array(read_body(SAMPLE).eigenvalues)
    lam[0] = 0.0
    broken = _body_with_eigenvalues(tmp_path, "zero", lam)
    missing = tmp_path / "missing.ffrf.h5"
    junit = tmp_path / "gate.xml"
    result = runner.invoke(app, ["gate", *AT_REST, str(SAMPLE), str(broken), str(missing), "--max-level", "IV",
                                 "--junit", str(junit)])
    assert result.exit_code == 2 and "Traceback" not in result.output
    cases = list(ET.parse(junit).getroot().iter("testcase"))
    assert [c.get("name") for c in cases] == [str(SAMPLE), str(broken), str(missing)]
    assert cases[0].find("error") is None and cases[1].find("error") is not None and cases[2].find("error") is not None


@pytest.mark.parametrize("content, message", [('sigma_allow = "abc"\n', "--sigma-allow"),
                                              ("thresholds = 5\n", "config thresholds"),
                                              ("f_sys = 0\n", "--f-sys")])
def test_config_values_of_the_wrong_type_are_one_line(tmp_path, content, message):
    cfg = tmp_path / "ffrf-advisor.toml"
    cfg.write_text(content)
    result = runner.invoke(app, ["analyze", str(SAMPLE), "--config", str(cfg)])
    assert result.exit_code == 2 and message in result.output and len(result.output.strip().splitlines()) == 1



def test_junit_is_valid_xml_with_testsuites_and_times_and_never_replaces_an_input_or_a_special_file(tmp_path):
    import os
    junit = tmp_path / "gate.xml"
    odd = tmp_path / "beam\x01odd.ffrf.h5"
    odd.write_bytes(SAMPLE.read_bytes())
    result = runner.invoke(app, ["gate", *AT_REST, str(SAMPLE), str(odd), "--max-level", "iv", "--junit", str(junit)])
    assert result.exit_code == 0, result.output
    root = ET.parse(junit).getroot()
    assert root.tag == "testsuites" and root.find("testsuite").get("tests") == "2"
    assert all(float(c.get("time")) > 0 for c in root.iter("testcase"))
    copy = tmp_path / "copy.ffrf.h5"
    copy.write_bytes(SAMPLE.read_bytes())
    stamp = copy.stat().st_mtime_ns
    same = runner.invoke(app, ["gate", *AT_REST, str(copy), "--max-level", "IV", "--junit", str(copy)])
    assert same.exit_code == 2 and "body of this run" in same.output and copy.stat().st_mtime_ns == stamp
    notes = tmp_path / "notes.txt"
    notes.write_text("mine")
    mine = runner.invoke(app, ["gate", *AT_REST, str(SAMPLE), "--max-level", "IV", "--junit", str(notes)])
    assert mine.exit_code == 2 and "not a JUnit report" in mine.output and notes.read_text() == "mine"
    link = tmp_path / "link.xml"
    os.symlink(notes, link)
    linked = runner.invoke(app, ["gate", *AT_REST, str(SAMPLE), "--max-level", "IV", "--junit", str(link), "--force"])
    assert linked.exit_code == 2 and "regular file" in linked.output and notes.read_text() == "mine"
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    special = runner.invoke(app, ["convert", str(SAMPLE), str(fifo), "--to", "ffrf-h5", "--force"])
    assert special.exit_code == 2 and "regular file" in special.output


@pytest.mark.parametrize("command", ["analyze", "gate", "compare"])
def test_every_analysing_command_takes_the_same_analysis_options(command):
    """The README's analysis options apply to analyze, gate and compare alike (issue 14)."""
    extra = ["--max-level", "IV", "--json"] if command == "gate" else ["--json"]
    args = ["--speed", "100", "--sigma-allow", "250", "--q-cap", "0.5", "--n-ratio", "6", "--spin-axis", "3",
            "--threshold", "dI_Q=0.5", "--rules", "thresholds"]
    result = runner.invoke(app, [command, str(SAMPLE), *extra, *args])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    body = data["bodies"][0] if command != "analyze" else data
    if command == "gate":
        body = body["analysis"]
    if command == "compare":
        assert body["q_max"][0] == pytest.approx(min(0.5, 250.0 / body["sigma_max"][0]), rel=1e-12)
    else:
        assert body["amplitudes"]["sigma_allow"] == 250.0 and body["significance"]["n_ratio"] == 6
        dI_Q = next(r for r in body["rules"] if r["name"] == "dI_Q")
        assert body["situation"]["principal_axis"] == 3 and dI_Q["threshold"] == 0.5 and not dI_Q["fired"]


@pytest.mark.slow  # a whole report: about 10 s
def test_a_set_is_called_the_same_in_analyze_simulate_and_the_report(tmp_path):
    """One word for one thing (issue 25): terms.lagrangian_status, in every text output."""
    from ffrf_advisor.terms import lagrangian_status
    args = [str(SAMPLE), "--speed", "300rad/s"]
    terms = json.loads(runner.invoke(app, ["analyze", *args, "--json"]).stdout)["terms"]
    status = lagrangian_status(terms)
    assert status == "Lagrangian + geo_stiff" and lagrangian_status(["gyro0", "cf1"]) == "not Lagrangian"
    assert f"({status})" in runner.invoke(app, ["analyze", *args]).stdout
    simulated = runner.invoke(app, ["simulate", *args, "--terms", "advised", "--t-end", "1e-4"]).stdout
    assert f"terms: {', '.join(terms)} ({status})" in " ".join(simulated.split())
    runner.invoke(app, ["report", *args, "-o", str(tmp_path / "r.html")])
    assert f"<dt>Lagrangian</dt><dd>{status}</dd>" in (tmp_path / "r.html").read_text()


def test_analyze_and_compare_stay_right_at_80_columns():
    """Stacked evidence: every term of the advice appears whole, no line is wider than 80; compare's labels
    carry units and each body's values stay in its own column."""
    text = runner.invoke(app, ["analyze", str(SAMPLE), "--speed", "300rad/s"], env={"COLUMNS": "80"}).stdout
    assert max(len(line) for line in text.splitlines()) <= 80
    advice = json.loads(runner.invoke(app, ["analyze", str(SAMPLE), "--speed", "300rad/s", "--json"]).stdout)
    assert "(Lagrangian + geo_stiff)" in text and "not Lagrangian" not in text  # geo_stiff is not a drift warning
    evidence = text[text.index("evidence per rule"):]
    assert all(term in evidence for term in advice["terms"] if term != "gyro0") and "…" not in evidence
    plate = SAMPLE.parent / "plate.ffrf.h5"
    table = runner.invoke(app, ["compare", str(SAMPLE), str(plate), "--speed", "1rad/s"], env={"COLUMNS": "80"}).stdout
    assert max(len(line) for line in table.splitlines()) <= 80
    assert "mass [t]" in table and "q_max [sqrt(t) mm]" in table and "f [Hz]" in table
    mass_row = next(line for line in table.splitlines() if line.startswith("│ mass"))
    assert mass_row.split("│")[2].strip() == "0.00628" and mass_row.split("│")[3].strip() == "0.00353"


@pytest.mark.parametrize("command, extra", [
    ("info", []),
    ("analyze", ["--speed", "300rad/s"]),
    ("gate", ["--max-level", "IV", "--speed", "300rad/s"]),
    ("compare", ["--speed", "1rad/s"]),
    ("settings", ["--speed", "300rad/s"]),
    ("modes", ["--speed", "300rad/s"]),
    ("diff", [str(SAMPLE), "--speed", "300rad/s"]),
])
def test_every_json_output_follows_its_documented_schema(command, extra):
    """One documented schema per command, shipped in the package and printed by `schema` (simulate and verify
    are checked in their own tests); the help names it, and a broken document fails it."""
    printed = runner.invoke(app, ["schema", command])
    assert printed.exit_code == 0
    spec = json.loads(printed.stdout)
    assert spec == schema(command)
    result = runner.invoke(app, [command, str(SAMPLE), *extra, "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    jsonschema.validate(data, spec)
    if command == "gate":
        jsonschema.validate(data["bodies"][0]["analysis"], SCHEMA)
    helptext = " ".join(runner.invoke(app, [command, "--help"], env={"COLUMNS": "200"}).stdout.split())
    assert f"ffrf-advisor schema {command}" in helptext
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({**data, "schema_version": 99}, spec)


@pytest.mark.slow
def test_the_wheel_ships_the_schemas_and_the_license(tmp_path):
    """`pip install .` gives a package whose `schema` command works anywhere: the wheel holds the JSON
    schemas and the LICENSE, not only .py files."""
    import subprocess
    import sys
    import zipfile
    root = Path(__file__).resolve().parent.parent
    done = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q",
                           "-w", str(tmp_path), str(root)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    names = zipfile.ZipFile(next(tmp_path.glob("*.whl"))).namelist()
    for command in ("info", "analyze", "gate", "compare", "settings", "simulate", "verify"):
        assert f"ffrf_advisor/schemas/{command}.json" in names
    assert any(n.endswith("/LICENSE") for n in names)


def test_gate_names_each_file_once(tmp_path):
    bad = tmp_path / "bad.ffrf.h5"
    bad.write_bytes(b"x")
    result = runner.invoke(app, ["gate", *AT_REST, str(SAMPLE), str(bad), "--max-level", "IV"], env={"COLUMNS": "300"})
    assert result.exit_code == 2
    squashed = "".join(result.stdout.split())  # a long temporary path may be folded by the console
    assert squashed.count(str(bad)) == 1 and squashed.count(str(SAMPLE)) == 1
    assert "ERROR" in squashed and "expected" in squashed and "ok" in squashed


def _blas_threads() -> list[int]:
    import numpy  # noqa: F401 - loads the BLAS that threadpoolctl looks for
    from threadpoolctl import threadpool_info
    return [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]


def test_pool_workers_use_one_blas_thread_each():
    """gate, verify and the sweep with --jobs N: BLAS's own threads on top of N workers made gate --jobs 2
    slower than --jobs 1 (issue 24, item 7; benchmarks/bench_gate.py measures the ratio)."""
    from ffrf_advisor.pool import local_pool

    with local_pool(1) as pool:
        threads = pool.submit(_blas_threads).result()
    assert threads and set(threads) == {1}, threads
