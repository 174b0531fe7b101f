"""SIGTERM at random moments of the writing commands (issue 23, item 13): the run ends with 143 (its handler
while it runs, the signal's default before that: the shell's 143 either way; or it had finished), the target is
the old file or a complete new one (export's folder: issue 49), no temporary is left, and no process of the run
outlives it (pool workers and the reading child die with their parent)."""
from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

SAMPLES = Path(__file__).resolve().parent.parent / "sample_bodies"
RUNS = 10  # terminations per command at random moments (20 took two of CI's 15 minutes)


def _complete(kind: str, path: Path) -> bool:
    """Whether ``path`` is a whole output of its kind."""
    if kind == "html":
        return path.read_text(encoding="utf-8", errors="replace").rstrip().endswith("</html>")
    if kind == "junit":
        return ET.parse(path).getroot().tag == "testsuites"
    from ffrf_advisor.io import read_body
    return read_body(path).nf > 0


def _group_alive(pgid: int) -> list[int]:
    """Processes of the session ``pgid`` still alive (zombies waiting for init count as dead)."""
    alive = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[2]) == pgid and fields[0] != "Z":
                alive.append(int(entry.name))
    return alive


COMMANDS = {
    "convert": (["convert", str(SAMPLES / "beam.ffrf.h5"), "{target}", "--force"], "out.ffrf.h5", "body"),
    "sample": (["sample", "zoo:block:3", "-o", "{target}", "--force"], "out.ffrf.h5", "body"),
    "gate": (["gate", str(SAMPLES / "beam.ffrf.h5"), str(SAMPLES / "conrod.ffrf.h5"), "--max-level", "IV",
              "--speed", "10rad/s", "--jobs", "2", "--junit", "{target}"], "out.xml", "junit"),
    "report": (["report", str(SAMPLES / "beam.ffrf.h5"), "--speed", "10rad/s", "-o", "{target}", "--force"],
               "out.html", "html"),
}


def _run(args: list[str], delay: float | None) -> tuple[int, float, bool]:
    """Run the CLI in its own session, SIGTERM it after ``delay`` s; (exit code, seconds, whether it was still
    running when signalled); every process of the session must be gone within 30 s of its end."""
    start = time.monotonic()
    proc = subprocess.Popen([sys.executable, "-m", "ffrf_advisor", *args], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, start_new_session=True)
    signalled = False
    if delay is not None:
        try:
            proc.wait(timeout=delay)
        except subprocess.TimeoutExpired:
            signalled = proc.poll() is None
            proc.send_signal(signal.SIGTERM)
    code = proc.wait(timeout=300)
    took = time.monotonic() - start
    for _ in range(1500):
        if not _group_alive(proc.pid):
            break
        time.sleep(0.02)
    left = _group_alive(proc.pid)
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    assert not left, f"{args[0]}: processes {left} outlived the run"
    return code, took, signalled


@pytest.mark.slow  # about a minute: 4 x RUNS runs of the CLI, each terminated at a random moment
@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_sigterm_ends_the_run_with_143_and_an_old_or_complete_target(tmp_path, command):
    args, name, kind = COMMANDS[command]
    target = tmp_path / name
    args = [a.replace("{target}", str(target)) for a in args]
    code, took, _ = _run(args, None)
    assert code in (0, 1) and _complete(kind, target)  # gate: 1 when a body is above IV (never)
    rng = random.Random(f"sigterm-{command}")
    for i in range(RUNS):
        before = target.read_bytes()
        delay = rng.uniform(0.05, took)
        code, _, signalled = _run(args, delay)
        ended = (143, -signal.SIGTERM)  # -15: ended by the signal's default action (the shell's 143)
        finishing = delay > 0.8 * took  # a signal during the process's own exit may find nothing left to stop
        assert code in (ended + (0, 1) if finishing or not signalled else ended), (i, code, signalled, delay, took)
        assert target.read_bytes() == before or _complete(kind, target), (i, code)
        assert not list(tmp_path.glob(".*.tmp")), (i, code, sorted(p.name for p in tmp_path.iterdir()))


RECREATING_WRITER = """
import sys, time
from pathlib import Path
from ffrf_advisor.io import guard
from ffrf_advisor.io.atomic import atomic_path, terminate_cleanly
target = Path(sys.argv[1])
def write(tmp):  # as the HDF5 library's 'w' mode would on a path removed under it: create it again, at once
    while True:
        if not tmp.exists():
            tmp.write_bytes(b"x")
with terminate_cleanly(), atomic_path(target) as tmp:
    print("writing", flush=True)
    guard.run_writer(target, write, tmp)
"""


@pytest.mark.slow
def test_sigterm_kills_the_writer_child_before_removing_its_temporary(tmp_path):
    """A writer child (io.guard) that creates the temporary again as soon as it is gone: the SIGTERM handler
    kills and reaps it before it removes the temporaries, so nothing is left (dying with the parent alone left
    the child the parent's exit to recreate it in)."""
    for _ in range(5):
        proc = subprocess.Popen([sys.executable, "-c", RECREATING_WRITER, str(tmp_path / "out.ffrf.h5")],
                                stdout=subprocess.PIPE, text=True, start_new_session=True)
        assert proc.stdout.readline() == "writing\n"
        time.sleep(0.3)
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=30) == 143
        time.sleep(0.3)
        assert not list(tmp_path.glob(".*.tmp")) and not _group_alive(proc.pid)


def _export_state(folder: Path, script: bytes) -> str:
    """'old' (the three placeholder files), 'new' (the three files of a complete export) or what else it is."""
    names = sorted(p.name for p in folder.iterdir()) if folder.is_dir() else []
    if names != ["body.npz", "run_exudyn.py", "scene.json"]:
        return f"files {names}"
    data = {n: (folder / n).read_bytes() for n in names}
    if all(v == b"old" for v in data.values()):
        return "old"
    if any(v == b"old" for v in data.values()):
        return "mixed"
    import json

    import numpy as np
    with np.load(folder / "body.npz") as f:
        complete = ("modes" in f.files and json.loads(data["scene.json"])["t_end"] > 0
                    and data["run_exudyn.py"] == script)
    return "new" if complete else "incomplete"


@pytest.mark.slow  # RUNS runs of export, each terminated at a random moment
def test_sigterm_during_export_leaves_the_old_folder_or_the_complete_new_one(tmp_path):
    """export -o DIR writes a temporary sibling folder renamed into place: a SIGTERM at any moment leaves the
    old files (placeholders here) or all the new ones, never a new body.npz beside an old scene.json (5 of 6
    kills did before), and no temporary."""
    from ffrf_advisor.export import exudyn
    script = Path(exudyn.__file__).with_name("run_exudyn.py").read_bytes()
    target = tmp_path / "exudyn"
    args = ["export", str(SAMPLES / "beam.ffrf.h5"), "-o", str(target), "--t-end", "0.01", "--force"]

    def old() -> None:
        target.mkdir(exist_ok=True)
        for name in exudyn.FILES:
            (target / name).write_bytes(b"old")
    old()
    code, took, _ = _run(args, None)
    assert code == 0 and _export_state(target, script) == "new"
    rng, seen = random.Random("sigterm-export"), set()
    for i in range(RUNS):
        old()
        code, _, signalled = _run(args, rng.uniform(0.05, took))
        state = _export_state(target, script)
        seen.add(state)
        assert state in ("old", "new") and code in (143, -signal.SIGTERM, 0), (i, code, state, signalled)
        assert not list(tmp_path.glob(".*.tmp*")), (i, sorted(p.name for p in tmp_path.iterdir()))
