"""What a body read whole costs the process tree (`convert`), against the bytes its file declares (io/limits.py).

For bars of growing size (tests/tree_memory.py: hexahedral mesh, lumped mass, nf smooth modes) prints the
peak RSS of the parent and of the reading child above those of the same run on a tiny bar, and

  tree ratio = (parent extra + child extra) / declared bytes     bound: limits.TREE_BYTES_PER_BYTE

`--max-memory` charges every declared byte of a whole read TREE_BYTES_PER_BYTE times, so the tree stays
within it while the ratio stays below that constant (the analysis's read of an uncached body keeps the nodal
data in the reading child, or streams them: tests/test_streaming.py).

Run: python benchmarks/bench_memory.py
"""
from __future__ import annotations

import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tests.tree_memory import synthetic_body, tree_rss  # noqa: E402

from ffrf_advisor.io.limits import TREE_BYTES_PER_BYTE  # noqa: E402

SIZES = [(10, 10), (700, 10), (1400, 20), (2800, 20)]  # (divisions along the bar, modes)
MIB = 2**20


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        rows = []
        for divisions, nf in SIZES:
            path = Path(tmp) / f"bar{divisions}_{nf}.ffrf.h5"
            declared = synthetic_body(path, divisions, nf)
            code, _, rss = tree_rss(["convert", str(path), str(path.with_name("copy.ffrf.h5")), "--force"])
            assert code == 0, f"convert failed on {path.name}"
            rows.append((divisions, nf, declared / MIB, rss["parent"], rss["child"]))
    _, _, _, parent0, child0 = rows[0]
    print(f"{'bar':>10} {'declared':>10} {'parent+':>9} {'child+':>9} {'tree ratio':>10}   (MiB; bound "
          f"{TREE_BYTES_PER_BYTE})")
    for divisions, nf, declared, parent, child in rows[1:]:
        ratio = (parent - parent0 + child - child0) / declared
        print(f"{divisions:>6}x{nf:<3} {declared:10.1f} {parent - parent0:9.1f} {child - child0:9.1f} {ratio:10.2f}")


if __name__ == "__main__":
    main()
