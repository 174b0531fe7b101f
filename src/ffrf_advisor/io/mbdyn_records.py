"""The record groups of an MBDyn modal FEM file (``.fem``, io.mbdyn), parsed and checked.

The layout follows MBDyn's own reader (``ReadModal`` in ``mbdyn/struct/modal.cc``): a line that starts with
``** RECORD GROUP k`` opens group k, ``** END OF FILE`` ends the file, every other line outside the groups'
data is a comment. Group 1 comes first and holds ``REV NNODES NNORMAL NATTACHED NCONSTRAINT NREJECTED``
(REV is ignored, as MBDyn ignores it); the modes are NNORMAL + NATTACHED + NCONSTRAINT - NREJECTED, the
rejected ones come first in group 8. Within a group the numbers are free-format; here every group must hold
exactly the count the header declares (MBDyn would read a shifted file silently), and lines starting with
``**`` inside a group are comments (the mode headers of group 8).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from ..errors import BodyFileError
from ..units import Units, UnitsError
from . import LARGEST
from .limits import Budget, check_file_size

NAMES = {1: "header", 2: "FE node list", 3: "initial modal displacements", 4: "initial modal velocities",
         5: "nodal X coordinates", 6: "nodal Y coordinates", 7: "nodal Z coordinates", 8: "mode shapes",
         9: "modal mass matrix", 10: "modal stiffness matrix", 11: "diagonal of the lumped mass matrix",
         12: "global inertia", 13: "modal damping matrix", 14: "invariant 3", 15: "invariant 4",
         16: "invariant 8", 17: "invariant 5", 18: "invariant 9", 19: "modal stress stiffening matrices"}
REQUIRED = (1, 2, 5, 6, 7, 8, 9, 10)  # as MBDyn's reader requires them
# Record groups 14-18: the Adams-style invariant (adams.to_adams, MBDyn's I8 sign) each holds, and the axes that
# turn the file's layout (3 rows; in each, mode j, then mode k, then the column) into that array's.
INVARIANT_GROUPS = {14: ("I3", (0, 1)), 15: ("I4", (0, 1)), 16: ("I8", (1, 0, 2)), 17: ("I5", (1, 0, 2)),
                    18: ("I9", (1, 2, 0, 3))}
HEADER, END = "** RECORD GROUP ", "** END OF FILE"
NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")  # what C++ reads as a double, no inf/nan
COUNT = re.compile(r"\+?\d{1,15}")
TAG = re.compile(r"\*\*\s*ffrf-advisor:\s*units\s+(\S+),\s*mass matrix\s+(consistent|lumped|unknown)\s*$")
TEXT_FACTOR = 10  # bytes held per byte of file (text, lines, the largest group's tokens): 8 measured on the beam


@dataclass(frozen=True)
class Counts:
    nodes: int
    modes: int  # available: normal + attachment + constraint - rejected
    rejected: int


def field(g: int) -> str:
    return f"record group {g} ({NAMES[g]})"


@dataclass(frozen=True)
class Records:
    """A parsed file: the counts of group 1, the numbers of every other group present (shaped; not 2, the
    labels), and the units and mass-matrix kind the writer's tag line states (None without one)."""

    path: str
    counts: Counts
    groups: dict[int, np.ndarray]
    units: Units | None
    mass_kind: str | None

    def fail(self, g: int, expected: str, got: str | None = None):
        raise BodyFileError(self.path, field(g), expected, got)

    @property
    def points(self) -> np.ndarray:
        return np.column_stack([self.groups[g] for g in (5, 6, 7)])

    def modes(self) -> tuple[np.ndarray, np.ndarray]:
        """Translations and rotations of the available modes at the nodes, each (n, 3, nf)."""
        shapes = self.groups[8][self.counts.rejected:]
        return shapes[:, :, :3].transpose(1, 2, 0), shapes[:, :, 3:].transpose(1, 2, 0)

    def invariant(self, g: int) -> np.ndarray:
        """Record group 14-18 as its Adams-style array (``INVARIANT_GROUPS``)."""
        return self.groups[g].transpose(INVARIANT_GROUPS[g][1])


def file_rows(g: int, a: np.ndarray) -> np.ndarray:
    """An Adams-style invariant as the 3 rows of record group ``g`` (the inverse of ``Records.invariant``)."""
    return a.transpose(np.argsort(INVARIANT_GROUPS[g][1])).reshape(3, -1)


def parse(path) -> Records:
    """The record groups of ``path``; one-line BodyFileError naming the group and what was expected."""
    check_file_size(path, TEXT_FACTOR)
    with open(path, "rb") as fh:
        lines = fh.read().decode("latin-1").split("\n")  # any byte decodes: a stray one is a bad token
    spans = _spans(path, lines)

    def tokens(g: int) -> list[str]:  # one group's at a time: the largest group bounds the memory
        a, b = spans[g]
        return " ".join(s for s in lines[a:b] if not s.lstrip().startswith("**")).split()

    counts = _counts(path, tokens(1))
    last = max(spans, key=lambda g: spans[g][0])
    shapes = _shapes(counts)
    groups = {g: _numbers(path, g, tokens(g), shapes[g], g == last) for g in spans if g in shapes}
    if 19 in spans:
        groups[19] = _stress_stiffening(path, tokens(19), counts.modes, last == 19)
    missing = [g for g in REQUIRED if g not in spans]
    if missing:
        raise BodyFileError(path, field(missing[0]), "present (MBDyn requires groups 1, 2, 5-10)", "missing")
    labels = len(tokens(2))
    if labels != counts.nodes:
        raise BodyFileError(path, field(2), f"{counts.nodes} node labels", str(labels))
    units, kind = _tag(path, lines[:spans[1][0]])
    return Records(str(path), counts, groups, units, kind)


def _spans(path, lines: list[str]) -> dict[int, tuple[int, int]]:
    """Line ranges [a, b) of each group's data, in MBDyn's rules: group 1 first, each group once, 1 to 19."""
    starts: list[tuple[int, int]] = []
    end = len(lines)
    for i, line in enumerate(lines):
        if line.startswith(END):
            end = i
            break
        if not line.startswith(HEADER):
            continue
        m = re.match(r"\s*([+-]?\d{1,9})", line[len(HEADER):])
        g = int(m.group(1)) if m else None
        where = f"line {i + 1}"
        if g not in NAMES:
            raise BodyFileError(path, where, "a record group number from 1 to 19", repr(line[:60]))
        if not starts and g != 1:
            raise BodyFileError(path, where, "record group 1 (the header) before any other", f"record group {g}")
        if any(g == s for s, _ in starts):
            raise BodyFileError(path, where, f"{field(g)} once", "a second one")
        starts.append((g, i))
    if not starts:
        raise BodyFileError(path, field(1), "a line '** RECORD GROUP 1' (an MBDyn modal FEM file)", "none")
    bounds = [i for _, i in starts[1:]] + [end]
    return {g: (i + 1, b) for (g, i), b in zip(starts, bounds)}


def _counts(path, tokens: list[str]) -> Counts:
    """REV and five counts (group 1), checked against the memory limit before anything is allocated."""
    if len(tokens) != 6:
        raise BodyFileError(path, field(1), "REV and 5 counts (nodes, normal, attachment, constraint, rejected "
                            "modes)", f"{len(tokens)} values")
    bad = [t for t in tokens[1:] if not COUNT.fullmatch(t)]
    if bad:
        raise BodyFileError(path, field(1), "whole non-negative counts", repr(bad[0][:40]))
    n, normal, attached, constraint, rejected = (int(t) for t in tokens[1:])
    counts = Counts(n, normal + attached + constraint - rejected, rejected)
    if n < 1 or counts.modes < 1:
        raise BodyFileError(path, field(1), "at least one node and one mode (normal + attachment + constraint - "
                            "rejected)", f"{n} nodes, {counts.modes} modes")
    nf, modes = counts.modes, counts.modes + rejected
    Budget(path).take(field(1), 8.0 * (15 * n + 6 * n * modes + 15 * nf * nf + 17 * nf + 13))
    return counts


def _shapes(c: Counts) -> dict[int, tuple[int, ...]]:
    n, nf = c.nodes, c.modes
    return {3: (nf,), 4: (nf,), 5: (n,), 6: (n,), 7: (n,), 8: (c.rejected + nf, n, 6), 9: (nf, nf),
            10: (nf, nf), 11: (n, 6), 12: (13,), 13: (nf, nf), 14: (3, nf), 15: (3, nf), 16: (3, nf, 3),
            17: (3, nf, nf), 18: (3, nf, nf, 3)}


def _numbers(path, g: int, tokens: list[str], shape: tuple[int, ...], last: bool = False) -> np.ndarray:
    """Exactly prod(shape) finite numbers, row-major as MBDyn reads them (``last``: the file's last group)."""
    count = math.prod(shape)
    if len(tokens) != count:
        dims = " x ".join(map(str, shape)) + " " if len(shape) > 1 else ""
        early = ": the file ends within it (truncated?)" if last and len(tokens) < count else ""
        raise BodyFileError(path, field(g), f"{count} numbers ({dims}from the counts of record group 1)",
                            f"{len(tokens)}{early}")
    if not all(map(NUMBER.fullmatch, tokens)):
        k = next(i for i, t in enumerate(tokens) if not NUMBER.fullmatch(t))
        raise BodyFileError(path, field(g), "numbers", f"{tokens[k][:40]!r} (value {k + 1})")
    a = np.array(tokens, dtype=float).reshape(shape)
    if not np.all(np.abs(a) < LARGEST):  # products of two stay finite (io.in_range)
        raise BodyFileError(path, field(g), f"numbers below {LARGEST:.0e} in magnitude", f"{np.abs(a).max():.3g}")
    return a


def _stress_stiffening(path, tokens: list[str], nf: int, last: bool) -> np.ndarray:
    """Group 19 (not used by the advisor): a count, then per matrix an index and nf x nf numbers."""
    if not tokens or not COUNT.fullmatch(tokens[0]):
        raise BodyFileError(path, field(19), "the number of matrices first", repr(tokens[0][:40]) if tokens else "none")
    return _numbers(path, 19, tokens[1:], (int(tokens[0]) * (1 + nf * nf),), last)


def _tag(path, comments: list[str]) -> tuple[Units | None, str | None]:
    """Units and mass-matrix kind from the tag line this project's writer puts before record group 1."""
    for line in comments:
        m = TAG.match(line)
        if m:
            try:
                return Units.parse(m.group(1)), m.group(2)
            except UnitsError as e:
                raise BodyFileError(path, "comment 'ffrf-advisor: units'", "a consistent unit system", str(e))
    return None, None
