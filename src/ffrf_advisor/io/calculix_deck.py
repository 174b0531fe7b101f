"""The CalculiX deck (``job.inp``) beside a ``.frd``: nodes, element names, material, point masses, spiders.

One streamed pass collects what the reader needs: ``*NODE`` coordinates (full
precision), the element name of every element number (``*ELEMENT, TYPE=``),
element and node sets, ``*MASS`` (point masses, element type MASS),
``*ROTARY INERTIA``, ``*RIGID BODY`` (NSET or ELSET, REF NODE, ROT NODE), the
first ``*ELASTIC`` and ``*DENSITY``, and whether results are written as
shell/beam mid-surfaces (``*NODE FILE, OUTPUT=2D``).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ..errors import BodyFileError
from ..fe.material import Material
from ..fe.mesh import Mesh

LINE_MAX = 4096  # characters of one text line read at once (longer lines come in pieces)
N_RIGID = 6


@dataclass
class RigidBody:
    """A ``*RIGID BODY`` card: its set, the reference node (translations) and rotation node (rotations)."""

    nset: str | None
    elset: str | None
    ref: int | None
    rot: int | None


@dataclass
class Deck:
    """What the reader takes from a deck; sets map upper-case names to numbers."""

    path: Path
    nodes: dict[int, tuple[float, float, float]] = field(default_factory=dict)
    element_names: dict[int, str] = field(default_factory=dict)
    element_nodes: dict[int, list[int]] = field(default_factory=dict)  # of MASS elements only
    elsets: dict[str, list] = field(default_factory=dict)
    nsets: dict[str, list] = field(default_factory=dict)
    masses: list[tuple[str, float]] = field(default_factory=list)      # (ELSET, mass)
    rotary: list[str] = field(default_factory=list)                    # ELSETs of *ROTARY INERTIA
    rigid: list[RigidBody] = field(default_factory=list)
    cards: dict[str, list[float]] = field(default_factory=dict)        # first data line of *DENSITY, *ELASTIC
    keywords: set[str] = field(default_factory=set)                    # every card's keyword
    elastic_type: str = "ISO"                                          # TYPE= of the first *ELASTIC
    output_2d: bool = False

    def members(self, sets: dict, name: str) -> list[int]:
        """The numbers of set ``name`` with the sets it names expanded."""
        out = []
        for item in sets.get(name.upper(), []):
            out += self.members(sets, item) if isinstance(item, str) else [item]
        return out

    def fail(self, field_: str, expected: str, got: str | None = None):
        raise BodyFileError(self.path, field_, expected, got)


def text_lines(path: Path):
    """The lines of a text file, streamed; a longer line than LINE_MAX comes in pieces (memory stays bounded)."""
    with open(path, "rb") as fh:
        while line := fh.readline(LINE_MAX):
            yield line.decode("latin-1").rstrip("\r\n")


def _keyword(line: str) -> tuple[str, dict[str, str]]:
    """'*ELEMENT, TYPE=C3D8, ELSET=E' -> ('*ELEMENT', {'TYPE': 'C3D8', 'ELSET': 'E'}), names upper case."""
    words = [w.strip() for w in line.split(",")]
    params = {}
    for w in words[1:]:
        key, _, value = w.partition("=")
        params[" ".join(key.upper().split())] = value.strip().upper()
    return " ".join(words[0].upper().split()), params


def _numbers(line: str) -> list[float]:
    return [float(x) for x in line.split(",") if x.strip()]


class _Reader:
    """The state of one pass over the deck's lines."""

    def __init__(self, deck: Deck):
        self.deck, self.key, self.params, self.pending = deck, "", {}, []

    def card(self, line: str) -> None:
        self.key, self.params = _keyword(line)
        d, p = self.deck, self.params
        if self.key == "*ELASTIC" and "*ELASTIC" not in d.keywords:
            d.elastic_type = p.get("TYPE", "ISO")
        d.keywords.add(self.key)
        if self.key == "*RIGID BODY":
            ref, rot = p.get("REF NODE"), p.get("ROT NODE")
            d.rigid.append(RigidBody(p.get("NSET"), p.get("ELSET"), int(ref) if ref else None,
                                     int(rot) if rot else None))
        elif self.key == "*ROTARY INERTIA":
            d.rotary.append(p.get("ELSET", ""))
        elif self.key in ("*NODE FILE", "*NODE OUTPUT") and p.get("OUTPUT") == "2D":
            d.output_2d = True
        for key in ("NSET", "ELSET"):  # a set named on a *NODE or *ELEMENT card collects its numbers
            if key in p and self.key in ("*NODE", "*ELEMENT", "*NSET", "*ELSET"):
                sets = d.nsets if key == "NSET" else d.elsets
                sets.setdefault(p[key], [])

    def data(self, line: str) -> None:
        d, p, key = self.deck, self.params, self.key
        if key == "*NODE":
            values = _numbers(line)
            if len(values) >= 4:
                d.nodes[int(values[0])] = tuple(values[1:4])
                if "NSET" in p:
                    d.nsets[p["NSET"]].append(int(values[0]))
        elif key == "*ELEMENT":
            self._element(line)
        elif key in ("*NSET", "*ELSET"):
            self._set(line)
        elif key == "*MASS":
            d.masses.append((p.get("ELSET", ""), _numbers(line)[0]))
            self.key = ""
        elif key in ("*DENSITY", "*ELASTIC"):
            d.cards.setdefault(key, _numbers(line))
            self.key = ""

    def _element(self, line: str) -> None:
        """Element lines; a line ending with ',' continues on the next."""
        self.pending += [w for w in line.split(",") if w.strip()]
        if line.rstrip().endswith(","):
            return
        words, self.pending = [int(w) for w in self.pending], []
        name = self.params.get("TYPE", "")
        self.deck.element_names[words[0]] = name
        if name == "MASS":
            self.deck.element_nodes[words[0]] = words[1:]
        if "ELSET" in self.params:
            self.deck.elsets[self.params["ELSET"]].append(words[0])

    def _set(self, line: str) -> None:
        sets = self.deck.nsets if self.key == "*NSET" else self.deck.elsets
        name = self.params.get(self.key[1:], "")
        words = [w.strip() for w in line.split(",") if w.strip()]
        if "GENERATE" in self.params:
            a, b, step = (int(w) for w in (words + ["1"])[:3])
            sets[name].extend(range(a, b + 1, step))
            return
        sets[name].extend(int(w) if w.lstrip("-").isdigit() else w.upper() for w in words)


def read_deck(path: Path) -> Deck | None:
    """The deck at ``path`` (None when there is none); a line that does not parse names the deck."""
    if not path.is_file():
        return None
    deck = _Reader(Deck(path))
    for number, line in enumerate(text_lines(path), 1):
        if line.startswith("**") or not line.strip():
            continue
        try:
            deck.card(line) if line.lstrip().startswith("*") else deck.data(line)
        except (ValueError, IndexError, KeyError):
            raise BodyFileError(path, f"line {number}", f"a data line of {deck.key or 'a card'}",
                                repr(line[:40])) from None
    return deck.deck


def deck_density(deck: Deck | None, frd_path: Path, stem: Path) -> float:
    """The first ``*DENSITY`` of the deck; without it the mass is missing (an error naming what was sought)."""
    if deck is None:
        raise BodyFileError(frd_path, "mass", f"{stem.with_suffix('.inp').name} (*DENSITY) or "
                            f"{stem.with_suffix('.mas').name} beside the .frd", "missing")
    values = deck.cards.get("*DENSITY")
    if not values:
        raise BodyFileError(frd_path, f"{deck.path.name}: *DENSITY", "a density line after *DENSITY")
    if not values[0] > 0 or values[0] == float("inf"):
        deck.fail("*DENSITY", "a finite positive density", f"{values[0]!r}")
    return values[0]


STIFFNESS = ("*ELASTIC", "*HYPERELASTIC", "*HYPERFOAM", "*USER MATERIAL", "*DEFORMATION PLASTICITY")


def check_stiffness(deck: Deck | None) -> None:
    """A frequency step needs a material stiffness: a deck without any of STIFFNESS (a damaged '*ELASTIC' reads as
    an unknown card, which CalculiX refuses) or with an isotropic *ELASTIC that is not E > 0, -1 < nu < 0.5 did
    not make the .frd; an error naming the card, never a body without its material."""
    if deck is None:
        return
    if not deck.keywords & set(STIFFNESS):
        deck.fail("*ELASTIC", "a material stiffness card (*ELASTIC; CalculiX's frequency step needs one)", "none")
    elastic = deck.cards.get("*ELASTIC")
    if "*ELASTIC" in deck.keywords and deck.elastic_type == "ISO" and \
            not (elastic and len(elastic) >= 2 and 0 < elastic[0] < float("inf") and -1 < elastic[1] < 0.5):
        deck.fail("*ELASTIC", "an isotropic E, nu with E > 0 and -1 < nu < 0.5", repr(elastic))


def unsupported(deck: Deck | None) -> bool:
    """Whether the deck's body is free: no *BOUNDARY card and no spring or gap element (a run without the deck
    may be anything)."""
    return deck is not None and "*BOUNDARY" not in deck.keywords and not any(
        name.startswith(("SPRING", "DASHPOT", "GAP")) for name in deck.element_names.values())


def deck_material(deck: Deck | None) -> Material | None:
    """E, nu (*ELASTIC) and rho (*DENSITY) of the deck (one isotropic material), or None."""
    if deck is None or deck.elastic_type != "ISO":
        return None
    elastic, density = deck.cards.get("*ELASTIC"), deck.cards.get("*DENSITY")
    if not elastic or len(elastic) < 2 or not density or elastic[0] <= 0 or not -1 < elastic[1] < 0.5 \
            or not density[0] > 0:
        return None
    return Material(f"{deck.path.name} material", elastic[0], elastic[1], density[0])


# ---------------------------------------------------------------- writing decks
CCX_NAMES = {"hexahedron": "C3D8", "hexahedron20": "C3D20", "tetra": "C3D4", "tetra10": "C3D10",
             "wedge": "C3D6", "wedge15": "C3D15"}  # VTK order is CalculiX's deck order for each


def _element_lines(ids: list[str]) -> list[str]:
    """One element's numbers, at most 16 a line, a trailing ',' where the element continues."""
    return [", ".join(ids[i:i + 16]) + ("," if i + 16 < len(ids) else "") for i in range(0, len(ids), 16)]


def write_deck(mesh: Mesh, material: Material, n_modes: int, path, binary: bool = False,
               matrix_storage: bool = False, extra: tuple[str, ...] = ()) -> None:
    """A free-free *FREQUENCY deck of ``mesh`` (solid elements of CCX_NAMES), ``extra`` cards before the step."""
    out = ["*HEADING", "ffrf_advisor free-free modal deck", "*NODE, NSET=NALL"]
    out += [f"{i + 1}, " + ", ".join(f"{v:.12e}" for v in p) for i, p in enumerate(mesh.points)]  # fields <= 20
    number = 1
    for cell_type, conn in mesh.cells.items():
        if cell_type not in CCX_NAMES:
            raise ValueError(f"no CalculiX element for {cell_type}")
        out.append(f"*ELEMENT, TYPE={CCX_NAMES[cell_type]}, ELSET=EALL")
        for c in conn + 1:
            out += _element_lines([str(number)] + [str(n) for n in c])
            number += 1
    out += ["*MATERIAL, NAME=MAT", "*ELASTIC", f"{material.E!r}, {material.nu!r}", "*DENSITY",
            f"{material.rho!r}", "*SOLID SECTION, ELSET=EALL, MATERIAL=MAT", *extra, "*STEP",
            "*FREQUENCY" + (", SOLVER=MATRIXSTORAGE" if matrix_storage else ""), f"{n_modes + N_RIGID}"]
    if not matrix_storage:
        out += ["*NODE OUTPUT" if binary else "*NODE FILE", "U",
                "*ELEMENT OUTPUT" if binary else "*EL FILE", "S"]
    out.append("*END STEP")
    Path(path).write_text("\n".join(out) + "\n")
