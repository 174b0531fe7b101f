"""A write that fails (a full disk, a quota, the file-size limit) is one line with exit 2, leaves no temporary,
and keeps the target as it was (issue 23, item 7: the HDF5 writer segfaulted and left its temporary)."""
from __future__ import annotations

import resource
import subprocess
import sys
from pathlib import Path

import pytest

SAMPLES = Path(__file__).resolve().parent.parent / "sample_bodies"
BEAM = str(SAMPLES / "beam.ffrf.h5")
LIMIT = 20_000  # bytes: below every output of the beam, above nothing the command must write elsewhere

WRITERS = {
    "convert-h5": ["convert", BEAM, "{out}.ffrf.h5", "--force"],
    "convert-json": ["convert", BEAM, "{out}.ffinv.json", "--force"],
    "convert-ffinv-h5": ["convert", BEAM, "{out}.ffinv.h5", "--force"],
    "sample": ["sample", "beam", "-o", "{out}.ffrf.h5", "--force"],
    "augment": ["augment", BEAM, "-o", "{out}.ffrf.h5", "--force"],
    "report": ["report", BEAM, "--speed", "10rad/s", "-o", "{out}.html", "--force"],
    "gate-junit": ["gate", BEAM, "--max-level", "IV", "--speed", "10rad/s", "--junit", "{out}.xml", "--force"],
    "simulate-csv": ["simulate", BEAM, "--t-end", "0.01", "-o", "{out}.csv", "--force"],
    "simulate-h5": ["simulate", BEAM, "--t-end", "0.01", "-o", "{out}.h5", "--force"],
}
SMALL = {"gate-junit": 300}  # the JUnit report of one body is a few kilobytes


def _limit(size: int):
    return lambda: resource.setrlimit(resource.RLIMIT_FSIZE, (size, size))


@pytest.mark.slow  # half a minute: every writer once under the file-size limit
@pytest.mark.parametrize("writer", sorted(WRITERS))
def test_a_failed_write_is_one_line_and_leaves_the_target_and_no_temporary(tmp_path, writer):
    args = [a.replace("{out}", str(tmp_path / "out")) for a in WRITERS[writer]]
    target = Path(next(a for a in args if a.startswith(str(tmp_path / "out"))))
    target.write_text("the old target\n")
    proc = subprocess.run([sys.executable, "-m", "ffrf_advisor", *args], preexec_fn=_limit(SMALL.get(writer, LIMIT)), capture_output=True,
                          text=True, timeout=600)
    lines = [line for line in proc.stderr.splitlines() if line.startswith("error")]
    assert proc.returncode == 2 and "Traceback" not in proc.stderr, proc.stderr[-3000:]
    assert len(lines) == 1 and f"{target}: write: expected to write the file" in lines[0], proc.stderr[-3000:]
    assert proc.stderr.strip().splitlines()[-1] == lines[0]  # progress lines may come before, nothing after
    assert target.read_text() == "the old target\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == [target.name]
