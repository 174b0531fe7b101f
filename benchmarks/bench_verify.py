"""`verify` and its integrators, measured side by side in one run (issue 24).

Prints
  1. per right-hand side inside the compiled integrators (DOP853 at verify's reference tolerance, the
     implicit midpoint rule) over the compiled right-hand side alone, called in a compiled loop
     (target: at most 1.5x);
  2. `verify` of the shipped beam with the default scenes as a process, with the compiled integrators and
     with the former path (scipy's DOP853 calling the right-hand side from Python, the Python midpoint
     rule: `sim.loads.Loads.compiled` patched to refuse), and their ratio (goal: at least 10x);
  3. optionally (--sweep) the wall time of the zoo sweep `scripts/verify_zoo.py` (it rewrites
     docs/verification.md).
Timings are minima over repeats, taken serially.

Run: python benchmarks/bench_verify.py [--repeat N] [--sweep]
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import numba as nb
import numpy as np

from ffrf_advisor.io import read_body
from ffrf_advisor.sim import kernels
from ffrf_advisor.sim.integrate import _compiled_model, integrate
from ffrf_advisor.sim.model import build_model, initial_state
from ffrf_advisor.terms import FULL

ROOT = Path(__file__).resolve().parent.parent
BEAM = ROOT / "sample_bodies" / "beam.ffrf.h5"
VERIFY = ["verify", str(BEAM), "--speed", "300rad/s"]
OLD_PATH = ("import sys; from ffrf_advisor.sim.loads import Loads; Loads.compiled = lambda self: None; "
            "from ffrf_advisor.cli import app; sys.argv = ['ffrf-advisor', *sys.argv[1:]]; app()")


@nb.njit
def _rhs_loop(y, out, n, model, zero3, zf):
    for _ in range(n):
        kernels.rhs_into(y, out, model, zero3, zf, False, zero3, zero3)


def best(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def per_evaluation(repeat: int) -> None:
    body = read_body(BEAM)
    m = build_model(body, FULL)
    y0 = initial_state(m, (0.0, 0.0, 300.0), np.full(body.nf, 0.05))
    out, n = np.empty_like(y0), 20000
    args = (_compiled_model(m), np.zeros(3), np.zeros(m.nf))
    _rhs_loop(y0, out, 1, *args)
    alone = best(lambda: _rhs_loop(y0, out, n, *args), repeat) / n
    runs = {"dop853 (rtol 1e-10)": lambda: integrate(m, y0, 0.02, "dop853", rtol=1e-10, atol=1e-14),
            "midpoint (h = 1e-5)": lambda: integrate(m, y0, 2e-3, "midpoint", 1e-5)}
    print(f"compiled right-hand side alone (beam, {body.nf} modes, full set): {alone * 1e6:.2f} us")
    for name, run in runs.items():
        nfev = run().nfev
        t = best(run, repeat)
        print(f"  {name}: {t / nfev * 1e6:.2f} us per evaluation, {t / nfev / alone:.2f}x the right-hand side "
              f"alone (target <= 1.5)")


def timed(cmd: list[str], repeat: int) -> float:
    return best(lambda: subprocess.run(cmd, check=True, capture_output=True, cwd=ROOT), repeat)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--sweep", action="store_true")
    args = parser.parse_args()
    per_evaluation(max(args.repeat, 3))
    new = timed([sys.executable, "-m", "ffrf_advisor", *VERIFY], args.repeat)
    old = timed([sys.executable, "-c", OLD_PATH, *VERIFY], args.repeat)
    print(f"verify beam at 300 rad/s (default scenes about both stable axes, term sets, work-precision, stability, Campbell), process wall, "
          f"minimum of {args.repeat}: compiled {new:.1f} s, former path {old:.1f} s: {old / new:.1f}x "
          "(goal >= 10)")
    if args.sweep:
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "scripts/verify_zoo.py"], check=True, capture_output=True, cwd=ROOT)
        print(f"zoo sweep (scripts/verify_zoo.py): {time.perf_counter() - t0:.0f} s wall")


if __name__ == "__main__":
    main()
