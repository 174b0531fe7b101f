"""Regenerate the shipped sample bodies: python scripts/make_samples.py [--docs] [--convergence] [NAME ...].

Writes sample_bodies/NAME.ffrf.h5 (bit-for-bit reproducible on one
machine). With --docs also renders docs/samples/NAME.png and rewrites the
advice table of docs/samples.md; with --convergence the mesh-convergence
table (first frequencies at refine 1 and 2, slow). Tables are rewritten
only when all six bodies are made.
"""
from __future__ import annotations

import argparse
import re
from pathlib import Path

from ffrf_advisor.analysis import Options, analyze
from ffrf_advisor.guidelines import Situation
from ffrf_advisor.io import write_body
from ffrf_advisor.report.figures import body_picture
from ffrf_advisor.samples import SAMPLES, sample

ROOT = Path(__file__).resolve().parent.parent
N_CONVERGENCE = 6  # frequencies shown per body


def convergence_row(name: str, coarse, fine) -> str:
    f1, f2 = coarse.frequencies_hz[:N_CONVERGENCE], fine.frequencies_hz[:N_CONVERGENCE]
    change = max(abs(f1 / f2 - 1))
    return (f"| {name} | {coarse.fe.mesh.n_nodes} / {fine.fe.mesh.n_nodes} | "
            + " ".join(f"{a:.4g}" for a in f1) + " | " + " ".join(f"{b:.4g}" for b in f2)
            + f" | {change:.2%} |")


def advice_row(body) -> str:
    """Level and the numbers that decided it at the moderate speed of docs/samples.md (1 rad/s, free)."""
    a = analyze(body, Options(situation=Situation(w_op=1.0)))
    sig, amp = a.significance, a.amplitudes
    fired = [f"{r.name} {r.value:.3g}" for r in a.advice.rules if r.rule == "III" and r.fired]
    return (f"| {body.name} | {body.frequencies_hz[0]:.4g} | {body.sigma_max[0]:.4g} | {amp.q_max[0]:.3g} | "
            + " ".join(f"{x:.2g}" for x in sig.dI_L.max(axis=1)) + " | "
            + " ".join(f"{x:.2g}" for x in sig.dI_Q.max(axis=1)) + f" | {a.advice.level} | "
            + (", ".join(fired) or "-") + " |")


def write_block(marker: str, header: str, rows: list[str]) -> None:
    """Replace the table between <!-- marker:start --> and <!-- marker:end --> of docs/samples.md."""
    doc = ROOT / "docs" / "samples.md"
    text = re.sub(rf"(<!-- {marker}:start -->\n).*?(\n?<!-- {marker}:end -->)",
                  lambda m: m.group(1) + header + "\n".join(rows) + "\n" + m.group(2).lstrip("\n"),
                  doc.read_text(), flags=re.S)
    doc.write_text(text)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("names", nargs="*", default=list(SAMPLES))
    parser.add_argument("--docs", action="store_true", help="also pictures and the advice table")
    parser.add_argument("--convergence", action="store_true", help="also the refine-2 convergence table (slow)")
    args = parser.parse_args()
    rows, advice = [], []
    for name in args.names:
        body = sample(name)
        path = ROOT / "sample_bodies" / f"{name}.ffrf.h5"
        write_body(body, path, overwrite=True)
        print(f"wrote {path} ({path.stat().st_size / 1e6:.2f} MB)", flush=True)
        if args.docs:
            body_picture(body, ROOT / "docs" / "samples" / f"{name}.png")
            advice.append(advice_row(body))
        if args.convergence:
            rows.append(convergence_row(name, body, sample(name, refine=2)))
            print(rows[-1], flush=True)
    complete = set(args.names) == set(SAMPLES)
    if args.convergence and complete:
        write_block("convergence", "| body | nodes (refine 1 / 2) | f1..f6 [Hz], refine 1 | f1..f6 [Hz], refine 2 "
                    "| largest change |\n|---|---|---|---|---|\n", rows)
    if args.docs and complete:
        write_block("advice", "| body | f1 [Hz] | sigma_1 [N/mm²] at q=1 | q_max,1 | dI_L axes 1 2 3 | "
                    "dI_Q axes 1 2 3 | level | rule III measures over threshold |\n"
                    "|---|---|---|---|---|---|---|---|\n", advice)


if __name__ == "__main__":
    main()
