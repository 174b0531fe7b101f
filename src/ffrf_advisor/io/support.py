"""Which element types each reader takes, where their mass comes from, and what it refuses (docs/elements.md,
`ffrf-advisor formats`). Plain data, imported by `formats` without any reader; tests/test_support.py holds it
against the readers' own tables, so a reader that learns or drops an element changes this table too."""
from __future__ import annotations

import textwrap

READERS = ("calculix", "meshio", "nastran", "ansys")

# kind -> reader -> what the reader does with it (names in the format's own words)
ELEMENTS: dict[str, dict[str, str]] = {
    "tetrahedra (4, 10 nodes)": {
        "calculix": "C3D4, C3D10: read; mass from the .mas, or the deck with CalculiX's own rules",
        "meshio": "tetra, tetra10: read; consistent mass of the density",
        "nastran": "CTETRA (4, 10): read; consistent mass, checked against pyNastran's mass properties",
        "ansys": "SOLID187 (4, 10), SOLID185/186 tetrahedral form: read; the .full's M",
    },
    "wedges (6, 15 nodes)": {
        "calculix": "C3D6, C3D15: read; as tetrahedra",
        "meshio": "wedge, wedge15: read; consistent mass",
        "nastran": "CPENTA (6, 15): read; as CTETRA",
        "ansys": "SOLID185/186 prism form: read; the .full's M",
    },
    "pyramids (5, 13 nodes)": {
        "calculix": "none in CalculiX",
        "meshio": "pyramid, pyramid13: read; consistent mass",
        "nastran": "CPYRAM (5, 13): read; as CTETRA",
        "ansys": "SOLID185/186 pyramid form: read; the .full's M",
    },
    "hexahedra (8, 20, 27 nodes)": {
        "calculix": "C3D8, C3D20, C3D20R: read; C3D8R, C3D8I: read with a .mas only",
        "meshio": "hexahedron, hexahedron20, hexahedron27: read; consistent mass",
        "nastran": "CHEXA (8, 20): read; as CTETRA",
        "ansys": "SOLID185, SOLID186 bricks: read; the .full's M",
    },
    "shells (3, 4, 6, 8 nodes)": {
        "calculix": "S3, S6, S8, S8R: read as CalculiX's 3D expansion (.mas or deck); S4, S4R: read with a .mas "
                    "only; *NODE FILE OUTPUT=2D refused (no rotations written)",
        "meshio": "triangle, triangle6, quad, quad8, quad9 with cell data thickness: read; fibre inertia at the "
                  "nodes (theory 3b)",
        "nastran": "CQUAD4, CQUAD8, CTRIA3, CTRIA6 (and R forms): read; lumped, or Nastran's MAAX",
        "ansys": "SHELL181, SHELL281: refused by name (their mass couples translations and rotations)",
    },
    "beams (2, 3 nodes)": {
        "calculix": "B32, B32R: read as CalculiX's 3D expansion; B31, B31R: read with a .mas only",
        "meshio": "line, line3 with cell data area, I22, I33 (orientation): read; section inertia at the nodes",
        "nastran": "CBAR, CBEAM, CROD, CONROD, CTUBE: read; lumped, or Nastran's MAAX",
        "ansys": "BEAM188, BEAM189: refused by name",
    },
    "point masses": {
        "calculix": "*MASS: read on nodes and on a spider's REF NODE; *ROTARY INERTIA refused (CalculiX 2.20 "
                    "ignores it)",
        "meshio": "vertex cells with cell data mass (and inertia): read",
        "nastran": "CONM2 (offset CG, inertia): read",
        "ansys": "MASS21 without rotary inertia: read (the .full's M); with it: refused by name",
    },
    "rigid spiders": {
        "calculix": "*RIGID BODY: read; a mass on the REF NODE moves with the spider's rigid fit, on the ROT "
                    "NODE refused",
        "meshio": "none in meshio's cells",
        "nastran": "RBE2, RBE3, RBAR: massless; a mass on a dependent grid moves with its recovered motion",
        "ansys": "MPC184: refused by name; CERIG's constraint equations are not checked",
    },
}


def markdown() -> str:
    """The table of docs/elements.md: one row per kind of element, one column per reader."""
    rows = ["| element | " + " | ".join(READERS) + " |", "|---" * (len(READERS) + 1) + "|"]
    rows += [f"| {kind} | " + " | ".join(ELEMENTS[kind][r] for r in READERS) + " |" for kind in ELEMENTS]
    return "\n".join(rows) + "\n"


def console_lines(width: int = 80) -> list[str]:
    """The same table for a terminal: per kind, one wrapped line per reader, indented under it."""
    lines = []
    for kind, readers in ELEMENTS.items():
        lines.append(kind)
        for r in READERS:
            lines += textwrap.wrap(readers[r], max(width, 40), initial_indent=f"  {r:<9} ",
                                   subsequent_indent=" " * 12, break_on_hyphens=False)
    return lines
