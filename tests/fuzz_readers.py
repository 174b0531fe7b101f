"""Mutation fuzzing of one reader, run in a child process with a memory limit (see tests/test_fuzz.py).

python tests/fuzz_readers.py SEED_FILE CASES RNG_SEED [KEY=VALUE reader options as JSON]
prints one JSON line: counts of outcomes and the first offending cases.
"""
from __future__ import annotations

import json
import re
import resource
import signal
import sys
import tempfile
import traceback
from pathlib import Path

import numpy as np

from ffrf_advisor.errors import FFRFError
from ffrf_advisor.io import read_body

MEMORY_LIMIT = 3 * 2**30  # bytes of address space: a huge allocation fails loudly
CASE_SECONDS = 60
NUMBER = re.compile(rb"-?\d+(\.\d+)?([eE][-+]?\d+)?")
HOSTILE = [b"1e308", b"-1", b"0", b"nan", b"99999999999", b"2147483647", b"-0.0", b"1e-320", b"3"]


def mutate(data: bytes, rng: np.random.Generator) -> bytes:
    """One random damage: truncation, bit flips, a random span, random bytes, or a hostile number."""
    kind = rng.integers(5)
    b = bytearray(data)
    if kind == 0:
        return bytes(b[: rng.integers(len(b))])
    if kind == 1:
        for _ in range(rng.integers(1, 9)):
            i = rng.integers(len(b))
            b[i] ^= 1 << int(rng.integers(8))
        return bytes(b)
    if kind == 2:
        i = rng.integers(len(b))
        n = int(rng.integers(1, 64))
        b[i:i + n] = rng.bytes(n)
        return bytes(b)
    if kind == 3:
        return rng.bytes(int(rng.integers(0, 2 * len(b) + 1)))
    numbers = list(NUMBER.finditer(data))
    if not numbers:
        return bytes(b)
    m = numbers[rng.integers(len(numbers))]
    return data[: m.start()] + HOSTILE[rng.integers(len(HOSTILE))] + data[m.end():]


def _timeout(*_):
    raise TimeoutError("case took too long")


def main(seed_file: str, cases: int, rng_seed: int, options: dict) -> dict:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
    signal.signal(signal.SIGALRM, _timeout)
    seed = Path(seed_file)
    data = seed.read_bytes()
    rng = np.random.default_rng(rng_seed)
    counts = {"read": 0, "ffrf_error": 0, "other": 0}
    offending = []
    with tempfile.TemporaryDirectory() as d:
        target = Path(d) / seed.name  # same name: the suffix picks the reader
        for sibling in seed.parent.iterdir():  # e.g. job.inp, job.dat beside job.frd
            if sibling.stem == seed.stem and sibling != seed and sibling.is_file():
                (Path(d) / sibling.name).write_bytes(sibling.read_bytes())
        for case in range(cases):
            target.write_bytes(mutate(data, rng))
            signal.alarm(CASE_SECONDS)
            try:
                read_body(target, **options)
                counts["read"] += 1
            except FFRFError as e:
                counts["ffrf_error"] += 1
                if "\n" in str(e):
                    counts["other"] += 1
                    offending.append({"case": case, "error": "multi-line message: " + str(e)[:300]})
            except BaseException as e:  # noqa: BLE001 - exactly what the fuzz test looks for
                counts["other"] += 1
                if len(offending) < 5:
                    offending.append({"case": case, "error": f"{type(e).__name__}: {str(e)[:200]}",
                                      "where": traceback.format_exc().splitlines()[-3][:200]})
            finally:
                signal.alarm(0)
    return {"counts": counts, "offending": offending}


if __name__ == "__main__":
    opts = json.loads(sys.argv[4]) if len(sys.argv) > 4 else {}
    print(json.dumps(main(sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), opts)))
