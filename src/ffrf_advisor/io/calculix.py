"""CalculiX frequency-step results: ``job.frd`` (+ ``job.dat``, ``job.inp``, ``job.mas/.sti/.dof``).

Read from the .frd (ASCII or binary node/element output): nodes, solid
elements, mode shapes (DISP) and nodal stresses (STRESS) per mode.
Eigenvalues come from the .dat table (7 digits) when it is beside the
.frd, else from the frequencies of the .frd (6 digits). The mass matrix is
the one CalculiX stored with ``*FREQUENCY, SOLVER=MATRIXSTORAGE`` (.mas,
.dof) when present, else the consistent mass assembled from the mesh and
the ``*DENSITY`` of the deck (.inp); the stiffness K from .sti when
present. Rigid modes (near-zero eigenvalues)
are dropped; a count other than six is reported in the provenance notes.
"""
from __future__ import annotations

import os
import struct
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from ..body import FlexibleBody, Provenance
from ..errors import BodyFileError
from ..fe.assembly import full_mass, mass_matrix
from ..fe_body import fe_body, mass_normalised_file_modes, with_centrifugal_response
from ..fe.material import Material
from ..fe.mesh import Mesh
from ..fe.stress import von_mises
from .limits import Budget, check_file_size

# frd element type -> (meshio type, frd position of each VTK/deck node)
ELEMENTS = {1: ("hexahedron", list(range(8))),
            4: ("hexahedron20", list(range(12)) + list(range(16, 20)) + list(range(12, 16)))}
RIGID_TOL = 1e-6  # |lambda| / largest |lambda| below which a mode is rigid
N_RIGID = 6
MAX_COUNT = 10**8  # sanity bound on block sizes from headers
LINE_MAX = 4096  # characters of one text line (frd records are under 100)
ELEMENT_BYTES = 20 * 36  # memory of one parsed element (a list of up to 20 Python ints)
ASCII_DIGITS = 6     # E12.5 columns: 6 significant digits
FLOAT32_DIGITS = 7   # binary result blocks are float32


class _Frd:
    """A parsed .frd: node ids and coordinates, elements, and result blocks per mode."""

    def __init__(self, path):
        self.path, self.budget = path, Budget(path)
        self.nodes: np.ndarray | None = None
        self.ids: np.ndarray | None = None
        self.elements: dict[str, list] = {}
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

    def _element_type(self, etype: int) -> tuple[str, list[int]]:
        if etype not in ELEMENTS:
            self.fail("3C element type", "8- or 20-node hexahedra (frd types 1, 4)", f"type {etype}")
        return ELEMENTS[etype]

    def _elements(self, header: str) -> None:
        count, fmt = self._header(header, "3C")
        self._fits(count, 16 + 4 * 8, "3C")  # the smallest element record: binary, 8 nodes
        self.budget.take("3C", ELEMENT_BYTES * count)
        for _ in range(count):
            if fmt >= 2:
                _, etype, _, _ = struct.unpack("<4i", self._take(16))
                cell_type, order = self._element_type(etype)
                nodes = list(struct.unpack(f"<{len(order)}i", self._take(4 * len(order))))
            else:
                head = self._line()
                if not head.startswith(" -1"):
                    self.fail("3C", "element records ' -1 id type group material'", repr(head[:40]))
                cell_type, order = self._element_type(self._int(head.split()[2], "3C element type"))
                nodes = []
                while len(nodes) < len(order):
                    line = self._line()
                    if not line.startswith(" -2"):
                        self.fail("3C", "node lines ' -2 ...'", repr(line[:40]))
                    nodes += [self._int(t, "3C element nodes") for t in line[3:].split()]
            self.elements.setdefault(cell_type, []).append([nodes[k] for k in order])
        if fmt < 2:
            self._block_end("3C")

    def _result(self, header: str) -> None:
        try:
            frequency = float(header[12:24])
            count = int(header[24:36])
        except ValueError:
            self.fail("100C", "a result header with value and node count", repr(header[:40]))
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
            ids, values = rec["id"].astype(np.int64), rec["v"].astype(float)
            self.digits = min(self.digits, FLOAT32_DIGITS)
        else:
            ids, values = self._ascii_records(fmt, ncomp, name or "100C", count)
            self.digits = min(self.digits, ASCII_DIGITS)
        if not np.all(np.isfinite(values)):
            self.fail(name or "100C", "finite values", "NaN or infinity")
        self.frequencies[self.mode] = frequency
        self.results[(self.mode, name)] = (ids, values)


def _nodal(frd: _Frd, index: dict, ids: np.ndarray, values: np.ndarray, field: str) -> np.ndarray:
    out = np.zeros((len(index), values.shape[1]))
    try:
        out[[index[i] for i in ids]] = values
    except KeyError as e:
        frd.fail(field, "results at nodes of the mesh", f"unknown node {e}")
    return out


def _tensor(v: np.ndarray) -> np.ndarray:
    """Symmetric tensors (n, 3, 3) from CalculiX components SXX SYY SZZ SXY SYZ SZX."""
    xx, yy, zz, xy, yz, zx = v[:, :6].T
    return np.stack([np.stack([xx, xy, zx], -1), np.stack([xy, yy, yz], -1), np.stack([zx, yz, zz], -1)], -2)


def _dat_eigenvalues(path: Path) -> np.ndarray | None:
    """The eigenvalue column of the .dat table 'E I G E N V A L U E   O U T P U T', or None."""
    if not path.is_file():
        return None
    lines = _text_lines(path)
    if not any("E I G E N V A L U E   O U T P U T" in line for line in lines):
        return None
    values = []
    for line in lines:
        parts = line.split()
        if values and not parts:
            break
        if len(parts) >= 2 and parts[0].isdigit():
            values.append(float(parts[1]))
    return np.array(values)


def _text_lines(path: Path):
    """The lines of a text file, streamed; a longer line than LINE_MAX comes in pieces (memory stays bounded)."""
    with open(path, "rb") as fh:
        while line := fh.readline(LINE_MAX):
            yield line.decode("latin-1").rstrip("\r\n")


def _deck_card(path: Path, keyword: str) -> list[float] | None:
    """The numbers on the data line after the first ``keyword`` card of the deck, None when absent."""
    lines = _text_lines(path)
    for line in lines:
        if line.strip().upper().startswith(keyword):
            try:
                return [float(x) for x in next(lines, "").split(",") if x.strip()] or None
            except ValueError:
                return None
    return None


def _deck_density(frd: _Frd, path: Path) -> float:
    if not path.is_file():
        frd.fail("mass", f"{path.name} (*DENSITY) or {path.with_suffix('.mas').name} beside the .frd", "missing")
    values = _deck_card(path, "*DENSITY")
    if not values:
        frd.fail(f"{path.name}: *DENSITY", "a density line after *DENSITY")
    if not (np.isfinite(values[0]) and values[0] > 0):
        raise BodyFileError(path, "*DENSITY", "a finite positive density", f"{values[0]!r}")
    return values[0]


def _deck_nodes(path: Path) -> dict[int, tuple[float, float, float]]:
    """Node id -> coordinates of the deck's *NODE cards (full precision; the ASCII .frd has 6 digits), empty
    without a deck or when its node lines do not parse."""
    if not path.is_file():
        return {}
    nodes, inside = {}, False
    for line in _text_lines(path):
        if line.startswith("**"):  # a comment
            continue
        if line.startswith("*"):
            inside = line.split(",")[0].strip().upper() == "*NODE"
            continue
        if inside and line.strip():
            try:
                values = [float(x) for x in line.split(",")[:4]]
            except ValueError:
                return {}
            if len(values) == 4:
                nodes[int(values[0])] = tuple(values[1:])
    return nodes


def _precise_points(frd: _Frd, path: Path) -> tuple[np.ndarray, str | None]:
    """The .frd's node coordinates, or the deck's where it defines every node and agrees with the .frd to the
    .frd's precision (else an error naming the deck); a note saying which."""
    deck = _deck_nodes(path)
    if not deck or any(int(n) not in deck for n in frd.ids):
        return frd.nodes, None
    points = np.array([deck[int(n)] for n in frd.ids])
    size = float(np.ptp(frd.nodes, axis=0).max()) or 1.0
    off = float(np.abs(points - frd.nodes).max())
    if off > 10.0 ** (1 - ASCII_DIGITS) * size:
        raise BodyFileError(path, "*NODE", f"the nodes of {frd.path.name} (within its precision)",
                            f"coordinates {off:.3g} away (another model's deck)")
    return points, "node coordinates from the deck's *NODE (full precision)"


def _deck_material(path: Path) -> Material | None:
    """E, nu (*ELASTIC) and rho (*DENSITY) of the deck beside the .frd (one isotropic material), or None."""
    if not path.is_file():
        return None
    elastic, density = _deck_card(path, "*ELASTIC"), _deck_card(path, "*DENSITY")
    if not elastic or len(elastic) < 2 or not density or elastic[0] <= 0 or not -1 < elastic[1] < 0.5 \
            or density[0] <= 0:
        return None
    return Material(f"{path.name} material", elastic[0], elastic[1], density[0])


def _stored_matrix(frd: _Frd, path: Path, rows: np.ndarray, n3: int) -> sp.csr_array:
    """A symmetric matrix from CalculiX 'row col value' triplets (upper triangle, 1-based DOF numbers)."""
    check_file_size(path, 2)  # text of 'i j value' lines holds more bytes than the three numbers parsed
    try:
        i, j, v = np.loadtxt(path, ndmin=2).T
        i, j = rows[i.astype(int) - 1], rows[j.astype(int) - 1]
    except (ValueError, IndexError) as e:
        frd.fail(path.name, "'row col value' triplets over the DOFs of the .dof file", str(e)[:60])
    off = i != j
    return sp.coo_array((np.r_[v, v[off]], (np.r_[i, j[off]], np.r_[j, i[off]])), shape=(n3, n3)).tocsr()


def _stored_matrices(frd: _Frd, stem: Path, index: dict) -> tuple[sp.csr_array | None, sp.csr_array | None]:
    """Scalar mass Ms (from M = kron(Ms, I3)) and stiffness K from job.mas/.sti/.dof, or None."""
    mas, sti, dof = (stem.with_suffix(s) for s in (".mas", ".sti", ".dof"))
    if not (mas.is_file() and dof.is_file()):
        return None, None
    check_file_size(dof, 16)
    try:
        rows = np.array([3 * index[int(n)] + int(c) - 1 for n, c in (l.split(".") for l in dof.read_text().split())])
    except (ValueError, KeyError) as e:
        frd.fail(dof.name, "node.dof labels of nodes in the .frd", str(e)[:60])
    n3 = 3 * len(index)
    M = _stored_matrix(frd, mas, rows, n3)
    Ms = sp.csr_array(M[0::3, 0::3])
    if abs(M - full_mass(Ms)).max() > 1e-10 * abs(Ms).max():
        frd.fail(mas.name, "a mass matrix of the form kron(Ms, I3) (solid elements)")
    return Ms, (_stored_matrix(frd, sti, rows, n3) if sti.is_file() else None)


def read(path, load_fe: bool = False) -> FlexibleBody:
    """A modal body from CalculiX frequency results (t-mm-N-s assumed)."""
    frd = _Frd(path)
    if frd.nodes is None or not frd.elements:
        frd.fail("frd", "a node block (2C) and an element block (3C)", "missing")
    index = {int(n): k for k, n in enumerate(frd.ids)}
    try:
        cells = {t: np.array([[index[n] for n in e] for e in es], np.int64) for t, es in frd.elements.items()}
    except KeyError as e:
        frd.fail("3C", "element nodes defined in the node block", f"unknown node {e}")
    stem = Path(path).with_suffix("")
    points, from_deck = _precise_points(frd, stem.with_suffix(".inp"))
    mesh = Mesh(points, cells)
    modes = sorted(m for m, name in frd.results if name == "DISP")
    if not modes:
        frd.fail("DISP", "mode shapes (*NODE FILE or *NODE OUTPUT with U)", "none")
    lam = _dat_eigenvalues(stem.with_suffix(".dat"))
    source = "eigenvalues from .dat (7 digits)"
    if lam is not None and len(lam) != max(modes):
        raise BodyFileError(stem.with_suffix(".dat"), "eigenvalues", f"as many as the modes of {Path(path).name} "
                            f"({max(modes)})", f"{len(lam)} (a cut .frd or another run's .dat)")
    if lam is None:
        lam = (2 * np.pi * np.array([frd.frequencies[m] for m in modes])) ** 2
        source = "eigenvalues from .frd frequencies (6 digits)"
    lam = lam[np.array(modes) - 1]
    Phi = np.stack([_nodal(frd, index, *frd.results[(m, "DISP")], "DISP")[:, :3] for m in modes], axis=-1)
    stress = None
    if all((m, "STRESS") in frd.results for m in modes):
        stress = np.stack([von_mises(_tensor(_nodal(frd, index, *frd.results[(m, "STRESS")], "STRESS")))
                           for m in modes], axis=-1)
    rigid = np.abs(lam) < RIGID_TOL * np.abs(lam).max()
    notes = [f"CalculiX {Path(path).name}: {len(modes)} modes, {int(rigid.sum())} rigid dropped; {source}"]
    notes += [from_deck] if from_deck else []
    if rigid.sum() != N_RIGID:
        notes.append(f"warning: {int(rigid.sum())} rigid modes instead of six: the body is "
                     + ("constrained" if rigid.sum() < N_RIGID else "not connected (a mechanism)"))
    flex = ~rigid
    if not flex.any():
        frd.fail("DISP", "at least one flexible mode", "only rigid modes")
    Ms, K = _stored_matrices(frd, stem, index)
    if Ms is None:
        Ms = mass_matrix(mesh, _deck_density(frd, stem.with_suffix(".inp")))
        notes.append("mass: consistent, assembled from the mesh and *DENSITY of the deck")
    else:
        notes.append("mass" + (" and stiffness" if K is not None else "") + ": CalculiX matrix storage (.mas/.dof"
                     + ("/.sti)" if K is not None else ")"))
    Phi_n, stress, _ = mass_normalised_file_modes(Ms, Phi[:, :, flex], None if stress is None else stress[:, flex],
                                                 mesh.points)
    material = _deck_material(stem.with_suffix(".inp"))
    if material is not None:
        notes.append("material from the deck (*ELASTIC, *DENSITY): static centrifugal response and geometric "
                     "stiffness computed (theory 9, 11)")
    body = fe_body(Path(path).name.split(".")[0], mesh, Ms, Phi_n, lam[flex],
                   Provenance(source=str(path), mass_matrix="consistent", notes=tuple(notes), digits=frd.digits),
                   K, stress, material)
    return body if material is None or rigid.sum() != N_RIGID else with_centrifugal_response(body)


# ---------------------------------------------------------------- decks
def write_deck(mesh: Mesh, material: Material, n_modes: int, path, binary: bool = False,
               matrix_storage: bool = False) -> None:
    """A free-free *FREQUENCY deck of ``mesh`` (8/20-node hexahedra; VTK order is the deck order)."""
    ccx_type = {"hexahedron": "C3D8", "hexahedron20": "C3D20"}
    out = ["*HEADING", "ffrf_advisor free-free modal deck", "*NODE, NSET=NALL"]
    out += [f"{i + 1}, " + ", ".join(f"{v:.12e}" for v in p) for i, p in enumerate(mesh.points)]  # fields <= 20
    number = 1
    for cell_type, conn in mesh.cells.items():
        if cell_type not in ccx_type:
            raise ValueError(f"no CalculiX element for {cell_type}")
        out.append(f"*ELEMENT, TYPE={ccx_type[cell_type]}, ELSET=EALL")
        for c in conn + 1:
            ids = [str(number)] + [str(n) for n in c]
            out += [", ".join(ids[i:i + 16]) + ("," if i + 16 < len(ids) else "") for i in range(0, len(ids), 16)]
            number += 1
    out += ["*MATERIAL, NAME=MAT", "*ELASTIC", f"{material.E!r}, {material.nu!r}", "*DENSITY",
            f"{material.rho!r}", "*SOLID SECTION, ELSET=EALL, MATERIAL=MAT", "*STEP",
            "*FREQUENCY" + (", SOLVER=MATRIXSTORAGE" if matrix_storage else ""), f"{n_modes + N_RIGID}"]
    if not matrix_storage:
        out += ["*NODE OUTPUT" if binary else "*NODE FILE", "U",
                "*ELEMENT OUTPUT" if binary else "*EL FILE", "S"]
    out.append("*END STEP")
    Path(path).write_text("\n".join(out) + "\n")
