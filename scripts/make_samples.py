"""Regenerate the shipped sample bodies bit-for-bit: python scripts/make_samples.py [NAME ...]."""
from __future__ import annotations

import sys
from pathlib import Path

from ffrf_advisor.io import write_body
from ffrf_advisor.samples import SAMPLES

OUT = Path(__file__).resolve().parent.parent / "sample_bodies"


def main(names: list[str]) -> None:
    for name in names or list(SAMPLES):
        path = OUT / f"{name}.ffrf.h5"
        write_body(SAMPLES[name](), path, overwrite=True)
        print(f"wrote {path} ({path.stat().st_size / 1e6:.2f} MB)")


if __name__ == "__main__":
    main(sys.argv[1:])
