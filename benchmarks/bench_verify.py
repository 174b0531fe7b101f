"""`verify` and its integrators, measured side by side in one run (issue 24).

Prints
  1. per right-hand side inside the compiled integrators (DOP853 at verify's reference tolerance, the
     implicit midpoint rule) over the compiled right-hand side alone, called in a compiled loop
     (target: at most 1.5x); beside it the same calls chained, each on the last one's result as in an
     integrator (independent calls overlap in the processor: the chain is the floor an integrator can reach);
  2. `verify` of the shipped beam with the default scenes as a process, with the compiled integrators and
     with the former path (scipy's DOP853 calling the right-hand side from Python, the Python midpoint
     rule with a Jacobian taken at every step: `sim.loads.Loads.compiled` patched to refuse,
     `sim.midpoint.THETA_REFRESH` below every ratio), and their ratio (goal: at least 10x; --skip-old:
     the compiled path only);
  3. `verify` of the shipped beam with the default scenes, and with --quick, as a process, over the sum of its
     evaluations' compiled cost (target: at most 2x). The floor: each run whose evaluations `verify --json`
     reports contributes its count times the compiled right-hand side of its term set per call (in a compiled
     loop at the state of 1): the timed runs (the scenes' rows; without --quick also the work-precision points)
     times verify's --repeat (each is taken that often; the JSON gives one run's count), the references (two
     DOP853 runs per scene, rtol 1e-10 and 1e-12) once. The stability studies and the Campbell study
     (linearisations, evaluated by numpy) report no evaluations: the ratio covers only what is counted, and
     the output names the counted parts;
  4. optionally (--sweep) the wall time of the zoo sweep `scripts/verify_zoo.py` (it rewrites
     docs/verification.md).
Timings are minima over repeats, taken serially, those of each part in turn within each repeat (timing.py).

Run: python benchmarks/bench_verify.py [--repeat N] [--skip-old] [--sweep]
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from collections import Counter
from functools import lru_cache
from pathlib import Path

import numba as nb
import numpy as np

from timing import interleaved, seconds, wall

from ffrf_advisor.io import read_body
from ffrf_advisor.sim import kernels
from ffrf_advisor.sim.integrate import _compiled_model, integrate
from ffrf_advisor.sim.model import build_model, initial_state
from ffrf_advisor.terms import FULL

ROOT = Path(__file__).resolve().parent.parent
BEAM = ROOT / "sample_bodies" / "beam.ffrf.h5"
VERIFY_REPEATS = 3  # verify's --repeat (its default): every counted run is taken this often
VERIFY = ["verify", str(BEAM), "--speed", "300rad/s", "--repeat", str(VERIFY_REPEATS)]
NEW_PATH = [sys.executable, "-m", "ffrf_advisor"]
OLD_PATH = ("import sys; from ffrf_advisor.sim.loads import Loads; Loads.compiled = lambda self: None; "
            "from ffrf_advisor.sim import midpoint; midpoint.THETA_REFRESH = -1.0; "
            "from ffrf_advisor.cli import app; sys.argv = ['ffrf-advisor', *sys.argv[1:]]; app()")


@nb.njit
def _rhs_loop(y, out, n, model, zero3, zf):
    for _ in range(n):
        kernels.rhs_into(y, out, model, zero3, zf, kernels.FREE[0], zero3, zero3)


@nb.njit
def _rhs_chain(y, out, n, model, zero3, zf):
    """As ``_rhs_loop``, each call reading the last one's result (as every stage of an integrator does; the
    update, 1e-300 of it, changes no state entry): the processor cannot overlap successive calls."""
    for _ in range(n):
        kernels.rhs_into(y, out, model, zero3, zf, kernels.FREE[0], zero3, zero3)
        for i in range(4, y.shape[0]):
            y[i] += 1e-300 * out[i]


def beam_state(m) -> np.ndarray:
    """The beam spinning at 300 rad/s about axis 3, every mode at 0.05."""
    return initial_state(m, (0.0, 0.0, 300.0), np.full(m.nf, 0.05))


def rhs_alone(m, n: int = 20000, loop=_rhs_loop) -> float:
    """Seconds per call of the compiled right-hand side of ``m`` at ``beam_state``, in a compiled loop of ``n``
    calls, timed once (``interleaved`` takes the minimum; ``loop``: ``_rhs_loop`` or ``_rhs_chain``)."""
    y0 = beam_state(m)
    out, args = np.empty_like(y0), (_compiled_model(m), np.zeros(3), np.zeros(m.nf))
    loop(y0.copy(), out, 1, *args)
    return seconds(lambda: loop(y0.copy(), out, n, *args)) / n


def per_evaluation(repeat: int) -> None:
    """Part 1: the compiled integrators per evaluation over the right-hand side alone and chained (full set),
    the four timed in turn within each repeat (timing.py). Both integrators run 0.02 s of the beam's spin
    (about 16,000 and 12,000 evaluations): a run's fixed cost, its call from Python, the model's packing and
    the output's allocation (0.1-0.4 ms), stays within 2 % of it; a run of 1,200 evaluations (the midpoint
    rule's 2 ms before) put up to a third of a right-hand side on each."""
    body = read_body(BEAM)
    m = build_model(body, FULL)
    y0 = beam_state(m)
    runs = {"dop853 (rtol 1e-10)": lambda: integrate(m, y0, 0.02, "dop853", rtol=1e-10, atol=1e-14),
            "midpoint (h = 1e-5)": lambda: integrate(m, y0, 0.02, "midpoint", 1e-5)}
    nfev = {name: run().nfev for name, run in runs.items()}
    timings = {"alone": lambda: rhs_alone(m), "chain": lambda: rhs_alone(m, loop=_rhs_chain),
               **{name: lambda run=run, name=name: seconds(run) / nfev[name] for name, run in runs.items()}}
    per = interleaved(timings, repeat)
    alone, chain = per.pop("alone"), per.pop("chain")
    print(f"compiled right-hand side alone (beam, {body.nf} modes, full set): {alone * 1e6:.2f} us; each call on the "
          f"last one's result, as in an integrator: {chain * 1e6:.2f} us")
    for name, t in per.items():
        print(f"  {name}: {t * 1e6:.2f} us per evaluation, {t / alone:.2f}x the right-hand side alone (target "
              f"<= 1.5), {t / chain:.2f}x the chained calls")


@lru_cache(maxsize=None)
def set_model(terms: tuple[str, ...]):
    """The beam's model of the term set ``terms``."""
    return build_model(read_body(BEAM), terms)


def compiled_cost(count: Counter) -> float:
    """Seconds of the compiled right-hand sides ``count`` (evaluations per term set) alone, each set timed once
    (``rhs_alone``)."""
    return sum(n * rhs_alone(set_model(terms)) for terms, n in count.items())


def evaluations(data: dict) -> tuple[Counter, Counter, list[str]]:
    """Right-hand-side evaluations per term set that ``verify --json`` (``data``) reports: (those of the timed
    runs, one run each; those of the runs taken once, the references), and the parts counted. Rows of sets with
    the same terms share one run (verify.runner.distinct) and count once."""
    rows, timed, once = data["results"], Counter(), Counter()
    runs = {(r["scene"], tuple(r["terms"])): r["rhs_evaluations"] for r in rows}  # sets of equal terms: one run
    for (_, terms), n in runs.items():
        timed[terms] += n
    full = next(tuple(r["terms"]) for r in rows if r["set"] == "IV (full)")  # the references' terms
    for sc in data["scenes"]:
        once[full] += sc["reference"]["rhs_evaluations"] + sc["reference"]["self_check_evaluations"]
    parts = [f"scenes' rows ({len(runs)} runs)", f"references ({2 * len(data['scenes'])} runs, taken once)"]
    if data["work_precision"] is not None:
        terms = {r["set"]: tuple(r["terms"]) for r in rows}
        points = {(terms[p["set"]], p["integrator"], p["setting"]): p["nfev"]
                  for p in data["work_precision"]["points"]}
        for (t, _, _), n in points.items():
            timed[t] += n
        parts.append(f"work-precision points ({len(points)} runs)")
    return timed, once, parts


def floor_timings(flags: list[str]) -> tuple[dict, dict]:
    """Part 3 for ``verify [flags]``: (timings for ``interleaved``: the process and its counted evaluations'
    compiled cost, one run each and the floor with the timed runs x verify's repeats; what to print with them)."""
    cmd = [*NEW_PATH, *VERIFY, *flags]
    data = json.loads(subprocess.run([*cmd, "--json"], check=True, capture_output=True, cwd=ROOT, text=True).stdout)
    timed_count, once, parts = evaluations(data)
    label = " ".join(["default scenes", *flags])
    timings = {label: lambda: wall(cmd, cwd=ROOT), f"{label} timed runs": lambda: compiled_cost(timed_count),
               f"{label} runs taken once": lambda: compiled_cost(once)}
    info = {"label": label, "parts": parts, "total": sum(timed_count.values()) + sum(once.values()),
            "sets": len(timed_count | once), "studies": data["work_precision"] is not None}
    return timings, info


def print_floor(best: dict[str, float], info: dict, repeat: int) -> None:
    label = info["label"]
    wall, timed_s, once_s = best[label], best[f"{label} timed runs"], best[f"{label} runs taken once"]
    one, floor = timed_s + once_s, VERIFY_REPEATS * timed_s + once_s
    print(f"verify beam at 300 rad/s, {label}: process wall {wall:.1f} s (minimum of {repeat}), compiled floor "
          f"{floor:.2f} s ({info['total']} evaluations of {info['sets']} term sets, the timed runs x {VERIFY_REPEATS} "
          f"repeats, timed in turn with the process): {wall / floor:.1f}x the floor (target <= 2; {wall / one:.1f}x "
          f"with one run each)\n  counted: {', '.join(info['parts'])}; not counted (no evaluations reported): "
          + ("the stability studies, the Campbell study, set-up" if info["studies"] else "set-up"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--skip-old", action="store_true", help="skip the former path of part 2")
    parser.add_argument("--sweep", action="store_true")
    args = parser.parse_args()
    per_evaluation(max(args.repeat, 15))  # a round of part 1 takes about 0.1 s
    parts = [floor_timings([]), floor_timings(["--quick"])]
    timings = {k: v for t, _ in parts for k, v in t.items()}
    if not args.skip_old:
        timings["former path"] = lambda: wall([sys.executable, "-c", OLD_PATH, *VERIFY], cwd=ROOT)
    best = interleaved(timings, args.repeat)
    new = best["default scenes"]
    head = (f"verify beam at 300 rad/s (default scenes about both stable axes, term sets, work-precision, stability, "
            f"Campbell), process wall, minimum of {args.repeat}, the two paths in turn: compiled {new:.1f} s, "
            "former path")
    if args.skip_old:
        print(f"{head} skipped (--skip-old)")
    else:
        print(f"{head} {best['former path']:.1f} s: {best['former path'] / new:.1f}x (goal >= 10)")
    for _, info in parts:
        print_floor(best, info, args.repeat)
    if args.sweep:
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "scripts/verify_zoo.py"], check=True, capture_output=True, cwd=ROOT)
        print(f"zoo sweep (scripts/verify_zoo.py): {time.perf_counter() - t0:.0f} s wall")


if __name__ == "__main__":
    main()
