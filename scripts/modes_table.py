"""The mode-set advice against simulation over the samples and the zoo: python scripts/modes_table.py [--jobs N].

Bodies: the six samples regenerated with 40 modes and one test-set body of
each zoo family (seed 1000, the zoo's 12 modes), built once into --cache
(default build/modes; never commit it). Each at 0.1 and 0.5 times its
smallest finite s_crit (without one: 2 pi f1 / 10 and 2 pi f1 / 2), advised
for the inertial scenes (modeset.INERTIAL_SCENES: spin-up, torque-pulse,
minor-axis; ``advise_modes``) and proved by simulation against the reference
basis (all modes plus the six residual vectors; ``modeset_proof.prove``).
Per row: modes kept, residual vectors, predicted and simulated error, the RK4
cost of the advised basis at its stable step over the reference's, the
DOP853 evaluations of the advised basis over those of the largest first-k
basis the proof ran (the reference's own evaluations are not kept), and the
verdict (``verdict``). Writes the table and one sentence per conservative,
unsafe or flagged row between the markers of docs/modes.md, the raw numbers
to docs/modes.json.

    python scripts/modes_table.py --jobs 2            # every row, two local processes
    python scripts/modes_table.py --only beam shaft   # a subset (sample names or zoo families)
    python scripts/modes_table.py --from-json         # remake the docs from docs/modes.json

Rows run in parallel on --jobs local processes (ffrf_advisor.pool.mapper),
the largest body files first; each prints its wall time. --only runs merge
into the saved rows of docs/modes.json (same body and speed replaced).

Run time (2 cores, 2026-11-25): all 40 rows in 1098 s wall with --jobs 2 (the
two carbody rows, 40 modes of a 66 MB body file, 428 s each side by side; the
genstruct rows 2.5-4 min, conrod about a minute, the zoo rows 10-30 s).
"""
from __future__ import annotations

import argparse
import json
import math
import re
import time
from pathlib import Path

import numpy as np

from ffrf_advisor.analysis import Options, analyze
from ffrf_advisor.fe_body import modal_body
from ffrf_advisor.guidelines import Situation
from ffrf_advisor.io import read_body, write_body
from ffrf_advisor.modeset import CASES, INERTIAL_SCENES, advise_modes, inertia_loads
from ffrf_advisor.modeset_proof import RTOLS, prove
from ffrf_advisor.pool import mapper
from ffrf_advisor.samples import RECIPES
from ffrf_advisor.zoo import FAMILIES, TEST_SEEDS_FROM, zoo_body

ROOT = Path(__file__).resolve().parent.parent
DOC, SAVED = ROOT / "docs" / "modes.md", ROOT / "docs" / "modes.json"
MARKERS = ("<!-- modes-table:start -->", "<!-- modes-table:end -->")
SAMPLE_MODES = 40
FRACTIONS = (0.1, 0.5)       # of the smallest finite s_crit
TOLERANCE = 0.01
VERDICTS = ("safe", "conservative", "unsafe", "flagged")


# ------------------------------------------------------------------ bodies and rows
def body_names(only=None) -> list[str]:
    """Sample names and "zoo:FAMILY", in table order; with ``only``, those named there (a bare name picks the
    sample and the zoo family of that name: "plate" is both)."""
    names = [*RECIPES, *(f"zoo:{f}" for f in FAMILIES)]
    picked = [n for n in names if not only or n in only or n.removeprefix("zoo:") in only]
    if only and not picked:
        raise SystemExit(f"--only {' '.join(only)}: expected sample names or zoo families: {', '.join(names)}")
    return picked


def build(name: str, cache: Path) -> str:
    """The cached body file of a sample (40 modes) or a zoo family (seed 1000), built when missing."""
    family = name.removeprefix("zoo:")
    path = cache / (f"{name}-{SAMPLE_MODES}.ffrf.h5" if name in RECIPES else f"zoo-{family}-{TEST_SEEDS_FROM}.ffrf.h5")
    if not path.exists():
        start = time.perf_counter()
        if name in RECIPES:
            make_mesh, material, _ = RECIPES[name]
            body = modal_body(make_mesh(1), material, SAMPLE_MODES, name=name)
        else:
            body = zoo_body(family, TEST_SEEDS_FROM)
        write_body(body, path)
        print(f"built {path.name} in {time.perf_counter() - start:.0f} s", flush=True)
    return str(path)


def speeds(path: str) -> tuple[list[tuple[float, float]], str, list]:
    """[(fraction, speed)], what the fractions are of, and the per-axis s_crit (None where unknown)."""
    body = read_body(path)
    s_crit = analyze(body, Options()).significance.s_crit
    finite = [] if s_crit is None else [float(s) for s in s_crit if np.isfinite(s) and s > 0]
    base, of = (min(finite), "s_crit") if finite else (2 * math.pi * float(body.frequencies_hz[0]), "2 pi f1")
    shown = None if s_crit is None else [float(s) if np.isfinite(s) else None for s in s_crit]
    return [(f, f * base) for f in FRACTIONS], of, shown


def tasks(names: list[str], cache: Path) -> list[dict]:
    out = []
    for name in names:
        path = build(name, cache)
        pairs, of, s_crit = speeds(path)
        out += [{"body": name, "kind": "sample" if name in RECIPES else "zoo", "path": path, "fraction": f,
                 "of": of, "speed": w, "s_crit": s_crit} for f, w in pairs]
    return out


def _weight(task: dict) -> int:
    """A guess of a row's run time for the order of the work: the size of its body file."""
    return Path(task["path"]).stat().st_size


def run_row(task: dict) -> dict:
    """Advice and proof of one body at one speed, reduced to the numbers of the table."""
    start = time.perf_counter()
    body = read_body(task["path"], load_fe=True)
    a = analyze(body, Options(situation=Situation(w_op=task["speed"], tolerance=TOLERANCE)))
    loads = inertia_loads(body)
    advice = advise_modes(a, INERTIAL_SCENES, tolerance=TOLERANCE, loads=loads)
    proof = prove(a, advice, loads, INERTIAL_SCENES)
    row = dict(task, **advice_numbers(advice), **proof_numbers(proof), time_s=time.perf_counter() - start)
    row["verdict"] = verdict(row["predicted"], row["simulated"])
    print(f"{task['body']} at {task['fraction']:g} {task['of']} ({task['speed']:.4g} rad/s): {row['verdict']} "
          f"in {row['time_s']:.0f} s", flush=True)
    return row


def advice_numbers(advice) -> dict:
    res = bool(advice.residual_cases)
    per_scene = [p[1] if res else p[0] for p in advice.predicted]
    return {"nf": advice.nf, "kept": [k + 1 for k in advice.kept],
            "residual": [CASES[j] for j in advice.residual_cases], "size": advice.size,
            "predicted": _number(advice.worst(res)), "predicted_with_residual": res,
            "predicted_scenes": {s.label: _number(p) for s, p in zip(advice.scenes, per_scene)},
            "scenes": [{"label": s.label, "f_exc_hz": s.f_exc, "excited_by": s.excited_by,
                        "cases": [CASES[j] for j in s.cases]} for s in advice.scenes],
            "rhs_ratio": advice.rhs_ratio, "notes": list(advice.notes)}


def proof_numbers(proof) -> dict:
    advised = proof.at("advised")
    worst = max(advised, key=lambda r: max(r.errors.values()))
    firsts = sorted((n for n in proof.sizes if n.startswith("first ") or n == "all modes"), key=proof.sizes.get)
    other = firsts[-1]  # all modes (first nf) where the proof ran it, else the largest first k
    scenes = sorted({r.scene for r in proof.runs})
    rk4 = {b: sum(proof.rk4_cost[(b, s)] for s in scenes) for b in ("advised", "reference")}
    nfev = {b: sum(r.nfev for r in proof.at(b)) for b in ("advised", other)}
    cost = {b: sum(r.cost for r in proof.at(b)) for b in ("advised", other)}
    return {"sizes": dict(proof.sizes), "proof_verdict": proof.verdict,
            "simulated": _number(max(worst.errors.values())),
            "simulated_where": {"scene": worst.scene, "measure": max(worst.errors, key=worst.errors.get)},
            "simulated_scenes": {r.scene: _number(max(r.errors.values())) for r in advised},
            "rk4_ratio": rk4["advised"] / rk4["reference"], "evals_basis": other,
            "evals_ratio": nfev["advised"] / nfev[other], "dop853_cost_ratio": cost["advised"] / cost[other],
            "rtol": RTOLS[-1], "basis_worst": {b: _number(max(max(r.errors.values()) for r in proof.at(b)))
                                                for b in proof.sizes if b != "reference"},
            "worst_scene_errors": {b: {m: _number(e) for r in proof.at(b) if r.scene == worst.scene
                                       for m, e in r.errors.items()} for b in proof.sizes if b != "reference"}}


def _number(x):
    """JSON-safe: None stays (no compliance), NaN as 'none' (no prediction: see the row's notes), infinities as
    'inf'."""
    if x is None:
        return None
    return "none" if np.isnan(x) else float(x) if np.isfinite(x) else "inf"


def _short(x):
    """``x`` with every float rounded to 6 significant digits (a shorter docs/modes.json; the table shows 2-3)."""
    if isinstance(x, float):
        return float(f"{x:.6g}")
    if isinstance(x, dict):
        return {k: _short(v) for k, v in x.items()}
    return [_short(v) for v in x] if isinstance(x, list) else x


def _value(x) -> float:
    """A number for the verdict: no prediction ('none') and 'inf' count as above the tolerance."""
    return math.inf if x in ("inf", "none") else x


def verdict(predicted, simulated) -> str:
    """safe: simulated within the tolerance and so predicted; conservative: predicted above, simulated within;
    unsafe: simulated above although predicted within (or not bounded); flagged: both above."""
    sim_ok = _value(simulated) <= TOLERANCE
    pred_ok = predicted is None or _value(predicted) <= TOLERANCE
    return ("safe" if pred_ok else "conservative") if sim_ok else ("unsafe" if pred_ok else "flagged")


# ------------------------------------------------------------------ the document
def _fmt(x) -> str:
    return "n/a" if x is None else x if x in ("inf", "none") else f"{x:.2g}"


def table(rows: list[dict]) -> str:
    lines = ["| body | / of | speed [rad/s] | modes kept / nf | residual vectors | predicted | simulated "
             "| RK4 cost / reference | DOP853 evaluations / first-k (k) | verdict |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        first_k = r["sizes"][r["evals_basis"]]
        lines.append(f"| {r['body']} | {r['fraction']:g} {r['of']} | {r['speed']:.4g} | {len(r['kept'])} / {r['nf']} "
                     f"| {', '.join(r['residual']) or '-'} | {_fmt(r['predicted'])} | {_fmt(r['simulated'])} "
                     f"| {r['rk4_ratio']:.2g} | {r['evals_ratio']:.2f} ({first_k}) | {r['verdict']} |")
    return "\n".join(lines)


def why(row: dict) -> str:
    """One sentence for a conservative, unsafe or flagged row, from the advice's numbers and notes."""
    scenes = {s["label"]: s for s in row["scenes"]}
    pred = {k: _value(v) for k, v in row["predicted_scenes"].items() if v is not None}
    head = f"{row['body']} at {row['fraction']:g} {row['of']} ({row['speed']:.4g} rad/s)"
    if row["of"] == "s_crit":
        head += f", s_crit per axis {', '.join('-' if s is None else f'{s:.4g}' for s in row['s_crit'])} rad/s"
    parts = []
    if pred:
        scene = max(pred, key=pred.get)
        s = scenes[scene]
        parts.append(f"predicted {_fmt(row['predicted_scenes'][scene])} "
                     f"({'with' if row['predicted_with_residual'] else 'without'} residual vectors) is worst in "
                     f"{scene}, which excites up to {s['f_exc_hz']:.4g} Hz ({s['excited_by']})")
    where = row["simulated_where"]
    parts.append(f"simulated {_fmt(row['simulated'])} worst in {where['scene']} ({where['measure']}), where "
                 f"{_fmt(row['predicted_scenes'].get(where['scene']))} was predicted and {others(row)}")
    notes = "; ".join(row["notes"])
    return f"- {head}: {'; '.join(parts)}" + (f". Notes of the advice: {notes}." if notes else ".")


def others(row: dict) -> str:
    """What the other bases of the proof erred in the advised basis' worst scene and measure."""
    where = row["simulated_where"]
    errs = {b: e[where["measure"]] for b, e in row["worst_scene_errors"].items() if b != "advised"}
    return "the other bases erred " + ", ".join(f"{_fmt(e)} ({b})" for b, e in errs.items())


def counts(rows: list[dict]) -> str:
    return ", ".join(f"{sum(r['verdict'] == v for r in rows)} {v}" for v in VERDICTS)


def revision() -> str:
    """The git revision of the ffrf_advisor imported (``-dirty`` with uncommitted changes), or where it lies."""
    import subprocess

    import ffrf_advisor
    src = Path(ffrf_advisor.__file__).resolve().parent
    if ROOT not in src.parents:
        return f"a copy at {src}"
    out = subprocess.run(["git", "-C", str(ROOT), "describe", "--always", "--dirty"], capture_output=True, text=True)
    return out.stdout.strip() or "unknown"


def document(rows: list[dict], wall: float, jobs: int, left_out: list[str], rev: str) -> str:
    explained = [r for r in rows if r["verdict"] != "safe"]
    parts = [f"Tolerance {TOLERANCE:g}; predicted: the advice's worst scene error (with its residual vectors "
             "where it has them; none: no prediction, the advice's note says why); simulated: the advised basis' worst error over the scenes and the measures "
             f"(w, orientation, largest displacement, peak stress) against the reference at rtol {RTOLS[-1]:g}. "
             "RK4 cost: the advised basis at its stable step over the reference (all modes and six residual "
             "vectors), summed over the scenes. DOP853 evaluations: the advised basis over all modes without residual "
             "vectors (or the largest first-k basis, k in brackets; the reference's evaluations are not kept), "
             "summed over the scenes "
             f"at rtol {RTOLS[-1]:g}. Verdict: safe (simulated within, and so predicted), conservative (predicted "
             "above, simulated within), unsafe (simulated above, predicted within), flagged (both above, or no "
             "prediction and simulated above: the advice said it cannot carry or judge the scene).", ""]
    if left_out:
        parts += [f"Not in this run: {', '.join(left_out)}.", ""]
    parts += [f"{len(rows)} rows: {counts(rows)}.", "", table(rows), ""]
    if explained:
        parts += ["Why each row that is not safe is what it is:", "", *[why(r) for r in explained], ""]
    parts.append(f"Made by `python scripts/modes_table.py --jobs {jobs}` in {wall:.0f} s wall (summed over the runs "
                 f"merged into docs/modes.json with --only), ffrf_advisor at {rev}.")
    return "\n".join(parts)


def write_docs(rows: list[dict], wall: float, jobs: int, rev: str) -> None:
    order = {n: i for i, n in enumerate(body_names())}
    rows = sorted(rows, key=lambda r: (order[r["body"]], r["fraction"]))
    left_out = [n for n in body_names() if n not in {r["body"] for r in rows}]
    text = document(rows, wall, jobs, left_out, rev)
    block = f"{MARKERS[0]}\n{text}\n{MARKERS[1]}"
    pattern = re.escape(MARKERS[0]) + ".*" + re.escape(MARKERS[1])
    DOC.write_text(re.sub(pattern, lambda _: block, DOC.read_text(), flags=re.S))
    print(text)


def merged(rows: list[dict], wall: float, rev: str) -> tuple[list[dict], float, str]:
    """The saved rows with those run now in their place (same body and fraction); the wall times add, the
    revisions are named both where they differ."""
    if not SAVED.exists():
        return rows, wall, rev
    old = json.loads(SAVED.read_text())
    fresh = {(r["body"], r["fraction"]): r for r in rows}
    kept = [r for r in old["rows"] if (r["body"], r["fraction"]) not in fresh]
    old_rev = old.get("revision", "unknown")
    return kept + rows, old["wall_s"] + wall, rev if old_rev == rev else f"{old_rev} and {rev}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=1, help="local processes (rows in parallel)")
    parser.add_argument("--only", nargs="*", default=None, help="only these sample names or zoo families")
    parser.add_argument("--cache", type=Path, default=ROOT / "build" / "modes", help="built bodies (.ffrf.h5)")
    parser.add_argument("--from-json", action="store_true", help="remake the docs from docs/modes.json")
    args = parser.parse_args()
    if args.from_json:
        saved = json.loads(SAVED.read_text())
        rows = [dict(r, verdict=verdict(r["predicted"], r["simulated"])) for r in saved["rows"]]
        return write_docs(rows, saved["wall_s"], saved["jobs"], saved.get("revision", "unknown"))
    start = time.perf_counter()
    args.cache.mkdir(parents=True, exist_ok=True)
    names = body_names(args.only)
    with mapper(args.jobs) as fmap:
        list(fmap(build, names, [args.cache] * len(names)))  # bodies in parallel; tasks() then finds them
        work = tasks(names, args.cache)
        order = sorted(range(len(work)), key=lambda i: -_weight(work[i]))  # the longest first: even load
        rows = [None] * len(work)
        for i, row in zip(order, fmap(run_row, [work[i] for i in order])):
            rows[i] = row
    wall = time.perf_counter() - start
    rev = revision()
    if args.only:
        rows, wall, rev = merged(rows, wall, rev)
    saved = [{k: v for k, v in r.items() if k != "path"} for r in rows]  # the cache is no part of the docs
    SAVED.write_text(json.dumps(_short({"rows": saved, "wall_s": wall, "jobs": args.jobs, "revision": rev})) + "\n")
    write_docs(rows, wall, args.jobs, rev)


if __name__ == "__main__":
    main()
