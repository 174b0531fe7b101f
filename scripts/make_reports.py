"""Regenerate the example reports in reports/: python scripts/make_reports.py

Each shipped sample body as HTML and PDF at 1 rad/s, connection free (the
settings of docs/samples.md), the beam's with its verification by
simulation (run once, passed in with --verification), and the six bodies
as one set; then
reports/README.md with the files and their sizes.
"""
from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

from ffrf_advisor.samples import SAMPLES

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "reports"
OPTIONS = ["--speed", "1rad/s", "--connection", "free"]


def report(bodies: list[str], stem: str, extra: tuple[str, ...] = ()) -> list[Path]:
    paths = []
    for suffix in (".html", ".pdf"):
        path = OUT / f"{stem}{suffix}"
        subprocess.run([sys.executable, "-m", "ffrf_advisor", "report", *bodies, *OPTIONS, *extra, "-o", str(path),
                        "--force"], cwd=ROOT, check=True)
        paths.append(path)
    return paths


def main() -> None:
    start = time.monotonic()
    OUT.mkdir(exist_ok=True)
    bodies = {name: f"sample_bodies/{name}.ffrf.h5" for name in SAMPLES}
    written = []
    with tempfile.TemporaryDirectory() as scratch:  # the beam's verification, run once for both files
        study = Path(scratch) / "beam.json"
        done = subprocess.run([sys.executable, "-m", "ffrf_advisor", "verify", bodies["beam"], *OPTIONS, "--json",
                               "-o", scratch], cwd=ROOT, check=True, capture_output=True, text=True)
        study.write_text(done.stdout)
        for name, body in bodies.items():
            written += report([body], name, ("--verification", str(study)) if name == "beam" else ())
    written += report(list(bodies.values()), "set")
    rows = "\n".join(f"| [{p.name}]({p.name}) | {p.stat().st_size / 1024:.0f} KiB |" for p in written)
    total = sum(p.stat().st_size for p in written) / 2**20
    (OUT / "README.md").write_text(
        "# Example reports\n\nMade by `python scripts/make_reports.py` (options: "
        f"`{' '.join(OPTIONS)}`; the beam's with its verification). HTML files are self-contained (open them "
        "offline); PDF files are the same content on A4 pages.\n\n| file | size |\n|---|---|\n"
        f"{rows}\n\nIn all {total:.1f} MiB.\n", encoding="utf-8")
    print(f"wrote {len(written)} reports ({total:.1f} MiB) in {time.monotonic() - start:.0f} s")


if __name__ == "__main__":
    main()
