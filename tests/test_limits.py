"""Bounded resources (issue 14): declared sizes, the memory limit, references to other files, the guarded child."""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from ffrf_advisor.cli import app
from ffrf_advisor.errors import BodyFileError, FFRFError
from ffrf_advisor.io import ffrf_h5, guard, h5_checksums, limits

ROOT = Path(__file__).resolve().parents[1]
BEAM = ROOT / "sample_bodies" / "beam.ffrf.h5"
runner = CliRunner()


def _one_line_exit_2(args, *needles):
    result = runner.invoke(app, [str(a) for a in args])
    assert result.exit_code == 2, result.output
    line = result.output.strip()
    assert "\n" not in line and "Traceback" not in line
    for needle in needles:
        assert needle in line, line
    return line


def _edited_beam(tmp_path, name, edit, stamp: bool = True) -> Path:
    path = tmp_path / name
    shutil.copy(BEAM, path)
    with h5py.File(path, "r+") as f:
        edit(f)
        if stamp:  # edited on purpose: the limits, not the checksums, are under test
            h5_checksums.stamp_cache(f)
    return path


def _declare(f, name, shape):
    """Replace dataset ``name`` by one of ``shape`` that is declared but never written (a tiny file)."""
    dtype = f[name].dtype
    del f[name]
    f.create_dataset(name, shape=shape, dtype=dtype)


def test_a_declared_huge_dataset_is_refused_before_it_is_read(tmp_path):
    """Where the nodal data are read (here: analyze of a file without its nodal summary, which streams them) a
    huge declared dataset is refused before any of it is read; a file with the summary cache is analysed
    without reading them at all (issue 24, item 3)."""
    points = _edited_beam(tmp_path, "points.ffrf.h5",
                          lambda f: (_declare(f, "mesh/points", (10**9, 3)), f.__delitem__("nodal_summary")))
    _one_line_exit_2(["analyze", points, "--speed", "300rad/s", "--connection", "stiff"], "mesh/points",
                     "memory limit of 8 GiB", "22.4 GiB declared")
    cached = _edited_beam(tmp_path, "cached.ffrf.h5", lambda f: _declare(f, "mesh/points", (10**9, 3)))
    assert runner.invoke(app, ["analyze", str(cached), "--speed", "300rad/s"]).exit_code == 0
    _one_line_exit_2(["convert", cached, tmp_path / "out.ffrf.h5"], "mesh/points", "22.4 GiB declared")
    modes = _edited_beam(tmp_path, "modes.ffrf.h5", lambda f: _declare(f, "modes/eigenvalues", (10**9,)),
                         stamp=False)  # its digest would read the 8 GB declared; the shape is refused before it
    _one_line_exit_2(["info", modes], "modes/eigenvalues", "as many modes as stress/max has (16)")


def test_the_memory_limit_is_settable_and_bounds_every_format(tmp_path, monkeypatch):
    # without cached invariants the beam's nodal data are read: 773 nodes, 16 modes (0.8 MiB in all) pass
    # the default 8 GiB and fail 256 KiB
    nodal = _edited_beam(tmp_path, "nodal.ffrf.h5", lambda f: f.__delitem__("invariants"))
    assert runner.invoke(app, ["info", str(nodal)]).exit_code == 0
    _one_line_exit_2(["--max-memory", "256K", "info", nodal], "memory limit of 256 KiB")
    monkeypatch.setenv(limits.ENV, "256K")
    _one_line_exit_2(["info", nodal], "memory limit of 256 KiB")
    monkeypatch.delenv(limits.ENV)
    _one_line_exit_2(["--max-memory", "lots", "info", BEAM], "--max-memory", "like 8G")
    monkeypatch.setenv(limits.ENV, "lots")
    _one_line_exit_2(["info", BEAM], limits.ENV, "like 8G")


@pytest.mark.parametrize("name", ["big.ffinv.json", "big.frd", "big.vtu"])
def test_a_sparse_3_gb_file_ends_in_one_line_without_reading_it(tmp_path, name):
    path = tmp_path / name
    with open(path, "wb") as fh:
        fh.truncate(3 * 2**30)  # a hole: no disk, 3 GiB of zeros to whoever reads it
    (tmp_path / "big.inp").write_text("*DENSITY\n7.85e-9\n")
    code = ("import resource, sys; from ffrf_advisor.cli import app; sys.argv = ['ffrf-advisor', 'info', "
            f"{str(path)!r}, '--density', '1', '--eigenvalues', '1']; "
            "sys.argv = sys.argv[:3] if not sys.argv[2].endswith('.vtu') else sys.argv\n"
            "try:\n    app()\nexcept SystemExit as e:\n"
            "    hwm = next(l for l in open('/proc/self/status') if l.startswith('VmHWM')).split()[1]\n"
            "    print(e.code, hwm, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)")
    # VmHWM, not getrusage(RUSAGE_SELF): Linux keeps ru_maxrss across exec, so that would be the RSS of the
    # pytest worker that forked this process (600 MB in one CI run), not this process's own peak
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    code_, rss, child_rss = done.stdout.split()
    assert code_ == "2" and len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert max(int(rss), int(child_rss)) < 600 * 1024, "kB: memory must not follow the file size"


def test_an_frd_declaring_more_nodes_than_it_holds_is_truncated(tmp_path):
    path = tmp_path / "t.frd"
    path.write_text("    1C\n    2C                  99999999                                     1\n"
                    " -1         1 0.00000E+00 0.00000E+00 0.00000E+00\n -3\n")
    _one_line_exit_2(["info", path], "2C", "records the rest of the file can hold", "99999999 declared")


def _external(tmp_path, name, target):
    return _edited_beam(tmp_path, name, lambda f: (f.__delitem__("stress/max"),
                                                   f.__setitem__("stress/max", h5py.ExternalLink(target, "/x"))))


def test_external_links_outside_the_folder_or_to_special_files_are_refused(tmp_path):
    _one_line_exit_2(["info", _external(tmp_path, "out.ffrf.h5", "/etc/passwd")],
                     "stress/max", "files in the body file's folder", "--follow-outside")
    os.mkfifo(tmp_path / "fifo.h5")
    fifo = _external(tmp_path, "fifo.ffrf.h5", "fifo.h5")
    done = subprocess.run([sys.executable, "-m", "ffrf_advisor", "info", str(fifo)], capture_output=True, text=True,
                          timeout=300)  # refused, not opened: opening a FIFO blocks forever (the timeout: a guard)
    assert done.returncode == 2 and "existing regular file" in done.stderr and "fifo.h5" in done.stderr
    # asked: the link is followed (and what it finds is checked like any other data)
    _one_line_exit_2(["--follow-outside", "info", _external(tmp_path, "asked.ffrf.h5", "/etc/passwd")],
                     "readable ffrf-h5 file")
    ffinv = tmp_path / "out.ffinv.h5"
    with h5py.File(ffinv, "w") as f:
        f["I1"] = h5py.ExternalLink("/etc/passwd", "/x")
    _one_line_exit_2(["info", ffinv], "I1", "files in the body file's folder")


def test_xdmf_heavy_data_outside_the_folder_is_refused(tmp_path):
    path = tmp_path / "m.xdmf"
    path.write_text(textwrap.dedent("""\
        <Xdmf Version="3.0"><Domain><Grid Name="g"><Geometry GeometryType="XYZ">
        <DataItem Dimensions="1 3" Format="HDF" NumberType="Float" Precision="8">/etc/passwd:/points</DataItem>
        </Geometry></Grid></Domain></Xdmf>"""))
    _one_line_exit_2(["info", path, "--density", "1", "--eigenvalues", "1"], "DataItem", "folder", "/etc/passwd")


# ---------------------------------------------------------------- the guarded child
def _spin() -> None:
    while True:
        pass


def _work(declared: int, cpu_seconds: float) -> str:
    """Declare ``declared`` bytes (as a reader's memory budget does), then compute for ``cpu_seconds`` of
    processor time (counted by the process's own clock of work, not the wall)."""
    limits.Budget("x").take("data", declared, copies=1)
    while time.process_time() < cpu_seconds:
        pass
    return "done"


def test_the_guard_words_a_loop_a_crash_and_a_memory_overrun_by_what_happened(tmp_path, monkeypatch):
    path = tmp_path / "x.h5"
    path.write_bytes(b"0" * 100)
    monkeypatch.setattr(guard, "BASE_SECONDS", 1.0)
    with pytest.raises(BodyFileError, match=r"lib used up its processor time reading it \(1 s plus 1 s per 2 MiB "
                       r".*raise FFRF_ADVISOR_READ_SECONDS \(now 1 s\)"):
        guard.run(path, "lib", _spin)
    with pytest.raises(BodyFileError, match=r"lib crashed reading it \(signal 11, SIGSEGV\)"):
        guard.run(path, "lib", _segfault)
    monkeypatch.setattr(limits, "_set", 64 * 2**20)
    with pytest.raises(MemoryError, match="memory limit of 64 MiB"):
        guard.run(path, "lib", np.ones, 2**30)
    assert guard.run(path, "lib", np.arange, 3).tolist() == [0, 1, 2]  # the result travels back


def test_a_reading_child_that_waits_is_not_taken_for_a_loop(tmp_path, monkeypatch):
    """Issue 49, part 6: a valid body with 458 MiB of modes in a 6 MiB file was refused as damaged at load 16.
    The child's bound is processor time: waiting (as on a loaded machine, which gives it no processor) past
    the base costs it nothing. A bad FFRF_ADVISOR_READ_SECONDS is the tool's one line."""
    path = tmp_path / "x.h5"
    path.write_bytes(b"0" * 100)
    monkeypatch.setattr(guard, "BASE_SECONDS", 1.0)
    assert guard.run(path, "lib", time.sleep, 1.5) is None
    monkeypatch.setenv(guard.SECONDS_ENV, "inf")
    with pytest.raises(FFRFError, match="FFRF_ADVISOR_READ_SECONDS: expected a positive number"):
        guard.run(path, "lib", _work, 0, 0.0)


@pytest.mark.slow  # 4 s of processor time, longer on a loaded machine
def test_the_reading_child_s_processor_time_grows_with_the_sizes_it_declares(tmp_path, monkeypatch):
    """With a base of 1 s, 2 MiB declared (an HDF5 file's uncompressed data, through the memory budget) allow
    1.5 s of work (1 s per 2 MiB), which the base alone stops, and so does the raise the message names."""
    path = tmp_path / "x.h5"
    path.write_bytes(b"0" * 100)
    monkeypatch.setattr(guard, "BASE_SECONDS", 1.0)
    assert guard.run(path, "lib", _work, 2 * 2**20, 1.5) == "done"
    with pytest.raises(BodyFileError, match="used up its processor time"):
        guard.run(path, "lib", _work, 0, 1.5)
    monkeypatch.setenv(guard.SECONDS_ENV, "2")
    assert guard.run(path, "lib", _work, 0, 1.5) == "done"


def _segfault():
    os.kill(os.getpid(), signal.SIGSEGV)


PARENT = """
import os, signal, sys, time
signal.signal(signal.SIGINT, signal.default_int_handler)  # Python ignores SIGINT when started with it ignored
from ffrf_advisor.io import guard
def child():
    open(sys.argv[1], "w").write(str(os.getpid()))
    time.sleep(600)
guard.run(sys.argv[1], "lib", child)
"""


@pytest.mark.parametrize("how", [signal.SIGINT, signal.SIGTERM, signal.SIGKILL])
def test_the_reading_child_never_outlives_its_parent(tmp_path, how):
    pidfile = tmp_path / "pid"
    pidfile.write_text("")
    parent = subprocess.Popen([sys.executable, "-c", PARENT, str(pidfile)], stderr=subprocess.DEVNULL)
    for _ in range(500):
        if pidfile.read_text():
            break
        time.sleep(0.02)
    child = int(pidfile.read_text())
    parent.send_signal(how)
    parent.wait(timeout=120)  # a loaded machine may be slow to reap it
    assert _ends(child), f"the child {child} outlived its parent ({how.name})"


def _ends(pid: int) -> bool:
    """Whether the process ``pid`` is gone (or a zombie waiting for init) within 5 s; if not, it is killed."""
    for _ in range(250):
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return True
        if Path(f"/proc/{pid}/stat").read_text().split()[2] == "Z":
            return True
        time.sleep(0.02)
    os.kill(pid, signal.SIGKILL)
    return False


def test_a_ctrl_c_another_thread_receives_ends_a_guarded_read_at_once(tmp_path):
    """The kernel may hand a signal to any thread; Python runs its handler in the main thread, which waits for
    the reading child in slices (guard._readable) and so ends within one, not at the read's deadline (30 s)."""
    pidfile = tmp_path / "pid"
    pidfile.write_text("")
    to_a_thread = ("import threading\ndef interrupt():\n"  # once the child runs (it writes its pid), in the wait
                   "    while not open(sys.argv[1]).read():\n        time.sleep(0.02)\n    time.sleep(0.5)\n"
                   "    signal.pthread_kill(threading.get_ident(), signal.SIGINT)\n"
                   "threading.Thread(target=interrupt, daemon=True).start()\n")
    script = PARENT.replace("guard.run(", to_a_thread + "guard.run(", 1)
    parent = subprocess.Popen([sys.executable, "-c", script, str(pidfile)], stderr=subprocess.PIPE, text=True)
    try:
        err = parent.communicate(timeout=20)[1]
    except subprocess.TimeoutExpired:
        parent.kill()
        err = None
    assert pidfile.read_text() and _ends(int(pidfile.read_text()))
    assert err is not None, "the read slept on through the SIGINT until its deadline"
    assert "KeyboardInterrupt" in err


def test_a_broken_dataset_in_a_large_valid_file_is_read_only_when_needed(tmp_path):
    # the default read does not touch nodal data: a damaged mode matrix does not stop `info`
    path = _edited_beam(tmp_path, "phi.ffrf.h5", lambda f: _declare(f, "modes/Phi", f["modes/Phi"].shape))
    result = runner.invoke(app, ["info", str(path), "--json"])
    assert result.exit_code == 0 and json.loads(result.stdout)["body"]["name"] == "beam"


def test_numbers_whose_products_overflow_are_refused_on_reading(tmp_path):
    # finite in the file, inf or NaN once multiplied (energies, I0): one line at reading, not a LinAlgError
    def edit(f):
        f["static_centrifugal/compliance"][0] = 1e200

    path = _edited_beam(tmp_path, "big.ffrf.h5", edit)
    _one_line_exit_2(["analyze", path, "--speed", "300rad/s"], "static_centrifugal compliance", "below 1e+150")


def test_the_parent_accepts_only_the_types_of_the_body_model_from_the_child(tmp_path):
    path = tmp_path / "x.h5"
    path.write_bytes(b"0")
    with pytest.raises(BodyFileError, match=r"outside the body model \(posix.system is not a type"):
        guard.run(path, "lib", lambda: os.system)  # what a subverted child would send to run a command
    with pytest.raises(RuntimeError, match="error: a foreign library's exception"):
        guard.run(path, "lib", _foreign_error)  # travels as its text
    body = guard.run(BEAM, "the HDF5 library", ffrf_h5._read_file, BEAM, True)  # a whole body passes
    assert body.fe is not None and body.nf == 16


def _foreign_error():
    import struct
    raise struct.error("a foreign library's exception")


def test_a_child_out_of_memory_names_the_limit(tmp_path, monkeypatch):
    """Issue 23, item 8: a body whose copy for the parent passed the limit failed with 'RuntimeError:
    FlexibleBody:', naming neither memory nor the limit."""
    def exhausted(*args):
        raise MemoryError("needed more than the memory limit of 470 MiB to send the body read to the parent")

    monkeypatch.setattr(ffrf_h5, "_read_file", exhausted)
    result = runner.invoke(app, ["--max-memory", "470M", "info", str(BEAM)])
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1, result.output
    assert "memory: expected a body that fits the memory limit of 470 MiB" in result.output


@pytest.mark.slow
def test_max_memory_bounds_the_peak_of_the_process_tree(tmp_path):
    """Issue 23, item 8: --max-memory bounded the bytes a file declares while a body that fit 470M peaked at
    939 MB in the process tree. Now the peak of the parent and the reading child above a tiny body's run stays
    within the limit when the body is read whole (convert), and a limit the body does not fit is one line
    naming the limit and the numbers (the analysis streams such a body instead: tests/test_streaming.py)."""
    from .tree_memory import synthetic_body, tree_rss

    tiny, body = tmp_path / "tiny.ffrf.h5", tmp_path / "bar.ffrf.h5"
    synthetic_body(tiny, 10, 10)
    declared = synthetic_body(body, 1400, 20)  # 93 MiB of arrays, 78 MiB of them modes
    limit = int(1.02 * limits.TREE_BYTES_PER_BYTE * declared)  # 2 %: eigenvalues and attributes
    code_tiny, _, base = tree_rss(["convert", str(tiny), str(tmp_path / "tiny-copy.ffrf.h5")])
    code, out, rss = tree_rss(["--max-memory", str(limit), "convert", str(body), str(tmp_path / "copy.ffrf.h5")])
    assert code_tiny == code == 0, out
    extra = (rss["parent"] - base["parent"] + rss["child"] - base["child"]) * 2**20
    assert extra <= limit, (rss, base, limit)
    code, out, _ = tree_rss(["--max-memory", str(int(0.9 * limit)), "convert", str(body),
                             str(tmp_path / "copy2.ffrf.h5")])
    assert code == 2 and len(out.strip().splitlines()) == 1, out
    assert "expected data that fit the memory limit of" in out and "for the process tree" in out, out


def test_the_parent_refuses_a_message_larger_than_the_limit_before_allocating_it():
    """A reading child (subverted by a hostile file) that announces more than the memory limit gets no
    allocation of that size in the parent; one that sends less than it announced is an early end."""
    read_end, write_end = os.pipe()
    os.write(write_end, guard._LENGTH.pack(1) + guard._LENGTH.pack(10) + guard._LENGTH.pack(2**40))
    with pytest.raises(guard._Oversize):
        guard._receive(read_end, time.monotonic() + 5, 2**30)
    os.write(write_end, guard._LENGTH.pack(0) + guard._LENGTH.pack(10) + b"short")
    os.close(write_end)
    assert guard._receive(read_end, time.monotonic() + 5, 2**30) == ()
    os.close(read_end)


@pytest.mark.slow
def test_analyze_of_a_cached_body_costs_the_same_memory_whatever_its_modes_weigh(tmp_path):
    """Issue 24, item 3: a body with its invariants and nodal summary cached is analysed from them; the process
    tree's peak above a tiny body's run stays below 16 MiB for 93 MiB of nodal arrays (measured: 0)."""
    from .tree_memory import synthetic_body, tree_rss

    tiny, body = tmp_path / "tiny.ffrf.h5", tmp_path / "bar.ffrf.h5"
    synthetic_body(tiny, 10, 10)
    synthetic_body(body, 1400, 20)
    runs = [tree_rss(["analyze", str(p), "--speed", "10rad/s"]) for p in (tiny, body)]
    assert all(code == 0 for code, _, _ in runs), runs
    (_, _, base), (_, _, rss) = runs
    assert rss["parent"] - base["parent"] + rss["child"] - base["child"] < 16, (rss, base)


def test_the_parent_imports_what_its_command_needs_while_the_child_reads(tmp_path, monkeypatch):
    """io.guard.importing_meanwhile: the named modules are imported by the parent (its pid) while the child
    parses, once; a read that does not fork leaves them unimported. Told by an event: the child's parse waits
    for the file the module's import writes, which an import after the read would never let it see (the wait
    is cut at 60 s only so that the test fails instead of hanging)."""
    sign = tmp_path / "imported"
    (tmp_path / "meanwhile_probe.py").write_text(f"import os\nPID = os.getpid()\nopen({str(sign)!r}, 'w').close()\n")
    monkeypatch.syspath_prepend(str(tmp_path))

    def waiting_parse(path):  # in the child
        for _ in range(6000):
            if sign.exists():
                return True
            time.sleep(0.01)
        return False
    try:
        with guard.importing_meanwhile("meanwhile_probe"):
            assert guard.run(BEAM, "a parser that waits for the import", waiting_parse, BEAM)
            assert guard._MEANWHILE == []  # imported once, by the first read
        probe = sys.modules["meanwhile_probe"]
        assert probe.PID == os.getpid()
        del sys.modules["meanwhile_probe"]
        monkeypatch.setattr(guard, "FORK", False)
        with guard.importing_meanwhile("meanwhile_probe"):
            guard.run(BEAM, "an in-process parser", lambda path: None, BEAM)
        assert "meanwhile_probe" not in sys.modules and guard._MEANWHILE == []
    finally:
        sys.modules.pop("meanwhile_probe", None)
