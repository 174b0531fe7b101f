"""The advisor against simulation over the shipped samples: python scripts/verify_samples.py [--jobs N] [--scheduler ADDR].

Every sample body at 0 (torque pulse only), 0.03, 0.1, 0.3 and 0.6 times
its smallest s_crit, connection free, through the scenes (theory section
10); writes docs/verification.md (the table between its markers) and
docs/verification.json, and prints the wall time. Rows run on local
processes (--jobs) or on a Dask cluster (--scheduler or
DASK_SCHEDULER_ADDRESS).
"""
from __future__ import annotations

import argparse
import json
import os
import re
import time
from pathlib import Path

import numpy as np

from ffrf_advisor.io import read_body
from ffrf_advisor.samples import SAMPLES
from ffrf_advisor.significance import softening_speeds
from ffrf_advisor.verify.scenes import SCENES
from ffrf_advisor.verify.sweep import Task, run_sweep

ROOT = Path(__file__).resolve().parent.parent
FRACTIONS = (0.0, 0.03, 0.1, 0.3, 0.6)
LEVEL_ORDER = ("I", "II", "III", "IV")


def tasks(names) -> list[Task]:
    out = []
    for name in names:
        path = ROOT / "sample_bodies" / f"{name}.ffrf.h5"
        s_crit = float(np.min(softening_speeds(read_body(path))))
        for f in FRACTIONS:
            scenes = ("torque-pulse",) if f == 0 else SCENES
            out.append(Task(str(path), f * s_crit, f, scenes))
    return out


def _fmt(x) -> str:
    return "fail" if x is None else f"{x:.2g}"


def deciding(row: dict) -> str:
    """The errors that decided the verdict: what broke the advice, or the advised and the next cheaper level."""
    w = row["worst_error"]
    if row["verdict"] == "unsafe":
        return "; ".join(f"{s.split(' (')[0]} {q} {_fmt(e)}" for s, q, e in row["broken"][:2])
    lower = LEVEL_ORDER[LEVEL_ORDER.index(row["cheapest"]) - 1] if row["cheapest"] not in (None, "I") else None
    text = f"advised {_fmt(w['advised'])}"
    if lower:
        text += f", {lower} {_fmt(w[lower if lower != 'IV' else 'IV (full)'])}"
    return text


def counts(verdicts) -> str:
    verdicts = list(verdicts)
    n = {v: verdicts.count(v) for v in ("agree", "conservative", "unsafe")}
    return f"{len(verdicts)} rows: {n['agree']} agree, {n['conservative']} conservative, {n['unsafe']} unsafe"


def table(rows: list[dict]) -> str:
    lines = ["| body | speed [rad/s] | / s_crit | advice at [rad/s] | advised | advised terms | cheapest adequate "
             "| verdict | deciding worst errors |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['body']} | {r['speed_rad_s']:.4g} | {r['fraction_of_s_crit']:g} | "
                     f"{r['advice_speed_rad_s']:.4g} | {r['advised_level']} | "
                     f"{', '.join(t for t in r['advised_terms'] if t != 'gyro0') or '-'} | {r['cheapest'] or 'none'} | "
                     f"{r['verdict']} | {deciding(r)} |")
    lines.append("")
    lines.append(f"By the {rows[0]['criterion']} errors: {counts(r['verdict'] for r in rows)}.")
    for c in rows[0]["other_criteria"]:
        lines.append(f"By the {c} errors: {counts(r['other_criteria'][c]['verdict'] for r in rows)}.")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", default=list(SAMPLES))
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--scheduler", default=None)
    args = parser.parse_args()
    start = time.perf_counter()
    rows = run_sweep(tasks(args.names), args.jobs, args.scheduler)
    wall = time.perf_counter() - start
    (ROOT / "docs" / "verification.json").write_text(json.dumps({"rows": rows}, indent=1) + "\n")
    doc = ROOT / "docs" / "verification.md"
    text = doc.read_text()
    block = (f"<!-- table:start -->\n{table(rows)}\n\nMade by `python scripts/verify_samples.py` in {wall:.0f} s "
             f"wall ({args.jobs} local processes).\n<!-- table:end -->")
    doc.write_text(re.sub(r"<!-- table:start -->.*<!-- table:end -->", lambda _: block, text, flags=re.S))
    print(table(rows))
    print(f"wall time {wall:.1f} s")


if __name__ == "__main__":
    main()
