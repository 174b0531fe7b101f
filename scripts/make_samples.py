"""Regenerate the shipped sample bodies: python scripts/make_samples.py [--docs] [--convergence] [NAME ...].

Writes sample_bodies/NAME.ffrf.h5 (bit-for-bit reproducible on one
machine). With --docs also renders docs/samples/NAME.png and then rewrites
every block of the docs that quotes the tool's output from the shipped
files (scripts/make_docs.py, which runs alone in seconds); with
--convergence the mesh-convergence table (first frequencies at refine 1
and 2, slow), rewritten only when all six bodies are made.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ffrf_advisor.io import write_body
from ffrf_advisor.report.figures import body_picture
from ffrf_advisor.samples import SAMPLES, sample

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))
import make_docs  # noqa: E402  (scripts/make_docs.py)

N_CONVERGENCE = 6  # frequencies shown per body


def convergence_row(name: str, coarse, fine) -> str:
    f1, f2 = coarse.frequencies_hz[:N_CONVERGENCE], fine.frequencies_hz[:N_CONVERGENCE]
    change = max(abs(f1 / f2 - 1))
    return (f"| {name} | {coarse.fe.mesh.n_nodes} / {fine.fe.mesh.n_nodes} | "
            + " ".join(f"{a:.4g}" for a in f1) + " | " + " ".join(f"{b:.4g}" for b in f2)
            + f" | {change:.2%} |")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("names", nargs="*", default=list(SAMPLES))
    parser.add_argument("--docs", action="store_true", help="also pictures and the docs' tool output (make_docs.py)")
    parser.add_argument("--convergence", action="store_true", help="also the refine-2 convergence table (slow)")
    args = parser.parse_args()
    rows = []
    for name in args.names:
        body = sample(name)
        path = ROOT / "sample_bodies" / f"{name}.ffrf.h5"
        write_body(body, path, overwrite=True)
        print(f"wrote {path} ({path.stat().st_size / 1e6:.2f} MB)", flush=True)
        if args.docs:
            body_picture(body, ROOT / "docs" / "samples" / f"{name}.png")
        if args.convergence:
            rows.append(convergence_row(name, body, sample(name, refine=2)))
            print(rows[-1], flush=True)
    complete = set(args.names) == set(SAMPLES)
    if args.convergence and complete:
        make_docs.write_block(make_docs.SAMPLES_MD, "convergence",
                              "| body | nodes (refine 1 / 2) | f1..f6 [Hz], refine 1 | f1..f6 [Hz], refine 2 "
                              "| largest change |\n|---|---|---|---|---|\n" + "\n".join(rows) + "\n")
    if args.docs:
        make_docs.main([])


if __name__ == "__main__":
    main()
