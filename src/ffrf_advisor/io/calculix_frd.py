"""The CalculiX ``.frd`` results file (ASCII or binary): nodes, elements, result blocks per mode."""
from __future__ import annotations

import os
import struct
from typing import NamedTuple

import numpy as np

from ..errors import BodyFileError
from .limits import Budget

MAX_COUNT = 10**8  # sanity bound on block sizes from headers
LINE_MAX = 4096  # characters of one text line (frd records are under 100)
ELEMENT_BYTES = 20 * 36  # memory of one parsed element (a list of up to 20 Python ints)
ASCII_DIGITS = 6     # E12.5 columns: 6 significant digits
FLOAT32_DIGITS = 7   # binary result blocks are float32


class FrdType(NamedTuple):
    """A .frd element type: meshio name, the .frd position of each VTK node, CalculiX's element names."""

    meshio: str
    order: list[int]
    names: str


_HE20 = list(range(12)) + list(range(16, 20)) + list(range(12, 16))  # .frd: corners, bottom, vertical, top edges
_PE15 = list(range(9)) + list(range(12, 15)) + list(range(9, 12))    # the same layers for the wedge
FRD_TYPES = {
    1: FrdType("hexahedron", list(range(8)), "C3D8, C3D8R, C3D8I"),
    2: FrdType("wedge", list(range(6)), "C3D6"),
    3: FrdType("tetra", list(range(4)), "C3D4"),
    4: FrdType("hexahedron20", _HE20, "C3D20, C3D20R (also shells and beams expanded by CalculiX)"),
    5: FrdType("wedge15", _PE15, "C3D15"),
    6: FrdType("tetra10", list(range(10)), "C3D10"),
    7: FrdType("triangle", list(range(3)), "S3, M3D3, CPS3, CPE3, CAX3"),
    8: FrdType("triangle6", list(range(6)), "S6, M3D6, CPS6, CPE6, CAX6"),
    9: FrdType("quad", list(range(4)), "S4, S4R, M3D4, CPS4, CPE4, CAX4"),
    10: FrdType("quad8", list(range(8)), "S8, S8R, M3D8, CPS8, CPE8, CAX8"),
    11: FrdType("line", list(range(2)), "B31, B31R, T3D2"),
    12: FrdType("line3", [0, 2, 1], "B32, B32R, T3D3"),  # .frd: end, middle, end; VTK: ends, then middle
}
SOLIDS = {t.meshio for k, t in FRD_TYPES.items() if k <= 6}
NAMES = {t.meshio: t.names for t in FRD_TYPES.values()}


class Frd:
    """A parsed .frd: node ids and coordinates, elements, and result blocks per mode."""

    def __init__(self, path):
        self.path, self.budget = path, Budget(path)
        self.nodes: np.ndarray | None = None
        self.ids: np.ndarray | None = None
        self.elements: dict[str, list] = {}  # meshio name -> VTK-ordered node ids per element
        self.numbers: dict[str, list] = {}  # meshio name -> element numbers
        self.results: dict[tuple[int, str], np.ndarray] = {}
        self.frequencies: dict[int, float] = {}
        self.mode = 0
        self.digits = 17  # lowered by each result block to its precision
        with open(path, "rb") as self.fh:  # streamed: memory follows what is parsed, not the file size
            self.size = os.fstat(self.fh.fileno()).st_size
            self._parse()

    def fail(self, field: str, expected: str, got: str | None = None):
        raise BodyFileError(self.path, field, expected, got)

    def _left(self) -> int:
        return self.size - self.fh.tell()

    def _line(self) -> str:
        raw = self.fh.readline(LINE_MAX + 1)
        if len(raw) > LINE_MAX:
            self.fail("frd", f"text lines of at most {LINE_MAX} characters", "a longer line")
        return raw.rstrip(b"\r\n").decode("latin-1")

    def _peek(self, n: int) -> bytes:
        at = self.fh.tell()
        head = self.fh.read(n)
        self.fh.seek(at)
        return head

    def _take(self, n: int) -> bytes:
        if n < 0 or n > self._left():
            self.fail("frd", "a complete binary block", "truncated file")
        self.budget.take("frd", 2 * n)  # the bytes and the arrays made of them
        return self.fh.read(n)

    def _fits(self, count: int, record_bytes: int, field: str) -> None:
        """A declared count of records of at least ``record_bytes`` each must fit in the rest of the file."""
        if count * record_bytes > self._left():
            self.fail(field, f"at most the {self._left() // record_bytes} records the rest of the file can hold",
                      f"{count} declared (truncated file)")

    def _parse(self) -> None:
        """The blocks up to the end marker ' 9999', which a complete file has (a cut file does not)."""
        while self._left() > 0:
            line = self._line()
            key = line[:6].strip()
            if key == "2C":
                self._nodes(line)
            elif key == "3C":
                self._elements(line)
            elif line.strip().startswith("1PMODE"):
                self.mode = self._int(line.split()[-1], "1PMODE")
            elif line.startswith("  100C"):
                self._result(line)
            elif key == "9999":
                return
        self.fail("frd", "the end-of-file marker ' 9999' of a complete file", "none (truncated file)")

    def _block_end(self, field: str) -> None:
        """The ' -3' that ends every ASCII block."""
        line = self._line() if self._left() > 0 else ""
        if not line.startswith(" -3"):
            self.fail(field, "the block's end marker ' -3'", repr(line[:40]) if line else "end of file (truncated)")

    def _int(self, text: str, field: str) -> int:
        try:
            return int(text)
        except ValueError:
            self.fail(field, "an integer", repr(text[:20]))

    def _header(self, line: str, field: str) -> tuple[int, int]:
        parts = line.split()
        if len(parts) < 3:
            self.fail(field, "a block header with count and format", repr(line[:40]))
        count, fmt = self._int(parts[1], field), self._int(parts[-1], field)
        if not 0 <= count <= MAX_COUNT:
            self.fail(field, f"a count up to {MAX_COUNT}", str(count))
        return count, fmt

    def _floats(self, line: str, start: int, n: int, field: str) -> list[float]:
        if len(line) < start + 12 * n:
            self.fail(field, f"{n} numbers in E12.5 columns", f"a line cut short ({line[:60]!r})")
        try:
            return [float(line[start + 12 * i:start + 12 * (i + 1)]) for i in range(n)]
        except ValueError:
            self.fail(field, f"{n} numbers in E12.5 columns", repr(line[:60]))

    def _nodes(self, header: str) -> None:
        count, fmt = self._header(header, "2C")
        if fmt >= 2:  # binary: int32 id + 3 float64 (format 3) or float32 (format 2)
            size = 8 if fmt == 3 else 4
            raw = self._take(count * (4 + 3 * size))
            rec = np.frombuffer(raw, np.dtype([("id", "<i4"), ("x", f"<f{size}", 3)]))
            self.ids, self.nodes = rec["id"].astype(np.int64), rec["x"].astype(float)
            return
        self.ids, self.nodes = self._ascii_records(fmt, 3, "2C", count)

    def _ascii_records(self, fmt: int, n: int, field: str, count: int) -> tuple[np.ndarray, np.ndarray]:
        """``count`` records ' -1 node v1 .. vn' up to ' -3' (node id in I10 for the long format 1, else I5)."""
        width = 10 if fmt == 1 else 5
        self._fits(count, 3 + width + 12 * n, field)
        self.budget.take(field, 8 * (n + 1) * count)
        ids, rows = np.zeros(count, np.int64), np.zeros((count, n))
        k, ended = 0, False
        while self._left() > 0:
            line = self._line()
            if line.startswith(" -3"):
                ended = True
                break
            if line.startswith(" -1"):
                if k == count:
                    self.fail(field, f"{count} records as the block header declares", "more")
                ids[k] = self._int(line[3:3 + width], f"{field} node id")
                rows[k] = self._floats(line, 3 + width, n, field)
                k += 1
        if k != count or not ended:
            self.fail(field, f"{count} records as the block header declares, then ' -3'",
                      f"{k} (truncated)" if k != count else "no ' -3' (truncated)")
        return ids, rows

    def _element_type(self, etype: int) -> FrdType:
        if etype not in FRD_TYPES:
            self.fail("3C element type", f"a CalculiX .frd element type 1 to {len(FRD_TYPES)}", f"type {etype}")
        return FRD_TYPES[etype]

    def _elements(self, header: str) -> None:
        count, fmt = self._header(header, "3C")
        self._fits(count, 16 + 4 * 2, "3C")  # the smallest element record: binary, 2 nodes
        self.budget.take("3C", ELEMENT_BYTES * count)
        for _ in range(count):
            if fmt >= 2:
                number, etype, _, _ = struct.unpack("<4i", self._take(16))
                kind = self._element_type(etype)
                nodes = list(struct.unpack(f"<{len(kind.order)}i", self._take(4 * len(kind.order))))
            else:
                number, kind, nodes = self._ascii_element()
            self.elements.setdefault(kind.meshio, []).append([nodes[k] for k in kind.order])
            self.numbers.setdefault(kind.meshio, []).append(number)
        if fmt < 2:
            self._block_end("3C")

    def _ascii_element(self) -> tuple[int, FrdType, list[int]]:
        """One ASCII element record ' -1 id type group material' and its ' -2' node lines."""
        head = self._line()
        if not head.startswith(" -1") or len(head.split()) < 3:
            self.fail("3C", "element records ' -1 id type group material'", repr(head[:40]))
        words = head.split()
        kind = self._element_type(self._int(words[2], "3C element type"))
        nodes = []
        while len(nodes) < len(kind.order):
            line = self._line()
            if not line.startswith(" -2"):
                self.fail("3C", "node lines ' -2 ...'", repr(line[:40]))
            nodes += [self._int(t, "3C element nodes") for t in line[3:].split()]
        return self._int(words[1], "3C element number"), kind, nodes

    def _mode_of(self, header: str) -> int:
        """The mode a result block belongs to: in a frequency step (analysis type MODAL) the header's step number,
        which the '1PMODE' line before the block must repeat (one damaged byte of either is an error, never a
        block filed under another mode); the last '1PMODE' otherwise."""
        if header[63:73].strip() != "MODAL":
            return self.mode
        step = self._int(header[58:63], "100C mode number")
        if self.mode != step:
            self.fail("1PMODE", f"the line '1PMODE {step}' before the result block of mode {step} (its 100C header)",
                      f"mode {self.mode}" if self.mode else "none")
        self.mode = 0  # each block of a frequency step has its own '1PMODE' line
        return step

    def _result(self, header: str) -> None:
        try:
            frequency = float(header[12:24])
            count = int(header[24:36])
        except ValueError:
            self.fail("100C", "a result header with value and node count", repr(header[:40]))
        mode = self._mode_of(header)
        fmt = self._int(header.split()[-1], "100C format")
        if not 0 <= count <= MAX_COUNT:
            self.fail("100C", f"a node count up to {MAX_COUNT}", str(count))
        words = self._line().split()
        name = words[1] if len(words) > 1 else ""
        ncomp = 0
        while self._peek(3) == b" -5":
            ncomp += "ALL" not in self._line()
        if fmt >= 2:
            rec = np.frombuffer(self._take(count * (4 + 4 * ncomp)), np.dtype([("id", "<i4"), ("v", "<f4", ncomp)]))
            with np.errstate(invalid="ignore"):  # a NaN among float32 values: refused below, not warned of
                ids, values = rec["id"].astype(np.int64), rec["v"].astype(float)
            self.digits = min(self.digits, FLOAT32_DIGITS)
        else:
            ids, values = self._ascii_records(fmt, ncomp, name or "100C", count)
            self.digits = min(self.digits, ASCII_DIGITS)
        if not np.all(np.isfinite(values)):
            self.fail(name or "100C", "finite values", "NaN or infinity")
        if (mode, name) in self.results or self.frequencies.get(mode, frequency) != frequency:
            self.fail("100C", f"one {name} block of mode {mode}, every block of a mode with the same frequency",
                      f"a second {name} block or another frequency ({frequency:.7g})")
        self.frequencies[mode] = frequency
        self.results[(mode, name)] = (ids, values)
