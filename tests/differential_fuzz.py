"""Differential fuzzing (issue 49, part 8): a damaged copy of a clean body file must be refused (one line), or
give the clean file's level and term set, or carry a warning the clean file lacks. Anything else is a silent
change of the advice (see tests/test_differential_fuzz.py).

Damage, one per copy, drawn with a fixed seed: truncation, a bit flipped in a number, a bit flipped in a key
(a word of a text file, a dataset or attribute name of an HDF5 file), one number times a factor from 0.25 to
100 (written in the number's own format; through h5py in HDF5, so its checksums no longer hold unless it
keeps them), and a type swap (a number replaced by a boolean, a string or a list).
"""
from __future__ import annotations

import hashlib
import pickle
import re
import signal
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ffrf_advisor.analysis import Options, analyze
from ffrf_advisor.errors import FFRFError
from ffrf_advisor.guidelines import Situation
from ffrf_advisor.io import read_body

KINDS = ("truncate", "flip_number", "flip_key", "factor", "type_swap")
FACTORS = (0.25, 0.5, 0.9, 1.1, 2.0, 10.0, 100.0)
NUMBER = re.compile(rb"(?<![\w.+-])[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?(?![\w.])")
WORD = re.compile(rb"[A-Za-z_][A-Za-z_]+")
SWAPS = {"json": (b"true", b"false", b'"1"', b"null", b"[1]", b"{}"), "text": (b"true", b"abc", b"1.2.3")}
MASKED = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?")  # numbers in a warning: its kind is the rest
# the numbers the advice hangs on, by suffix: half the number damage goes there (the rest anywhere)
KEY_SPANS = {
    ".fem": re.compile(rb"RECORD GROUP 9,.*?RECORD GROUP 14", re.S),  # modal mass, stiffness, mass and inertia
    ".inp": re.compile(rb"\*MATERIAL.*?\*STEP", re.S),                 # *ELASTIC, *DENSITY
    ".frd": re.compile(rb"  100C[^\n]*|-4  STRESS.*?\n -3", re.S),      # frequencies, modal stresses
    ".dat": re.compile(rb"E I G E N V A L U E   O U T P U T.*?P A R T I C I P A T I O N", re.S),
    ".vtu": re.compile(rb"<FieldData>.*?</FieldData>", re.S),           # eigenvalues, frequencies, density
    ".json": re.compile(rb'"(eigenvalues|frequencies_hz|max_von_mises|I1|I7|mass)":[^"]*'),
}
CASE_SECONDS = 60
OPTIONS = Options(situation=Situation(w_op=1000.0, connection="free"))  # the term set is 6 of 10 on the seeds
FAILURES = ("silent", "multi_line", "traceback", "hang", "stray_warning")


class CaseTimeout(BaseException):
    """A case over its time (not an OSError, which readers turn into one line)."""


def _timeout(*_):
    raise CaseTimeout("case took too long")


def _token(data: bytes, rng, pattern=NUMBER, text_only: bool = False, spans=None):
    """A random match of ``pattern`` (in printable lines only for a binary file; within ``spans`` where given and
    holding one), or None."""
    found = [m for m in pattern.finditer(data) if not text_only or _printable(data, m.start())]
    if spans is not None:
        ranges = [m.span() for m in spans.finditer(data)]
        inside = [m for m in found if any(a <= m.start() < b for a, b in ranges)]
        found = inside or found
    return found[rng.integers(len(found))] if found else None


def _printable(data: bytes, at: int) -> bool:
    start, end = data.rfind(b"\n", 0, at) + 1, data.find(b"\n", at)
    line = data[start:end if end >= 0 else len(data)]
    return all(32 <= c < 127 for c in line.rstrip(b"\r"))


def _flip(data: bytes, start: int, end: int, rng) -> bytes:
    b = bytearray(data)
    b[int(rng.integers(start, end))] ^= 1 << int(rng.integers(8))
    return bytes(b)


def scaled_token(text: bytes, factor: float) -> bytes:
    """``text`` (a number) times ``factor`` in the same format: mantissa digits and exponent letter, decimals, or
    an integer."""
    s = text.decode()
    value = float(s) * factor
    mantissa, e, _ = s.replace("e", "E").partition("E")
    decimals = len(mantissa.partition(".")[2])
    if e:
        out = f"{value:.{decimals}E}".replace("E", "e" if "e" in s else "E")
    elif "." in s:
        out = f"{value:.{decimals}f}"
    else:
        out = str(int(round(value)))
    return out.encode()


def mutate_text(data: bytes, kind: str, rng, suffix: str, binary: bool = False) -> bytes:
    """One damage of a text file with ``suffix`` (or of the text lines of a binary .frd)."""
    if kind == "truncate":
        return data[:int(rng.integers(len(data)))]
    if kind == "flip_number" and binary:  # a binary record: a bit of a byte outside the text lines
        at = int(rng.integers(len(data)))
        return data if _printable(data, at) else _flip(data, at, at + 1, rng)
    spans = KEY_SPANS.get(suffix) if kind != "flip_key" and rng.random() < 0.5 else None
    m = _token(data, rng, WORD if kind == "flip_key" else NUMBER, text_only=binary, spans=spans)
    if m is None:
        return data
    if kind in ("flip_number", "flip_key"):
        return _flip(data, m.start(), m.end(), rng)
    if kind == "factor":
        new = scaled_token(m.group(), FACTORS[rng.integers(len(FACTORS))])
    else:
        swaps = SWAPS["json" if suffix == ".json" else "text"]
        new = swaps[rng.integers(len(swaps))]
    return data[:m.start()] + new + data[m.end():]


def _numeric(f) -> list:
    """(object, attribute name or None) of every numeric dataset and attribute of an HDF5 file."""
    import h5py
    out = []

    def visit(_, obj):
        if isinstance(obj, h5py.Dataset) and obj.dtype.kind in "fiu" and obj.size:
            out.append((obj, None))
        out.extend((obj, k) for k, v in obj.attrs.items() if np.asarray(v).dtype.kind in "fiub")
    visit("", f)
    f.visititems(visit)
    return out


def mutate_h5(path: Path, data: bytes, kind: str, rng) -> None:
    """One damage of an HDF5 file at ``path`` (a copy of ``data``)."""
    import h5py
    if kind == "truncate":
        path.write_bytes(data[:int(rng.integers(len(data)))])
        return
    if kind == "flip_key":
        names = [m for m in WORD.finditer(data) if len(m.group()) > 2]
        m = names[rng.integers(len(names))]
        path.write_bytes(_flip(data, m.start(), m.end(), rng))
        return
    path.write_bytes(data)
    with h5py.File(path, "r+") as f:
        targets = _numeric(f)
        obj, attr = targets[rng.integers(len(targets))]
        if kind == "flip_number":
            spans = _stored_spans(f)
            start, size = spans[rng.integers(len(spans))]
            flip_at = (start, start + size)
        elif attr is None:
            _dataset_edit(f, obj, kind, rng)
        else:
            _attribute_edit(obj, attr, kind, rng)
    if kind == "flip_number":
        path.write_bytes(_flip(path.read_bytes(), *flip_at, rng))


def _stored_spans(f) -> list[tuple[int, int]]:
    """(byte offset, size) of every numeric dataset's stored data (contiguous or its first chunk)."""
    import h5py
    spans = []

    def visit(_, obj):
        if isinstance(obj, h5py.Dataset) and obj.dtype.kind in "fiu" and obj.size:
            if obj.chunks is None:
                at = obj.id.get_offset()
                spans.extend([(at, obj.id.get_storage_size())] if at is not None else [])
            else:
                info = obj.id.get_chunk_info(0)
                spans.append((info.byte_offset, info.size))
    f.visititems(visit)
    return [s for s in spans if s[1] > 0]


def _dataset_edit(f, obj, kind: str, rng) -> None:
    import h5py
    name = obj.name
    if kind == "factor":
        a = obj[()]
        flat = a.reshape(-1)
        k = int(rng.integers(flat.size))
        flat[k] = flat[k] * FACTORS[rng.integers(len(FACTORS))]
        obj[...] = a
    else:  # a type swap: strings where the numbers were
        shape = obj.shape
        del f[name]
        f.create_dataset(name, data=np.full(shape or (), "1", dtype=object), dtype=h5py.string_dtype())


def _attribute_edit(obj, attr: str, kind: str, rng) -> None:
    value = np.asarray(obj.attrs[attr])
    if kind == "factor" and value.dtype.kind != "b":
        flat = value.astype(float).reshape(-1)
        k = int(rng.integers(flat.size))
        flat[k] *= FACTORS[rng.integers(len(FACTORS))]
        obj.attrs[attr] = flat.reshape(value.shape).astype(value.dtype) if value.dtype.kind == "f" else flat
    else:
        obj.attrs[attr] = [True, "1", np.array([1.0, 2.0])][rng.integers(3)]


@dataclass(frozen=True)
class Clean:
    """What the clean file gives: level, term set and the kinds of its warnings."""

    level: str
    terms: frozenset
    warnings: frozenset


def kinds(warnings) -> frozenset:
    """Warnings with their numbers masked: a damaged number changes a warning's numbers, not its kind."""
    return frozenset(MASKED.sub("#", w) for w in warnings)


def advice_of(path: Path, options: dict, memo: dict) -> Clean:
    """Read as `analyze` does (the nodal summary only) and analyse; the analysis of a body read before is
    reused (it depends on the body alone)."""
    body = read_body(path, load_fe="summary", **options)
    key = hashlib.sha256(pickle.dumps(body)).hexdigest()
    if key not in memo:
        advice = analyze(body, OPTIONS).advice
        memo[key] = Clean(advice.level, frozenset(advice.terms), kinds(advice.warnings))
    return memo[key]


@dataclass
class Tally:
    """Outcomes counted by damage kind, and the first few offending cases."""

    counts: dict = field(default_factory=dict)
    failed: list = field(default_factory=list)  # (case, description) of every case in FAILURES

    def add(self, kind: str, outcome: str, what: str, case: int) -> None:
        self.counts.setdefault(outcome, {}).setdefault(kind, 0)
        self.counts[outcome][kind] += 1
        if outcome in FAILURES:
            self.failed.append((case, f"{outcome} ({kind}): {what}"))

    def total(self, outcome: str) -> int:
        return sum(self.counts.get(outcome, {}).values())


def classify(path: Path, options: dict, clean: Clean, memo: dict) -> tuple[str, str]:
    """The outcome of one damaged file: refused, same, warned; or silent, multi_line, traceback, hang, and
    stray_warning (a Python warning: lines on the CLI's stderr beside its one-line error or its advice)."""
    with warnings.catch_warnings(record=True) as stray:
        warnings.simplefilter("always")
        outcome = _outcome(path, options, clean, memo)
    if stray:
        w = stray[0]
        return "stray_warning", f"{w.category.__name__}: {w.message} ({w.filename}:{w.lineno}); then {outcome}"
    return outcome


def _outcome(path: Path, options: dict, clean: Clean, memo: dict) -> tuple[str, str]:
    signal.signal(signal.SIGALRM, _timeout)
    signal.alarm(CASE_SECONDS)
    try:
        got = advice_of(path, options, memo)
    except FFRFError as e:
        return ("multi_line" if "\n" in str(e) else "refused"), str(e)[:300]
    except BaseException as e:  # noqa: BLE001 - what the fuzzer looks for
        return ("hang" if isinstance(e, CaseTimeout) else "traceback"), f"{type(e).__name__}: {str(e)[:200]}"
    finally:
        signal.alarm(0)
    if (got.level, got.terms) == (clean.level, clean.terms):
        return "same", ""
    if got.warnings - clean.warnings:
        return "warned", "; ".join(sorted(got.warnings - clean.warnings))[:300]
    return "silent", (f"level {clean.level} -> {got.level}, terms {sorted(clean.terms)} -> {sorted(got.terms)}")
