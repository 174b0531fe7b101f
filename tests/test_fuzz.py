"""Damaged inputs end in the project's one-line error: never a traceback, a hang or a huge allocation."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

import meshio
import numpy as np
import pytest
from typer.testing import CliRunner

from ffrf_advisor.cli import app
from ffrf_advisor.fe_body import modal_body
from ffrf_advisor.fe.material import STEEL
from ffrf_advisor.fe.mesh import box_mesh
from ffrf_advisor.io import write_body
from ffrf_advisor.io.calculix import write_deck

from . import fuzz_readers
from .fuzz_readers import counted, damage

CASES = 600  # per reader (each read and analysed in a guarded child)
HARNESS = Path(__file__).resolve().parent / "fuzz_readers.py"
MESH = box_mesh([60.0, 20.0, 10.0], [3, 1, 1], "hexahedron20")
NF = 4


@pytest.fixture(scope="module")
def seeds(tmp_path_factory):
    """One small valid file per reader, with the reader options it needs."""
    d = tmp_path_factory.mktemp("seeds")
    body = modal_body(MESH, STEEL, NF, name="seed")
    out = {}
    for name in ("seed.ffrf.h5", "seed.ffinv.json", "seed.ffinv.h5"):
        write_body(body, d / name)
        out[name] = {}
    fe = body.fe
    point_data = {f"mode_{p + 1}": fe.Phi[:, :, p] for p in range(NF)}
    meshio.write(d / "seed.vtu", meshio.Mesh(fe.mesh.points, list(fe.mesh.cells.items()), point_data=point_data))
    out["seed.vtu"] = {"eigenvalues": body.eigenvalues.tolist(), "density": STEEL.rho}
    if shutil.which("ccx"):
        for job, binary in (("ascii", False), ("binary", True)):
            (d / job).mkdir()
            write_deck(MESH, STEEL, NF, d / job / "seed.inp", binary=binary)
            subprocess.run(["ccx", "seed"], cwd=d / job, capture_output=True, timeout=300, check=True)
            out[f"{job}/seed.frd"] = {}
    return d, out


READERS = ["seed.ffrf.h5", "seed.ffinv.json", "seed.ffinv.h5", "seed.vtu", "ascii/seed.frd", "binary/seed.frd"]


@pytest.mark.slow
@pytest.mark.parametrize("name", READERS)
def test_reader_survives_thousands_of_damaged_files(seeds, name):
    d, options = seeds
    if name not in options:
        pytest.skip("CalculiX (ccx) is not installed")
    done = subprocess.run([sys.executable, str(HARNESS), str(d / name), str(CASES), "20261121",
                           json.dumps(options[name])], capture_output=True, text=True, timeout=1800)
    counts = counted(done, CASES)
    assert counts["one_line_error"] > CASES // 4


NASTRAN = Path(__file__).resolve().parents[2] / "shared" / "data" / "nastran" / "beam_modes_m1.op2"
OP2_CASES = 100  # about 0.4 s each (pyNastran in the guarded child)


@pytest.mark.slow
def test_the_nastran_reader_survives_hundreds_of_damaged_files():
    pytest.importorskip("pyNastran", reason="the Nastran reader's optional extra")
    if not NASTRAN.is_file():
        pytest.skip(f"the shared Nastran file is not at {NASTRAN}")
    done = subprocess.run([sys.executable, str(HARNESS), str(NASTRAN), str(OP2_CASES), "20261122"],
                          capture_output=True, text=True, timeout=1800)
    counted(done, OP2_CASES)


@pytest.mark.slow  # four formats' damage through the whole CLI: 5-6 s (the one-line errors of bad input have
# their default tests in test_cli.py and test_hostile_options.py)
def test_damaged_files_through_the_cli_give_one_line_and_exit_2(seeds, tmp_path):
    """Byte and structural damage (huge shapes, links, long strings), read and analysed through the CLI."""
    d, _ = seeds
    rng = np.random.default_rng(7)
    runner = CliRunner()
    for name, extra in (("seed.ffrf.h5", []), ("seed.ffinv.json", []), ("seed.ffinv.h5", []),
                        ("seed.vtu", ["--density", "1", "--eigenvalues", "1,2,3,4"])):
        data = (d / name).read_bytes()
        for _ in range(15):
            path = tmp_path / name
            damage(d / name, data, path, rng)
            result = runner.invoke(app, ["analyze", str(path), "--speed", "300rad/s", *extra])
            assert result.exit_code in (0, 2), result.output
            if result.exit_code == 2:
                assert len(result.output.strip().splitlines()) == 1 and "Traceback" not in result.output


def test_the_harness_counts_a_timeout_and_an_analysis_error_as_failures(seeds, monkeypatch):
    d, _ = seeds
    monkeypatch.setattr(fuzz_readers, "CASE_SECONDS", 1)
    monkeypatch.setattr(fuzz_readers, "read_body", lambda *a, **k: time.sleep(3))
    assert fuzz_readers.main(str(d / "seed.ffinv.json"), 1, 0, {})["counts"]["hang"] == 1
    monkeypatch.setattr(fuzz_readers, "read_body", lambda *a, **k: None)  # the analysis fails on it
    report = fuzz_readers.main(str(d / "seed.ffinv.json"), 1, 0, {})
    assert report["counts"]["traceback"] == 1 and "AttributeError" in report["offending"][0]["error"]
