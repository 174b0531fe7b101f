"""`info`, `analyze` and `gate` as processes against the import floor, with the process tree's peak memory
(issue 24, item 3), measured side by side in one run.

Bodies: the shipped beam and carbody, and a synthetic 200k-node x 100-mode bar (tests/tree_memory.py,
Phi 458 MiB), each written again by the tool so that it carries its invariants and nodal summary (the
shipped files predate the summary). Prints per body and command

  time ratio = wall time of `ffrf-advisor COMMAND BODY` / the import floor
               `python -c "import numpy, scipy.sparse, h5py"`                  target <= 1.3
  tree peak  = peak RSS of the tool and its reading child [MiB]                 target <= 200, whatever Phi weighs

Timings: minimum over repeats, serially, with bytecode cached (a scratch PYTHONPYCACHEPREFIX, after one
warm-up run), as in an installation, even where PYTHONDONTWRITEBYTECODE is set. The start-up of `--version` and `--help` is measured by
benchmarks/bench_startup.py.

Run: python benchmarks/bench_analyze.py [--repeat N] [--skip-synthetic]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from tests.tree_memory import synthetic_body, tree_rss  # noqa: E402
from timing import installed_env, interleaved, wall  # noqa: E402

from ffrf_advisor.io import read_body, write_body  # noqa: E402

FLOOR = [sys.executable, "-c", "import numpy, scipy.sparse, h5py"]
ENV: dict[str, str] = {}  # timing.installed_env, set in main
COMMANDS = {"info": ["info"], "analyze": ["analyze", "--speed", "300rad/s"], "gate": ["gate", "--speed", "300rad/s",
                                                                                       "--max-level", "IV"]}


def timed(cmd: list[str], repeat: int) -> tuple[float, float]:
    """(best wall time of ``cmd``, best of the import floor) [s], the two in turn within each repeat (timing.py),
    after a warm-up run of each that writes the bytecode."""
    for c in (cmd, FLOOR):
        wall(c, env=ENV)
    best = interleaved({"cmd": lambda: wall(cmd, env=ENV), "floor": lambda: wall(FLOOR, env=ENV)}, repeat)
    return best["cmd"], best["floor"]


def cached(source: Path, target: Path) -> Path:
    write_body(read_body(source, load_fe=True), target, overwrite=True)
    return target


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--skip-synthetic", action="store_true")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        ENV.update(installed_env(str(tmp / "pycache")))
        bodies = {name: cached(ROOT / "sample_bodies" / f"{name}.ffrf.h5", tmp / f"{name}.ffrf.h5")
                  for name in ("beam", "carbody")}
        if not args.skip_synthetic:
            path = tmp / "bar200k.ffrf.h5"
            synthetic_body(path, 1652, 100)  # (1652 + 1) x 11 x 11 = 200k nodes
            bodies["bar 200k x 100"] = path
        print(f"{'body':<16} {'Phi MiB':>8} {'command':<8} {'wall s':>7} {'floor s':>7} {'ratio':>6} {'tree MiB':>9}")
        for name, path in bodies.items():
            with_fe = read_body(path, load_fe=True)
            phi = with_fe.fe.Phi.nbytes / 2**20
            del with_fe
            for command, words in COMMANDS.items():
                cmd = [sys.executable, "-m", "ffrf_advisor", words[0], str(path), *words[1:]]
                wall, floor = timed(cmd, args.repeat)
                code, out, rss = tree_rss([words[0], str(path), *words[1:]])
                assert code in (0, 1), out  # gate exits 1 when the level exceeds its maximum
                print(f"{name:<16} {phi:>8.0f} {command:<8} {wall:>7.3f} {floor:>7.3f} {wall / floor:>6.2f} "
                      f"{rss['parent'] + rss['child']:>9.0f}")
    print("targets: ratio <= 1.3, tree peak <= 200 MiB")


if __name__ == "__main__":
    main()
