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
     docs/verification.md);
  5. (--series, issue 52) the mode-count series: the beam's recipe with 12, 24, 48 and 96 modes, `verify --quick
     --repeat 1` of each as a process (after one untimed run that fills numba's cache), its CPU time against the
     12-mode body's (target: 96 modes at most 3x);
     with --series-default also the default `verify` of the 96-mode body (target: under 60 CPU-s);
  6. (--series) `verify --quick` of the beam: every evaluation it makes (its runs, counted as they return, and
     the compiled timing loops) against one run of each reference and distinct set (target: at most 1.1x);
  7. (--series) the exponential integrator (sim.lawson) against the compiled DOP853 on every scene's reference
     (full set, rtol 1e-10) of each sample and each series body: evaluations and CPU-time ratios per body.
Timings are minima over repeats, taken serially, those of each part in turn within each repeat (timing.py);
parts 5-7 are CPU times of one run each.

Run: python benchmarks/bench_verify.py [--repeat N] [--skip-old] [--sweep] [--series [--series-default]]
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


SERIES = (12, 24, 48, 96)
SAMPLES = ("beam", "carbody", "conrod", "genstruct1", "genstruct2", "plate")
COUNTING = """
import sys
from ffrf_advisor.sim import timing
from ffrf_advisor.verify import runner
runs, loops, inner, inner_loop = [], [], runner.run_scene, timing._evaluations
def counting(*args, **kwargs):
    runs.append(inner(*args, **kwargs))
    return runs[-1]
def loop(rhs, y, out, n, *rest):
    loops.append(n)
    return inner_loop(rhs, y, out, n, *rest)
runner.run_scene, timing._evaluations = counting, loop
from ffrf_advisor.cli import app
sys.argv = ['ffrf-advisor', *sys.argv[1:]]
try:
    app()
except SystemExit:
    pass
print(sum(r.nfev for r in runs), sum(loops), file=sys.stderr)
"""


def series_body(nf: int, folder: Path) -> Path:
    """The beam's recipe (samples.beam_mesh, steel) with ``nf`` modes, written to ``folder``."""
    from ffrf_advisor.fe.material import STEEL
    from ffrf_advisor.fe_body import modal_body
    from ffrf_advisor.io import write_body
    from ffrf_advisor.samples import beam_mesh
    path = folder / f"beam{nf}.ffrf.h5"
    if not path.exists():
        write_body(modal_body(beam_mesh(1), STEEL, nf, name=f"beam{nf}"), path)
    return path


def child_cpu(cmd: list[str]) -> tuple[float, str, str]:
    """(CPU seconds of the process ``cmd`` and its children, stdout, stderr)."""
    import resource
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    done = subprocess.run(cmd, check=True, capture_output=True, cwd=ROOT, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime, done.stdout, done.stderr


def mode_series(folder: Path, default: bool) -> list[Path]:
    """Part 5: verify --quick (and optionally the default verify of the last body) of the series bodies."""
    bodies, cpu = [series_body(nf, folder) for nf in SERIES], {}
    child_cpu([*NEW_PATH, "verify", str(bodies[0]), "--scene", "free-spin", "--quick", "--repeat", "1"])  # compiles
    for nf, path in zip(SERIES, bodies):
        cpu[nf], out, _ = child_cpu([*NEW_PATH, "verify", str(path), "--speed", "300rad/s", "--quick", "--repeat", "1",
                                     "--json"])
        data = json.loads(out)
        runs = {(r["scene"], tuple(r["terms"])): r["rhs_evaluations"] for r in data["results"]}
        refs = sum(sc["reference"]["rhs_evaluations"] + sc["reference"]["self_check_evaluations"]
                   for sc in data["scenes"])
        print(f"verify --quick, beam recipe with {nf} modes (highest {read_body(path).frequencies_hz[-1]:.0f} Hz): "
              f"{cpu[nf]:.1f} CPU-s, {cpu[nf] / cpu[SERIES[0]]:.2f}x the {SERIES[0]}-mode body's (target for 96 "
              f"modes: <= 3); evaluations: sets {sum(runs.values())}, references {refs}; verdict "
              f"{data['verdict']['verdict']}", flush=True)
    if default:
        t, _, _ = child_cpu([*NEW_PATH, "verify", str(bodies[-1]), "--speed", "300rad/s", "--repeat", "1", "--json"])
        print(f"default verify, {SERIES[-1]} modes: {t:.1f} CPU-s (target < 60)", flush=True)
    return bodies


def evaluations_ratio() -> None:
    """Part 6: every evaluation of verify --quick of the beam against one run of each reference and set."""
    _, out, err = child_cpu([sys.executable, "-c", COUNTING, "verify", str(BEAM), "--speed", "300rad/s", "--quick",
                             "--repeat", "1", "--json"])
    made, loops = (int(v) for v in err.split()[-2:])
    data = json.loads(out)
    once = sum({(r["scene"], tuple(r["terms"])): r["rhs_evaluations"] for r in data["results"]}.values()) + sum(
        sc["reference"]["rhs_evaluations"] for sc in data["scenes"])
    print(f"verify --quick beam at 300 rad/s: {made + loops} evaluations ({made} in runs, {loops} in the timing "
          f"loops) against {once} of one run per reference and set: {(made + loops) / once:.3f}x (target <= 1.1)",
          flush=True)


def exponential_against_dop853(bodies: list[Path]) -> None:
    """Part 7: every scene's reference model at rtol 1e-10, exponential against compiled DOP853, per body."""
    from ffrf_advisor.analysis import Options, analyze
    from ffrf_advisor.guidelines import Situation
    from ffrf_advisor.verify import runner
    from ffrf_advisor.verify.measures import worst
    from ffrf_advisor.verify.reference import scene_errors
    from ffrf_advisor.verify.scenes import SCENES, make_scenes
    for path in [ROOT / "sample_bodies" / f"{n}.ffrf.h5" for n in SAMPLES] + bodies:
        body = read_body(path)
        a = analyze(body, Options(situation=Situation(w_op=300.0 if "beam" in path.name else None)))
        scenes = make_scenes(list(SCENES), a)
        a = runner.for_scenes(a, scenes)
        nfev, cpu, err = Counter(), Counter(), 0.0
        for sc in scenes:
            model, runs = runner.reference_model(a, sc), {}
            for name in ("dop853", "exponential"):
                t0 = time.process_time()
                runs[name] = runner.run_scene(model, sc, name, rtol=1e-10)
                cpu[name] += time.process_time() - t0
                nfev[name] += runs[name].nfev
            err = max(err, worst(scene_errors(a, runs["exponential"], runs["dop853"]), "response"))
        print(f"{body.name} ({body.nf} modes, {body.frequencies_hz[-1]:.0f} Hz, {len(scenes)} scenes), rtol 1e-10: "
              f"exponential / DOP853 evaluations {nfev['exponential'] / nfev['dop853']:.2f} ({nfev['exponential']} / "
              f"{nfev['dop853']}), CPU {cpu['exponential'] / cpu['dop853']:.2f}; largest response difference "
              f"{err:.1e}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--skip-old", action="store_true", help="skip the former path of part 2")
    parser.add_argument("--sweep", action="store_true")
    parser.add_argument("--series", action="store_true", help="parts 5-7 only (issue 52)")
    parser.add_argument("--series-default", action="store_true", help="with --series: the default verify too")
    args = parser.parse_args()
    if args.series:
        import tempfile
        print(f"bench_verify parts 5-7, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}", flush=True)
        with tempfile.TemporaryDirectory() as folder:
            bodies = mode_series(Path(folder), args.series_default)
            evaluations_ratio()
            exponential_against_dop853(bodies)
        return
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
