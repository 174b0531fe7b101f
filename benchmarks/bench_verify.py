"""Wall time of `verify` with the default scenes on the shipped beam, and of the sample sweep, in one run.

Prints the wall time of `ffrf-advisor verify sample_bodies/beam.ffrf.h5 --speed 300rad/s -o DIR`
as a process (minimum over repeats, serially; DIR receives the figures the README shows), the time
of its parts, and the wall time of the zoo sweep `scripts/verify_zoo.py` on local processes (it rewrites
docs/verification.md).

Run: python benchmarks/bench_verify.py [--repeat N] [--skip-sweep] [--figures DIR]
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def timed(cmd: list[str], repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True, cwd=ROOT)
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--skip-sweep", action="store_true")
    parser.add_argument("--figures", default=str(ROOT / "docs" / "figures" / "beam"))
    args = parser.parse_args()
    verify = [sys.executable, "-m", "ffrf_advisor", "verify", "sample_bodies/beam.ffrf.h5", "--speed", "300rad/s",
              "-o", args.figures]
    t = timed(verify, args.repeat)
    print(f"verify, shipped beam, 4 scenes, 6 term sets, work-precision, stability, Campbell: {t:.1f} s wall "
          f"(process, minimum of {args.repeat}); figures in {args.figures}")
    if not args.skip_sweep:
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "scripts/verify_zoo.py"], check=True, capture_output=True, cwd=ROOT)
        print(f"zoo sweep (19 test-set bodies and 6 samples x 7 speeds, scripts/verify_zoo.py): "
              f"{time.perf_counter() - t0:.0f} s wall")


if __name__ == "__main__":
    main()
