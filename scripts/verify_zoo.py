"""The advisor against simulation on bodies it was not tuned on: python scripts/verify_zoo.py [--jobs N] [--scheduler ADDR].

Test-set bodies of the zoo (docs/zoo.md: seeds from 1000 on, never used to
choose anything; every family, and a second seed of the families with a
symmetry axis) and the six samples, each at 0, 0.003, 0.01, 0.03, 0.1, 0.3
and 0.6 times its smallest s_crit, connection free, through verify's scenes
(docs/scenes.md; at speed 0 the torque pulse only) with the response
criterion. Writes docs/verification.md (the table between its markers, a
per-family summary, the right-hand-side cost of each advice against the
full set's, a sentence for every conservative row) and
docs/verification.json. Rows run on local processes (--jobs) or on a Dask
cluster (--scheduler or DASK_SCHEDULER_ADDRESS); bodies are built once into
--cache (default build/zoo).
"""
from __future__ import annotations

import argparse
import json
import os
import re
import time
from pathlib import Path

import numpy as np

from ffrf_advisor.analysis import Options, analyze
from ffrf_advisor.guidelines import Situation
from ffrf_advisor.io import read_body, write_body
from ffrf_advisor.predict import MARGIN, level_of, reference_terms
from ffrf_advisor.samples import SAMPLES
from ffrf_advisor.significance import softening_speeds
from ffrf_advisor.sim.cost import rhs_cost
from ffrf_advisor.verify.scenes import SCENES
from ffrf_advisor.verify.sweep import Task, run_sweep, run_task
from ffrf_advisor.zoo import FAMILIES, TEST_SEEDS_FROM, zoo_body

ROOT = Path(__file__).resolve().parent.parent
FRACTIONS = (0.0, 0.003, 0.01, 0.03, 0.1, 0.3, 0.6)
SYMMETRIC = ("shaft", "ring")  # a second seed each: spun about their symmetry axis
LEVEL_ORDER = ("I", "II", "III", "IV")
TOLERANCE = 0.01


def zoo_bodies(cache: Path) -> list[tuple[str, Path]]:
    """(family, file) of the test-set bodies, built into ``cache`` when missing."""
    cache.mkdir(parents=True, exist_ok=True)
    chosen = [(f, TEST_SEEDS_FROM) for f in FAMILIES] + [(f, TEST_SEEDS_FROM + 1) for f in SYMMETRIC]
    out = []
    for family, seed in chosen:
        path = cache / f"{family}-{seed}.ffrf.h5"
        if not path.exists():
            write_body(zoo_body(family, seed), path)
        out.append((family, path))
    return out


def tasks(bodies: list[tuple[str, Path]], fractions=FRACTIONS) -> list[Task]:
    out = []
    for _, path in bodies:
        s_crit = float(np.min(softening_speeds(read_body(path))))
        out += [Task(str(path), f * s_crit, f, ("torque-pulse",) if f == 0 else SCENES, TOLERANCE) for f in fractions]
    return out


def row_of(task: Task) -> dict:
    """The verification row with the advice's predictions and its cost against the full set's."""
    row = run_task(task)
    body = read_body(task.body)
    a = analyze(body, Options(situation=Situation(w_op=row["advice_speed_rad_s"], tolerance=task.tolerance,
                                                  excitation=row["advice_excitation"])))
    full = rhs_cost(reference_terms(body), body.nf)
    row["cost_ratio"] = rhs_cost(row["advised_terms"], body.nf) / full
    row["predicted"] = {c.label: {"label": c.label, "terms": list(c.terms), "errors": c.errors, "axes": c.axes}
                        for c in a.advice.candidates}
    return row


def _fmt(x) -> str:
    return "fail" if x is None else f"{x:.2g}"


def deciding(row: dict) -> str:
    """What decided the verdict: what broke the advice, or the advised set's worst error and that of the next
    cheaper level set than the cheapest adequate one."""
    w = row["worst_error"]
    if row["verdict"] == "unsafe":
        return "; ".join(f"{s} {q} {_fmt(e)}" for s, q, e in row["broken"][:2])
    unjudged = "; ".join(f"no verdict in {s}" for s, _ in row.get("unjudged", []))
    if row["verdict"] == "no verdict" or row["cheapest"] is None:
        return unjudged or "-"
    cheaper = [lv for lv in LEVEL_ORDER[:LEVEL_ORDER.index(row["cheapest"])] if _label(w, lv)]
    text = f"advised {_fmt(w['advised'])}" + (f", {cheaper[-1]} {_fmt(w[_label(w, cheaper[-1])])}" if cheaper else "")
    return text + (f" (over every scene); {unjudged}" if unjudged else "")


def _label(worst: dict, level: str) -> str | None:
    """The set label a level's verdict set ran under (closed or canonical), None when it did not run."""
    return next((lab for lab in (f"{level} (closed)", level, "IV (full)" if level == "IV" else None) if lab in worst),
                None)


def why_conservative(row: dict) -> str:
    """A sentence for a conservative row: the cheaper level set that met the tolerance, and which of its
    predicted errors exceeded tolerance / MARGIN."""
    level = row["cheapest"]
    simulated = row["worst_error"].get(_label(row["worst_error"], level))
    match = next((p for p in row["predicted"].values() if p["label"] == level or level_of(p["terms"]) == level), None)
    if match is None:
        return f"level {level} meets the tolerance (worst {_fmt(simulated)}); it was no candidate of the advice"
    kind = max(match["errors"], key=match["errors"].get)
    where = "in the scenes with a verdict" if row.get("unjudged") else "in the scenes"
    return (f"level {level} meets the tolerance {where} (worst {_fmt(simulated)} over all), but its predicted {kind} "
            f"error {_fmt(match['errors'][kind])} exceeds {TOLERANCE / MARGIN:g} about principal axis "
            f"{match['axes'][kind] + 1}")


def counts(verdicts) -> str:
    verdicts = list(verdicts)
    n = {v: verdicts.count(v) for v in ("agree", "conservative", "unsafe", "no verdict")}
    return (f"{len(verdicts)} rows: {n['agree']} agree, {n['conservative']} conservative, {n['unsafe']} unsafe, "
            f"{n['no verdict']} no verdict")


def table(rows: list[dict]) -> str:
    lines = ["| family | body | / s_crit | speed [rad/s] | advised | advised terms | rhs / full | cheapest adequate "
             "| verdict | deciding worst errors |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['family']} | {r['body']} | {r['fraction_of_s_crit']:g} | {r['advice_speed_rad_s']:.4g} | "
                     f"{r['advised_level']} | {', '.join(t for t in r['advised_terms'] if t != 'gyro0') or '-'} | "
                     f"{r['cost_ratio']:.2f} | {r['cheapest'] or 'none'} | {r['verdict']} | {deciding(r)} |")
    return "\n".join(lines)


def summary(rows: list[dict]) -> str:
    lines = ["| family | rows | agree | conservative | unsafe | no verdict | mean rhs / full |", "|---|---|---|---|---|---|---|"]
    for family in dict.fromkeys(r["family"] for r in rows):
        mine = [r for r in rows if r["family"] == family]
        n = {v: sum(r["verdict"] == v for r in mine) for v in ("agree", "conservative", "unsafe", "no verdict")}
        lines.append(f"| {family} | {len(mine)} | {n['agree']} | {n['conservative']} | {n['unsafe']} | "
                     f"{n['no verdict']} | {np.mean([r['cost_ratio'] for r in mine]):.2f} |")
    return "\n".join(lines)


def document(rows: list[dict], wall: float, jobs: int) -> str:
    zoo = [r for r in rows if r["family"] != "sample"]
    samples = [r for r in rows if r["family"] == "sample"]
    conservative = [r for r in rows if r["verdict"] == "conservative"]
    parts = [summary(rows), "",
             f"Test-set zoo bodies by the {rows[0]['criterion']} errors: {counts(r['verdict'] for r in zoo)}; "
             f"by the trajectory errors: {counts(r['other_criteria']['trajectory']['verdict'] for r in zoo)}.",
             (f"Samples by the {rows[0]['criterion']} errors: {counts(r['verdict'] for r in samples)}."
              if samples else "Samples: not in this run (`--no-samples`)."), "", table(rows), ""]
    if conservative:
        parts += ["Why each conservative row is conservative:", ""]
        parts += [f"- {r['body']} at {r['fraction_of_s_crit']:g} s_crit: {why_conservative(r)}." for r in conservative]
        parts.append("")
    parts.append(f"Made by `python scripts/verify_zoo.py` in {wall:.0f} s wall ({jobs} local processes).")
    return "\n".join(parts)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--scheduler", default=None)
    parser.add_argument("--cache", type=Path, default=ROOT / "build" / "zoo")
    parser.add_argument("--families", nargs="*", default=None, help="only these zoo families ('sample': the samples)")
    parser.add_argument("--no-samples", action="store_true", help="the zoo bodies only")
    parser.add_argument("--fractions", nargs="*", type=float, default=FRACTIONS, help="only these shares of s_crit")
    parser.add_argument("--merge", action="store_true", help="replace only the rows run in docs/verification.json "
                                                              "and keep the others")
    parser.add_argument("--from-json", action="store_true", help="remake docs/verification.md from the rows of "
                                                                   "docs/verification.json without running them")
    args = parser.parse_args()
    saved = ROOT / "docs" / "verification.json"
    if args.from_json:
        data = json.loads(saved.read_text())
        return write_docs(data["rows"], data["wall_s"], data["jobs"])
    start = time.perf_counter()
    chosen = (lambda family: args.families is None or family in args.families)
    bodies = [b for b in zoo_bodies(args.cache) if chosen(b[0])]
    if not args.no_samples and chosen("sample"):
        bodies += [("sample", ROOT / "sample_bodies" / f"{name}.ffrf.h5") for name in SAMPLES]
    family_of = {str(path): family for family, path in bodies}
    work = tasks(bodies, tuple(args.fractions))
    rows = [dict(r, family=family_of[t.body]) for r, t in zip(run_sweep(work, args.jobs, args.scheduler, row_of), work)]
    wall = time.perf_counter() - start
    if args.merge:
        rows, wall = merged(json.loads(saved.read_text()), rows, wall)
    saved.write_text(json.dumps({"rows": rows, "wall_s": wall, "jobs": args.jobs}, indent=1) + "\n")
    write_docs(rows, wall, args.jobs)


def merged(old: dict, new: list[dict], wall: float) -> tuple[list[dict], float]:
    """The saved rows with those run now in their place (same body and share of s_crit), new ones appended;
    the wall time is the sum of the runs that made them."""
    key = (lambda r: (r["body"], r["fraction_of_s_crit"]))
    fresh = {key(r): r for r in new}
    rows = [fresh.pop(key(r), r) for r in old["rows"]]
    return rows + list(fresh.values()), old["wall_s"] + wall


def write_docs(rows: list[dict], wall: float, jobs: int) -> None:
    """The generated part of docs/verification.md, between its markers; printed too."""
    doc = ROOT / "docs" / "verification.md"
    block = f"<!-- table:start -->\n{document(rows, wall, jobs)}\n<!-- table:end -->"
    doc.write_text(re.sub(r"<!-- table:start -->.*<!-- table:end -->", lambda _: block, doc.read_text(), flags=re.S))
    print(document(rows, wall, jobs))


if __name__ == "__main__":
    main()
