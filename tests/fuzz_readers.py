"""Mutation fuzzing of one reader and the analysis after it, in a child process with a memory limit
(see tests/test_fuzz.py).

python tests/fuzz_readers.py SEED_FILE CASES RNG_SEED [reader options as JSON]
prints one JSON line: counts of outcomes and the first offending cases. Byte damage (truncation, bit
flips, random spans, hostile numbers in text and in binary) is mixed with structural damage of HDF5
files (huge declared shapes, external and soft links, long strings), long strings in JSON, and bodies
that cannot exist or whose cache disagrees with its nodal data (``mutate_physics``: negated, scaled or
NaN entries, indefinite matrices, shuffled rows). The option ``"_read": NAME`` reads the sibling NAME
of the damaged file instead (a damaged geometry deck or punch file beside an intact OP2). Outcomes:
``valid`` (read and analysed), ``one_line_error`` (the project's error), ``multi_line``,
``traceback`` and ``hang``; a case passes in the first two.
"""
from __future__ import annotations

import json
import re
import resource
import signal
import struct
import sys
import tempfile
import traceback
from pathlib import Path

import numpy as np

from ffrf_advisor.analysis import Options, analyze
from ffrf_advisor.errors import FFRFError
from ffrf_advisor.guidelines import Situation
from ffrf_advisor.io import limits, read_body

MEMORY_LIMIT = 3 * 2**30  # bytes of address space: a huge allocation fails loudly
READ_LIMIT = 512 * 2**20  # the tool's own memory limit (--max-memory) inside that
CASE_SECONDS = 60
LONG = 100_000  # characters of a long string
ANALYSIS = Options(situation=Situation(w_op=300.0, connection="free"))
NUMBER = re.compile(rb"-?\d+(\.\d+)?([eE][-+]?\d+)?")
HOSTILE = [b"1e308", b"-1", b"0", b"nan", b"99999999999", b"2147483647", b"-0.0", b"1e-320", b"3"]


BINARY_HOSTILE = [struct.pack("<f", x) for x in (np.nan, np.inf, -1.0, 0.0, 3e38, 1e-45)] + \
    [struct.pack("<d", x) for x in (np.nan, -np.inf, -1.0, 1e308, 5e-324)] + \
    [struct.pack("<i", x) for x in (-1, 0, 2**31 - 1, -2**31)]
FAILURES = ("multi_line", "traceback", "hang")


def mutate(data: bytes, rng: np.random.Generator) -> bytes:
    """One random damage: truncation, bit flips, a random span, random bytes, a hostile number in the text
    or a hostile binary number (float32, float64, int32) at an aligned offset."""
    kind = rng.integers(6)
    if kind == 5:
        value = BINARY_HOSTILE[rng.integers(len(BINARY_HOSTILE))]
        i = int(rng.integers(max(1, len(data) // 4))) * 4
        return data[:i] + value + data[i + len(value):]
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


def mutate_structure(path: Path, rng: np.random.Generator) -> None:
    """Structural damage a byte mutation rarely makes: huge declared shapes, links, long strings."""
    import h5py

    with h5py.File(path, "r+") as f:
        names = []
        f.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        name = names[rng.integers(len(names))]
        kind = rng.integers(4)
        if kind == 0:
            shape, dtype = f[name].shape, f[name].dtype
            del f[name]
            f.create_dataset(name, shape=tuple(10**int(rng.integers(6, 10)) if i == 0 else d
                                               for i, d in enumerate(shape or (1,))), dtype=dtype)
        elif kind == 1:
            del f[name]
            f[name] = h5py.ExternalLink(["/etc/passwd", "/dev/zero", "missing.h5", path.name][rng.integers(4)], "/x")
        elif kind == 2:
            del f[name]
            f[name] = h5py.SoftLink("/" + name)  # a link to itself
        else:
            f.attrs["name"] = "\x1b[2J" + "x" * LONG


def unphysical(a: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A body that cannot exist or a cache that disagrees: ``a`` negated, scaled by 1 + 10^-k, with one entry
    negated or NaN, made indefinite (a square matrix minus twice its largest entry on the diagonal), or with
    its rows shuffled."""
    b = np.array(a, dtype=float)
    kind = rng.integers(6)
    if kind == 0:
        return -b
    if kind == 1:
        return b * (1 + 10.0 ** -int(rng.integers(2, 9)))
    if kind in (2, 3) and b.size:
        b.flat[rng.integers(b.size)] = np.nan if kind == 3 else -abs(b.flat[rng.integers(b.size)]) - 1
        return b
    if kind == 4 and b.ndim >= 2 and b.shape[-1] == b.shape[-2]:
        return b - 2 * np.abs(b).max() * np.eye(b.shape[-1])
    return b[rng.permutation(len(b))] if b.ndim else -b


def mutate_physics(path: Path, rng: np.random.Generator) -> None:
    """One numeric dataset of an HDF5 file, or one number or array of a JSON file, made ``unphysical``."""
    if path.suffix == ".json":
        doc = json.loads(path.read_text())
        keys = [k for k, v in doc.items() if isinstance(v, (int, float, list)) and not isinstance(v, bool)]
        key = keys[rng.integers(len(keys))]
        doc[key] = unphysical(np.asarray(doc[key], dtype=float), rng).tolist()
        path.write_text(json.dumps(doc))  # NaN as JSON5-style NaN: the reader must refuse it
        return
    import h5py

    with h5py.File(path, "r+") as f:
        names = []
        f.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) and o.dtype.kind == "f" else None)
        name = names[rng.integers(len(names))]
        f[name][...] = unphysical(f[name][()], rng)


def mutate_json(data: bytes) -> bytes:
    """A long string where the body's name is."""
    return data.replace(b'"name": "', b'"name": "' + b"\\u001b[31m" + b"y" * LONG, 1)


def counted(done, cases: int) -> dict:
    """The counts of a harness run (a subprocess.CompletedProcess), after asserting that it ran every case and that
    none failed (a crash of the harness itself is its exit status)."""
    assert done.returncode == 0, done.stderr[-2000:]
    report = json.loads(done.stdout.strip().splitlines()[-1])
    assert all(report["counts"][k] == 0 for k in FAILURES), report
    assert sum(report["counts"].values()) == cases
    return report["counts"]


class CaseTimeout(BaseException):
    """A case over its time: not an OSError (TimeoutError is one, and readers turn those into one line)."""


def _timeout(*_):
    raise CaseTimeout("case took too long")


def damage(seed: Path, data: bytes, target: Path, rng: np.random.Generator) -> None:
    """One damaged file at ``target``: byte damage in 3 of 5 cases, else structural or physical (HDF5, JSON)."""
    draw = rng.random()
    if draw < 0.6 or seed.suffix not in (".h5", ".json"):
        target.write_bytes(mutate(data, rng))
        return
    target.write_bytes(data)
    if draw < 0.8:
        mutate_physics(target, rng)
    elif seed.suffix == ".h5":
        mutate_structure(target, rng)
    else:
        target.write_bytes(mutate_json(data))


def main(seed_file: str, cases: int, rng_seed: int, options: dict) -> dict:
    signal.signal(signal.SIGALRM, _timeout)
    seed = Path(seed_file)
    data = seed.read_bytes()
    rng = np.random.default_rng(rng_seed)
    counts = dict.fromkeys(("valid", "one_line_error", *FAILURES), 0)
    offending = []
    options = dict(options)
    read_name = options.pop("_read", seed.name)
    with tempfile.TemporaryDirectory() as d:
        target = Path(d) / seed.name  # same name: the suffix picks the reader
        for sibling in seed.parent.iterdir():  # e.g. job.inp, job.dat beside job.frd
            if sibling.stem == seed.stem and sibling != seed and sibling.is_file():
                (Path(d) / sibling.name).write_bytes(sibling.read_bytes())
        for case in range(cases):
            damage(seed, data, target, rng)
            signal.alarm(CASE_SECONDS)
            try:
                analyze(read_body(target.with_name(read_name), **options), ANALYSIS)
                counts["valid"] += 1
            except FFRFError as e:
                kind = "multi_line" if "\n" in str(e) else "one_line_error"
                counts[kind] += 1
                if kind == "multi_line" and len(offending) < 5:
                    offending.append({"case": case, "error": "multi-line message: " + str(e)[:300]})
            except BaseException as e:  # noqa: BLE001 - exactly what the fuzz test looks for
                counts["hang" if isinstance(e, CaseTimeout) else "traceback"] += 1
                if len(offending) < 5:
                    offending.append({"case": case, "error": f"{type(e).__name__}: {str(e)[:200]}",
                                      "where": traceback.format_exc().splitlines()[-3][:200]})
            finally:
                signal.alarm(0)
    return {"counts": counts, "offending": offending}


if __name__ == "__main__":
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
    limits.set_max_bytes(READ_LIMIT)
    opts = json.loads(sys.argv[4]) if len(sys.argv) > 4 else {}
    print(json.dumps(main(sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), opts)))
