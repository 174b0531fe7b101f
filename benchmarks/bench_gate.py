"""`gate` over many bodies: `--jobs 2` against `--jobs 1`, measured side by side in one run (issue 24, item 7).

Sixty bodies (ten copies of each shipped sample) gated at rest as processes; minimum over repeats, taken
serially, the two in turn within each repeat, with bytecode cached as in an installation, after a warm-up run
(timing.py). Prints the ratio time(--jobs 1) / time(--jobs 2) (target >= 1.6 on a 2-core machine).

Run: python benchmarks/bench_gate.py [--repeat N]
"""
from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

from timing import installed_env, interleaved, wall

ROOT = Path(__file__).resolve().parent.parent
SAMPLES = ("beam", "plate", "conrod", "genstruct1", "genstruct2", "carbody")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        bodies = []
        for i in range(10):
            for name in SAMPLES:
                bodies.append(Path(tmp) / f"{name}-{i}.ffrf.h5")
                shutil.copy(ROOT / "sample_bodies" / f"{name}.ffrf.h5", bodies[-1])
        gate = [sys.executable, "-m", "ffrf_advisor", "gate", *map(str, bodies), "--max-level", "IV", "--speed", "0"]
        env = installed_env(str(Path(tmp) / "pycache"))
        wall([*gate, "--jobs", "2"], env=env)  # warm-up: bytecode written
        best = interleaved({j: lambda j=j: wall([*gate, "--jobs", j], env=env) for j in ("1", "2")}, args.repeat)
        one, two = best["1"], best["2"]
    print(f"gate, 60 bodies: --jobs 1 {one:.2f} s, --jobs 2 {two:.2f} s: {one / two:.2f}x (target >= 1.6)")


if __name__ == "__main__":
    main()
