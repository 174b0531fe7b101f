"""`gate` over many bodies: `--jobs 2` against `--jobs 1`, measured side by side in one run (issue 24, item 7).

Sixty bodies (ten copies of each shipped sample) gated at rest as processes; minimum over repeats, taken
serially. Prints the ratio time(--jobs 1) / time(--jobs 2) (target >= 1.6 on a 2-core machine).

Run: python benchmarks/bench_gate.py [--repeat N]
"""
from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SAMPLES = ("beam", "plate", "conrod", "genstruct1", "genstruct2", "carbody")


def timed(cmd: list[str], repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True)
        best = min(best, time.perf_counter() - t0)
    return best


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
        one, two = (timed([*gate, "--jobs", str(j)], args.repeat) for j in (1, 2))
    print(f"gate, 60 bodies: --jobs 1 {one:.2f} s, --jobs 2 {two:.2f} s: {one / two:.2f}x (target >= 1.6)")


if __name__ == "__main__":
    main()
