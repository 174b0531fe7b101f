"""Rebuild the sample bodies and compare them with shipped files: python scripts/check_reproducible.py [--dir D] [NAME ...].

Prints one markdown row per body (the table "Reproducibility" of
docs/samples.md): the eigenvalue accuracy of the shipped body, the largest
ratio of difference to tolerance for the eigenvalues and for the modes and
integrals, and the clusters compared as subspaces. Exits 1 when a body
fails the comparison.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ffrf_advisor.equivalence import compare_modal_bodies, eigenpair_accuracy
from ffrf_advisor.io import read_body
from ffrf_advisor.samples import SAMPLES, sample

ROOT = Path(__file__).resolve().parent.parent


def row(name: str, directory: Path) -> tuple[str, bool]:
    made = sample(name, keep_stiffness=True)
    shipped = read_body(directory / f"{name}.ffrf.h5", load_fe=True)
    result = compare_modal_bodies(made, shipped, made.fe.K)
    ratios = {f.quantity: f.difference for f in result.findings if f.tolerance == 1.0}
    eig = ratios.pop("eigenvalues / accuracy")
    ratios.pop("residual / eigenpair limit")
    accuracy = (2 * eigenpair_accuracy(made.fe.K, shipped)[0] / shipped.eigenvalues).max()
    clusters = ", ".join(f"modes {g[0] + 1}-{g[-1] + 1}" for g in result.clusters) or "none"
    text = f"| {name} | {accuracy:.1e} | {eig:.2g} | {max(ratios.values()):.2g} | {clusters} |"
    return text + ("" if result.ok else f" FAILED: {result.summary()}"), result.ok


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", default=list(SAMPLES))
    parser.add_argument("--dir", type=Path, default=ROOT / "sample_bodies", help="folder of the shipped files")
    args = parser.parse_args()
    ok = True
    for name in args.names:
        text, good = row(name, args.dir)
        print(text, flush=True)
        ok &= good
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
