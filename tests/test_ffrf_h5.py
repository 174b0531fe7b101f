"""The .ffrf.h5 format: round trip, lazy reading, every reader error, atomic writes."""
from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

import h5py
import numpy as np
import pytest

from ffrf_advisor.errors import BodyFileError, FFRFError
from ffrf_advisor.io import ffrf_h5, guard, h5_checksums, read_body, write_body


@pytest.fixture
def body_file(tmp_path, block_body):
    path = tmp_path / "block.ffrf.h5"
    write_body(block_body, path)
    return path


def restamp(path) -> None:
    """Record the cache checksum of ``path`` as it now is (a file changed by a writer that checksums it)."""
    with h5py.File(path, "r+") as f:
        h5_checksums.stamp_cache(f)


def test_round_trip_with_nodal_data(body_file, block_body):
    back = read_body(body_file, load_fe=True)
    assert back.name == block_body.name and back.units == block_body.units
    assert back.provenance == block_body.provenance
    assert np.array_equal(back.eigenvalues, block_body.eigenvalues)
    assert np.array_equal(back.sigma_max, block_body.sigma_max)
    fe, ref = back.fe, block_body.fe
    assert np.array_equal(fe.mesh.points, ref.mesh.points)
    assert all(np.array_equal(fe.mesh.cells[k], ref.mesh.cells[k]) for k in ref.mesh.cells)
    assert (abs(fe.Ms - ref.Ms)).max() == 0 and (abs(fe.K - ref.K)).max() == 0
    assert np.array_equal(fe.Phi, ref.Phi) and np.array_equal(fe.stress_nodal, ref.stress_nodal)
    cached = read_body(body_file)
    for name in ("I", "Ibar", "Sbar", "mode_sum", "first_moment"):
        assert np.array_equal(getattr(cached.integrals, name), getattr(block_body.integrals, name))
        a, b = getattr(back.integrals, name), getattr(block_body.integrals, name)  # recomputed
        assert np.abs(a - b).max() <= 1e-12 * max(np.abs(b).max(), 1e-300) + 1e-15
    assert cached.mass == block_body.mass


def test_round_trip_of_an_invariants_only_body(tmp_path, block_body):
    path = tmp_path / "inv.ffrf.h5"
    write_body(replace(block_body, fe=None), path)
    back = read_body(path)
    assert back.fe is None and np.array_equal(back.integrals.Sbar, block_body.integrals.Sbar)
    assert read_body(path, load_fe=True).fe is None  # load_fe loads nodal data when there are any


def test_default_read_does_not_touch_nodal_datasets(body_file, monkeypatch):
    monkeypatch.setattr(guard, "FORK", False)  # the spy must see the reading, so it runs in this process
    touched = []
    original = h5py.Dataset.__getitem__

    def spy(self, key):
        touched.append(self.name)
        return original(self, key)

    monkeypatch.setattr(h5py.Dataset, "__getitem__", spy)
    read_body(body_file)
    assert touched and not any(n.startswith(("/modes/Phi", "/mass", "/mesh", "/stiffness", "/stress/nodal"))
                               for n in touched)


def _mutate(path: Path, fn):
    with h5py.File(path, "r+") as f:
        fn(f)


def _replace(name, data):
    def fn(f):
        del f[name]
        f[name] = data
    return fn


def _set_attr(name, value, obj="/"):
    def fn(f):
        f[obj].attrs[name] = value
    return fn


def _csr_entry(f):
    f["mass/Ms/data"][0] = -abs(f["mass/Ms/data"][0]) * 1e6  # breaks positivity of the diagonal


def _nan_phi(f):
    f["modes/Phi"][0, 0, 0] = np.nan


BROKEN = {
    "missing eigenvalues": (lambda f: f.__delitem__("modes/eigenvalues"), "modes/eigenvalues"),
    "missing mass": (lambda f: (f.__delitem__("mass"), f.__delitem__("invariants")), "mass/Ms"),
    "missing Phi": (lambda f: (f.__delitem__("modes/Phi"), f.__delitem__("invariants")), "modes/Phi"),
    "Phi shape": (lambda f: (_replace("modes/Phi", np.zeros((3, 3)))(f), f.__delitem__("invariants")), "modes/Phi"),
    "NaN in Phi": (lambda f: (_nan_phi(f), f.__delitem__("invariants")), "modes/Phi"),
    "NaN eigenvalue": (_replace("modes/eigenvalues", np.array([np.nan] * 10)), "modes/eigenvalues"),
    "inf stress": (_replace("stress/max", np.array([np.inf] * 10)), "stress/max"),
    "stress shape": (_replace("stress/max", np.ones(3)), "stress/max"),
    "negative mass": (lambda f: (_csr_entry(f), f.__delitem__("invariants")), "mass/Ms"),
    "cached mass": (_set_attr("mass", -1.0, "invariants"), "invariants@mass"),
    "Sbar shape": (_replace("invariants/Sbar", np.zeros((3, 3, 2, 2))), "invariants/Sbar"),
    "unknown version": (_set_attr("version", 99), "@version"),
    "wrong format": (_set_attr("format", "something"), "@format"),
    "bad units": (_set_attr("units", "furlong-fortnight"), "@units"),
    "cells out of range": (lambda f: (f["mesh/cells/hexahedron27"].__setitem__((0, 0), 10**6),
                                      f.__delitem__("invariants")), "mesh/cells/hexahedron27"),
    "CSR indptr": (lambda f: (_replace("mass/Ms/indptr", np.arange(5))(f), f.__delitem__("invariants")),
                   "mass/Ms/indptr"),
    "points dtype": (lambda f: (_replace("mesh/points", np.array(["a"] * 3, dtype="S1").reshape(1, 3))(f),
                                f.__delitem__("invariants")), "mesh/points"),
}


@pytest.mark.parametrize("case", list(BROKEN))
def test_reader_errors_name_the_field(case, body_file):
    mutate, field = BROKEN[case]
    _mutate(body_file, mutate)
    with pytest.raises(BodyFileError) as info:
        read_body(body_file)
    message = str(info.value)
    assert message.startswith(str(body_file)) and field in message and "\n" not in message


def test_not_hdf5_and_missing_file(tmp_path):
    junk = tmp_path / "junk.ffrf.h5"
    junk.write_bytes(b"\x89HDF\r\n not really")
    with pytest.raises(BodyFileError, match="HDF5"):
        read_body(junk)
    with pytest.raises(BodyFileError, match="not found"):
        read_body(tmp_path / "none.ffrf.h5")


def test_writer_refuses_to_overwrite_and_is_atomic(body_file, block_body, monkeypatch):
    before = body_file.read_bytes()
    with pytest.raises(FFRFError, match="overwrite"):
        write_body(block_body, body_file)

    def boom(*args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr(ffrf_h5, "_write_fe", boom)
    with pytest.raises(FFRFError, match="write: expected to write the file, got RuntimeError: disk full"):
        write_body(block_body, body_file, overwrite=True)
    assert body_file.read_bytes() == before
    assert [p.name for p in body_file.parent.iterdir()] == [body_file.name]


def test_a_terminated_writer_leaves_no_temporary_and_a_killed_ones_is_swept(tmp_path, block_body):
    """SIGTERM while writing removes the temporary file; one left by SIGKILL goes with the next write to the
    same target (its process is gone), while another target's temporary stays."""
    import signal
    import subprocess
    import sys
    import time
    script = ("import sys, time\nfrom ffrf_advisor.io.atomic import atomic_path\n"
              "with atomic_path(sys.argv[1]) as tmp:\n    tmp.write_bytes(b'x' * 1000)\n"
              "    print('ready', flush=True)\n    for _ in range(600):\n        time.sleep(0.1)\n")
    # a writer at work (in slices: a SIGTERM handled just before one long sleep is acted on when it ends)
    target = tmp_path / "out.ffrf.h5"
    for sig in (signal.SIGTERM, signal.SIGKILL):
        child = subprocess.Popen([sys.executable, "-c", script, str(target)], stdout=subprocess.PIPE,
                                 stderr=subprocess.PIPE, text=True)
        line = child.stdout.readline().strip()
        assert line == "ready", child.communicate(timeout=60)[1][-2000:]
        child.send_signal(sig)
        child.wait(timeout=30)
        left = list(tmp_path.glob(".out.ffrf.h5.*.tmp"))
        assert (left == []) is (sig == signal.SIGTERM), (sig, left)
    other = tmp_path / ".other.ffrf.h5.1.abc.tmp"
    other.write_bytes(b"")
    time.sleep(0.01)
    write_body(block_body, target)
    assert sorted(p.name for p in tmp_path.iterdir()) == [".other.ffrf.h5.1.abc.tmp", "out.ffrf.h5"]


def test_a_temporary_is_this_processs_before_it_exists(tmp_path, monkeypatch):
    """A SIGTERM handled between any two bytecodes finds the temporary noted: at the moment the file is
    created its name is already among this process's temporaries (the race a CI run hit with mkstemp)."""
    from ffrf_advisor.io import atomic
    seen = []
    real_open = os.open

    def watching_open(path, flags, mode=0o777):
        fd = real_open(path, flags, mode)
        seen.append(Path(path) in atomic._TEMPORARIES)
        return fd
    monkeypatch.setattr(atomic.os, "open", watching_open)
    with atomic.atomic_path(tmp_path / "out.html") as tmp:
        tmp.write_text("x")
    assert seen and seen[0] is True
    assert not atomic._TEMPORARIES and sorted(p.name for p in tmp_path.iterdir()) == ["out.html"]


def test_writes_are_bit_for_bit_reproducible(tmp_path, block_body):
    a, b = tmp_path / "a.ffrf.h5", tmp_path / "b.ffrf.h5"
    write_body(block_body, a)
    write_body(block_body, b)
    assert a.read_bytes() == b.read_bytes()


SHIPPED_BEAM = Path(__file__).resolve().parent.parent / "sample_bodies" / "beam.ffrf.h5"


def _analyze_json(path) -> dict:
    import json

    from typer.testing import CliRunner

    from ffrf_advisor.cli import app
    result = CliRunner().invoke(app, ["analyze", str(path), "--speed", "300rad/s", "--json"])
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)


def test_analyze_of_a_body_with_its_nodal_summary_reads_no_nodal_data(tmp_path):
    """Issue 24, item 3: the beam written with its nodal data carries the nodal summary, equal to the nodal
    data's, and analyze gives the same JSON when its modes/Phi, mesh and mass are NaN (declared, never written,
    NaN as fill value: reading them fails). Both runs read the invariants this write cached (the shipped file's
    were computed on another processor: recomputed here they may differ in the last bit)."""
    path = tmp_path / "beam.ffrf.h5"
    write_body(read_body(SHIPPED_BEAM, load_fe=True), path)
    old = _analyze_json(path)
    with h5py.File(path, "r") as f:
        summary = f["nodal_summary"].attrs
        assert summary["n_nodes"] == f["mesh/points"].shape[0] and summary["stiffness"] == ("stiffness/K" in f)
    body = read_body(path, load_fe="summary")
    assert body.fe is None and body.nodal is not None
    assert np.array_equal(body.nodal.max_deflection, read_body(path, load_fe=True).fe.max_deflection())
    with h5py.File(path, "r+") as f:
        for name in ("modes/Phi", "mesh/points", "mass/Ms/data"):
            dtype, shape = f[name].dtype, f[name].shape
            del f[name]
            f.create_dataset(name, shape=shape, dtype=dtype, fillvalue=np.nan, chunks=True, fletcher32=True)
    assert _analyze_json(path) == old
    with pytest.raises(BodyFileError, match="NaN or inf"):
        read_body(path, load_fe=True)


def test_a_nodal_summary_that_disagrees_with_the_nodal_data_is_refused(tmp_path):
    path = tmp_path / "beam.ffrf.h5"
    write_body(read_body(SHIPPED_BEAM, load_fe=True), path)
    with h5py.File(path, "r+") as f:
        f["nodal_summary/max_deflection"][0] *= 1.5
    with pytest.raises(BodyFileError, match="checksums@nodal_summary_sha256: expected the SHA-256 of the nodal_summary"):
        read_body(path, load_fe="summary")  # the cache's own checksum
    restamp(path)  # a writer that checksums a wrong cache: the nodal data still refuse it
    assert read_body(path, load_fe="summary").nodal.max_deflection[0] > 0
    with pytest.raises(BodyFileError, match="nodal_summary: expected the summary of the nodal data"):
        read_body(path, load_fe=True)
