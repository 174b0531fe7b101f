"""Wall time of `ffrf-advisor analyze` on each shipped sample body, as a process (imports included).

Also prints, measured in-process in the same run, the ratio of analysis
time (q_max, significance, rules) to reading time. Target: < 1 s per body.
Run: python benchmarks/bench_analyze.py
"""
from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

from ffrf_advisor.analysis import analyze
from ffrf_advisor.io import read_body

SAMPLES = Path(__file__).resolve().parent.parent / "sample_bodies"


def main() -> None:
    for path in sorted(SAMPLES.glob("*.ffrf.h5")):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "ffrf_advisor", "analyze", str(path), "--json"],
                       check=True, capture_output=True)
        wall = time.perf_counter() - t0
        t0 = time.perf_counter()
        body = read_body(path, load_fe=True)
        t_read = time.perf_counter() - t0
        t0 = time.perf_counter()
        analyze(body)
        t_analyze = time.perf_counter() - t0
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", "import ffrf_advisor.cli"], check=True)
        t_import = time.perf_counter() - t0
        print(f"{path.name}: analyze process {wall:.2f} s (target < 1 s); python + imports {t_import:.2f} s; "
              f"read {t_read * 1e3:.1f} ms, analysis {t_analyze * 1e3:.1f} ms, "
              f"analysis / read = {t_analyze / t_read:.2f}")


if __name__ == "__main__":
    main()
