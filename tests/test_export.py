"""`export --solver exudyn` (issue 27, item 4) and `--modes advised` of convert and export: the files
EXUDYN's ObjectFFRFreducedOrder takes, checked by nodal sums here; the script run in EXUDYN (its own venv,
.ci/run) against `simulate` with the full set."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
from typer.testing import CliRunner

from ffrf_advisor.analysis import Options, analyze
from ffrf_advisor.cli import app
from ffrf_advisor.guidelines import Situation
from ffrf_advisor.io import read_body
from ffrf_advisor.modeset import advise_modes

BEAM = Path(__file__).resolve().parent.parent / "sample_bodies" / "beam.ffrf.h5"
runner = CliRunner()
ROUND_OFF = 1e-12  # nodal sums in another order than the body's invariants (double precision, 10^4 nodes)


def _export(tmp_path, *extra):
    out = tmp_path / "exudyn"
    r = runner.invoke(app, ["export", str(BEAM), "-o", str(out), *extra])
    assert r.exit_code == 0, r.output
    return out, r


def _npz(out: Path) -> dict:
    with np.load(out / "body.npz", allow_pickle=False) as f:
        return {k: f[k] for k in f.files}


def test_export_writes_the_body_exudyn_builds_its_invariants_from(tmp_path):
    """Mass, centre of mass and inertia about it summed over the exported nodes and mass matrix (as EXUDYN's
    FEMinterface does) equal the body's; the modes are mass-normalised in it (Phi^T M Phi = I)."""
    out, r = _export(tmp_path, "--t-end", "0.01")
    assert "every inertia term" in r.output  # EXUDYN has no term switches: the output says so
    body, d = read_body(BEAM, load_fe=True), _npz(out)
    M = sp.csr_array((d["mass_data"], d["mass_indices"], d["mass_indptr"]), shape=tuple(d["mass_shape"]))
    X, Psi = d["nodes"], d["modes"]
    ones = np.tile(np.eye(3), (len(X), 1))  # rigid translations, node-interleaved
    Mtt = ones.T @ (M @ ones)
    mass = Mtt[0, 0]
    com = (ones.T @ (M @ X.ravel())) / mass
    r_ = X - com
    Rt = np.zeros((3 * len(X), 3))  # rigid rotations about the CoM: u = e_k x r
    for k in range(3):
        Rt[:, k] = np.cross(np.eye(3)[k], r_).ravel()
    assert mass == pytest.approx(body.mass, rel=ROUND_OFF)
    assert np.allclose(Mtt, mass * np.eye(3), rtol=0, atol=ROUND_OFF * mass)
    assert np.allclose(com, body.com, rtol=0, atol=ROUND_OFF * np.abs(X).max())
    assert np.allclose(Rt.T @ (M @ Rt), body.I0, rtol=0, atol=ROUND_OFF * np.abs(body.I0).max())
    assert np.allclose(Psi.T @ (M @ Psi), np.eye(body.nf), rtol=0, atol=1e-10)  # the file's mass-normalisation
    assert np.array_equal(d["eigenvalues"], body.eigenvalues)
    assert str(d["length_unit"]) == body.units.length


def test_export_scene_step_divides_the_end_time(tmp_path):
    out, _ = _export(tmp_path, "--omega0", "0,0,300", "--q0", "qmax", "--t-end", "0.01", "--step", "3e-6",
                     "--output-step", "1e-4")
    scene = json.loads((out / "scene.json").read_text())
    n, every = scene["t_end"] / scene["step"], scene["output_step"] / scene["step"]
    assert scene["t_end"] == 0.01 and scene["omega0"] == [0.0, 0.0, 300.0]
    assert abs(n - round(n)) < 1e-9 and scene["step"] <= 3e-6
    assert abs(every - round(every)) < 1e-9 and abs(scene["output_step"] - 1e-4) <= scene["step"] / 2
    body = read_body(BEAM)
    assert len(scene["q0"]) == body.nf and max(scene["q0"]) > 0


def test_export_refuses_in_one_line(tmp_path):
    inv = tmp_path / "beam.ffinv.json"
    assert runner.invoke(app, ["convert", str(BEAM), str(inv)]).exit_code == 0
    cases = [(["export", str(inv), "-o", str(tmp_path / "a")], "invariants only"),
             (["export", str(BEAM), "-o", str(tmp_path / "b"), "--solver", "adams"], "settings --solver"),
             (["export", str(BEAM), "-o", str(inv)], "got a file")]
    for args, words in cases:
        r = runner.invoke(app, args)
        assert r.exit_code == 2 and words in r.output and len(r.output.strip().splitlines()) == 1, r.output
    out, _ = _export(tmp_path, "--t-end", "0.01")
    before = (out / "scene.json").read_text()
    r = runner.invoke(app, ["export", str(BEAM), "-o", str(out), "--t-end", "0.02"])
    assert r.exit_code == 2 and ("scene.json" in r.output or "body.npz" in r.output)
    assert (out / "scene.json").read_text() == before  # nothing the user owns is replaced without --force


def test_convert_modes_advised_writes_the_advised_body(tmp_path):
    """convert --modes advised = the mode set `modes` advises with the default options (kept modes plus
    residual vectors, theory 12)."""
    target = tmp_path / "beam_advised.ffrf.h5"
    r = runner.invoke(app, ["convert", str(BEAM), str(target), "--modes", "advised"])
    assert r.exit_code == 0, r.output
    advice = advise_modes(analyze(read_body(BEAM, load_fe=True), Options()))
    reduced = read_body(target)
    assert reduced.nf == advice.size < read_body(BEAM).nf
    assert "mode set (theory 12)" in " ".join(reduced.provenance.notes)
    fem = tmp_path / "beam_advised.fem"  # MBDyn's modal element with the advised modes (issue 27, item 3)
    assert runner.invoke(app, ["convert", str(BEAM), str(fem), "--modes", "advised"]).exit_code == 0
    assert np.array_equal(read_body(fem).eigenvalues, reduced.eigenvalues)
    r = runner.invoke(app, ["convert", str(BEAM), str(tmp_path / "x.ffrf.h5"), "--modes", "some"])
    assert r.exit_code == 2 and "--modes 'some'" in r.output


def _rotation(p: np.ndarray) -> np.ndarray:
    """Row-major rotation matrices body to global of unit Euler parameters p0..p3 (rows)."""
    e0, e1, e2, e3 = p.T
    return np.stack([e0**2 + e1**2 - e2**2 - e3**2, 2 * (e1 * e2 - e0 * e3), 2 * (e1 * e3 + e0 * e2),
                     2 * (e1 * e2 + e0 * e3), e0**2 - e1**2 + e2**2 - e3**2, 2 * (e2 * e3 - e0 * e1),
                     2 * (e1 * e3 - e0 * e2), 2 * (e2 * e3 + e0 * e1), e0**2 - e1**2 - e2**2 + e3**2], axis=1)


AGREE = 1e-6  # issue 27: EXUDYN's RK44 at h Omega_max = 0.1 (phase error ~1e-7 per period of the top mode)
# against our DOP853 at rtol 1e-12; measured 1e-8 in w and 2e-7 in q on this scene


@pytest.mark.slow
def test_the_exported_script_runs_in_exudyn_as_simulate_does(tmp_path):
    """The beam spun fast with every mode at q_max for 10 ms: EXUDYN's trajectory (w, rotation, q) equals
    `simulate --terms full` to AGREE relative to each quantity's largest value."""
    pytest.importorskip("exudyn")
    scene = ["--omega0", "10,5,300", "--q0", "qmax", "--t-end", "0.01"]
    out, _ = _export(tmp_path, *scene)
    subprocess.run([sys.executable, str(out / "run_exudyn.py"), "-o", str(tmp_path / "exudyn.csv")], check=True,
                   capture_output=True, timeout=600)
    h = json.loads((out / "scene.json").read_text())["step"]
    r = runner.invoke(app, ["simulate", str(BEAM), *scene, "--terms", "full", "--rtol", "1e-12", "--atol", "1e-14",
                            "--output-step", repr(h), "-o", str(tmp_path / "ours.csv")])
    assert r.exit_code == 0, r.output
    ex = np.loadtxt(tmp_path / "exudyn.csv", delimiter=",", skiprows=1)
    ours = np.loadtxt(tmp_path / "ours.csv", delimiter=",", skiprows=1)
    k = np.rint(ex[:, 0] / h).astype(int)
    assert len(ex) > 100 and np.abs(k * h - ex[:, 0]).max() < 1e-9 * h and k[-1] == len(ours) - 1
    ours = ours[k]
    nf = read_body(BEAM).nf
    pairs = {"w": (ex[:, 1:4], ours[:, 1:4]), "R": (ex[:, 4:13], _rotation(ours[:, 4:8])),
             "q": (ex[:, 13:13 + nf], ours[:, 8:8 + nf])}
    for name, (a, b) in pairs.items():
        assert np.abs(a - b).max() <= AGREE * np.abs(b).max(), name


def test_an_export_that_fails_midway_leaves_the_old_folder_whole(tmp_path, monkeypatch):
    """The files go to a temporary sibling folder renamed into place: a failure after body.npz and scene.json
    were written leaves the old three files (not a new body.npz beside an old scene.json) and no temporary."""
    from ffrf_advisor.export import exudyn
    out, _ = _export(tmp_path, "--t-end", "0.01")
    before = {p.name: p.read_bytes() for p in out.iterdir()}

    def full_disk(*_args):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(exudyn.shutil, "copyfile", full_disk)
    r = runner.invoke(app, ["export", str(BEAM), "-o", str(out), "--t-end", "0.02", "--force"])
    assert r.exit_code == 2 and "No space left on device" in r.output and len(r.output.strip().splitlines()) == 1
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["exudyn"]


def test_export_replaces_a_folder_of_its_own_files_only(tmp_path):
    """The folder is replaced whole, so one holding anything else is refused (its files would go), and its own
    files are replaced only with --force."""
    out, _ = _export(tmp_path, "--t-end", "0.01")
    r = runner.invoke(app, ["export", str(BEAM), "-o", str(out), "--t-end", "0.02"])
    assert r.exit_code == 2 and "use --force" in r.output
    (out / "notes.txt").write_text("mine")
    r = runner.invoke(app, ["export", str(BEAM), "-o", str(out), "--t-end", "0.02", "--force"])
    assert r.exit_code == 2 and "'notes.txt'" in r.output and (out / "notes.txt").read_text() == "mine"
    (out / "notes.txt").unlink()
    r = runner.invoke(app, ["export", str(BEAM), "-o", str(out), "--t-end", "0.02", "--force"])
    assert r.exit_code == 0 and json.loads((out / "scene.json").read_text())["t_end"] == pytest.approx(0.02)
