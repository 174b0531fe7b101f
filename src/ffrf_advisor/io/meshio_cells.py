"""The cells of a meshio mesh and the mass they carry (theory 2, 3b).

- solids (``fe.elements``: tetrahedra, wedges, pyramids, hexahedra, linear and quadratic): the consistent
  mass of the density;
- shells (``triangle``, ``triangle6``, ``quad``, ``quad8``, ``quad9``) with cell data ``thickness``;
- beams (``line``, ``line3``) with cell data ``area``, ``I22``, ``I33`` and, where I22 != I33, ``orientation``
  (a vector whose part normal to the axis is the section's axis 2);
- point masses: ``vertex`` cells with cell data ``mass`` and optional ``inertia`` (3 x 3 about the node, or
  9 numbers row by row);
each section field may instead be one value in field data for every cell (``fe.structural`` has the mass).
A cell of a shell, beam or vertex type without its data (missing, NaN or 0) whose nodes all belong to cells
that carry mass is a face, edge or point of them (meshers write such cells for boundaries and groups): it
carries no mass and is named in a note. One with a node elsewhere is refused, naming its type and the field.
Any other cell type is refused by name.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from ..errors import BodyFileError
from ..fe.elements import ELEMENT_TYPES
from ..fe.structural import BEAMS, SHELLS, BeamSection, StructuralMass, beam_mass, point_mass, shell_mass

DEFINING = {**{t: "thickness" for t in SHELLS}, **{t: "area" for t in BEAMS}, "vertex": "mass"}


@dataclass
class Cells:
    """Solid connectivity by type, the other cells that carry mass with their data, unused cells by type."""

    points: np.ndarray
    solids: dict[str, np.ndarray] = field(default_factory=dict)
    shells: list[tuple[str, np.ndarray, np.ndarray]] = field(default_factory=list)
    beams: list[tuple[str, np.ndarray, BeamSection]] = field(default_factory=list)
    masses: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=list)
    unused: Counter = field(default_factory=Counter)

    @property
    def distributed(self) -> bool:
        """Whether any cell needs the density."""
        return bool(self.solids or self.shells or self.beams)

    def structural_mass(self, path, rho: float) -> StructuralMass | None:
        """The shells', beams' and point masses' mass (fe.structural), or None without any."""
        if not (self.shells or self.beams or self.masses):
            return None
        total = StructuralMass.zero(len(self.points))
        for cell_type, conn, data in (*self.shells, *self.beams):
            mass = shell_mass if cell_type in SHELLS else beam_mass
            try:
                total = total + mass(self.points, cell_type, conn, data, rho)
            except ValueError as e:
                raise BodyFileError(path, f"cells/{cell_type}", "cells of positive size (and beam orientations "
                                    "off their axis)", str(e)) from None
        for nodes, m, J in self.masses:
            total = total + point_mass(len(self.points), nodes, m, J)
        return total

    def notes(self) -> list[str]:
        """What carries mass and which cells carry none."""
        parts = [f"{len(c)} {t}" for t, c in self.solids.items()]
        parts += [f"{len(c)} {t} shells" for t, c, _ in self.shells]
        parts += [f"{len(c)} {t} beams" for t, c, _ in self.beams]
        k = sum(len(nodes) for nodes, _, _ in self.masses)
        parts += [f"{k} point masses (vertex cells)"] if k else []
        notes = [f"mass from {', '.join(parts)}"]
        if self.unused:
            notes.append(f"cells without mass of their own: {', '.join(f'{v} {t}' for t, v in self.unused.items())} "
                         f"(no {'/'.join(sorted({DEFINING[t] for t in self.unused}))} data; faces, edges or points "
                         "of cells that carry mass)")
        return notes


def body_cells(path, m) -> Cells:
    """The cells of meshio's mesh ``m`` sorted by what they carry (module docstring)."""
    points = np.asarray(m.points, dtype=float)
    if points.ndim != 2 or points.shape[1] != 3 or not np.all(np.isfinite(points)):
        raise BodyFileError(path, "points", "finite 3D coordinates", str(points.shape))
    cells, pending = Cells(points), []
    for i, block in enumerate(m.cells):
        conn = _connectivity(path, block, len(points))
        if block.type in ELEMENT_TYPES:
            cells.solids[block.type] = np.concatenate([cells.solids[block.type], conn]) \
                if block.type in cells.solids else conn
        elif block.type in DEFINING:
            carried = _carried(path, m, i, block.type, conn, cells)
            pending.append((block.type, conn[~carried]))
        else:
            raise BodyFileError(path, f"cells/{block.type}", "cell types the reader carries (solids: "
                                f"{', '.join(ELEMENT_TYPES)}; shells: {', '.join(SHELLS)}; beams: "
                                f"{', '.join(BEAMS)}; vertex)", block.type)
    massive = np.zeros(len(points), bool)
    for conn in (*cells.solids.values(), *(c for _, c, _ in (*cells.shells, *cells.beams)),
                 *(nodes[:, None] for nodes, _, _ in cells.masses)):
        massive[conn.ravel()] = True
    for cell_type, conn in pending:
        _unused(path, cell_type, conn, massive, cells.unused)
    if not (cells.distributed or cells.masses):
        raise BodyFileError(path, "cells", "cells that carry mass (solids, or shells, beams and vertex cells with "
                            "their data: docs/format.md)", "none")
    return cells


def _connectivity(path, block, n: int) -> np.ndarray:
    conn = np.asarray(block.data, dtype=np.int64).reshape(len(block.data), -1)
    if conn.size and (conn.min() < 0 or conn.max() >= n):
        raise BodyFileError(path, f"cells/{block.type}", f"node indices in [0, {n})")
    return conn


def _unused(path, cell_type: str, conn: np.ndarray, massive: np.ndarray, unused: Counter) -> None:
    """Cells without their data: faces, edges or points of cells that carry mass, else refused."""
    if not len(conn):
        return
    outside = ~massive[conn].all(axis=1)
    if outside.any():
        what = {"vertex": "point masses", "line": "beams", "line3": "beams"}.get(cell_type, "shells")
        raise BodyFileError(path, f"cells/{cell_type}", f"cell data {DEFINING[cell_type]} for {what} (or field "
                            f"data for all of them; docs/format.md)",
                            f"none for {int(outside.sum())} cells with nodes outside the cells that carry mass")
    unused[cell_type] += len(conn)


def _carried(path, m, i: int, cell_type: str, conn: np.ndarray, cells: Cells) -> np.ndarray:
    """Per cell of block i, whether it carries its data; those that do are added to ``cells``."""
    name = DEFINING[cell_type]
    defining = _values(path, m, name, i, len(conn), 1)
    carried = np.zeros(len(conn), bool) if defining is None else np.isfinite(defining[:, 0]) & (defining[:, 0] != 0)
    if carried.any() and np.any(defining[carried, 0] < 0):
        raise BodyFileError(path, f"cell_data/{name}", f"positive values for {cell_type} cells",
                            f"{defining[carried, 0].min():g}")
    if not carried.any():
        return carried
    c, value = conn[carried], defining[carried, 0]
    if cell_type in SHELLS:
        cells.shells.append((cell_type, c, value))
    elif cell_type in BEAMS:
        cells.beams.append((cell_type, c, _section(path, m, i, cell_type, carried, value)))
    else:
        inertia = _values(path, m, "inertia", i, len(conn), 9)
        J = None if inertia is None else _inertia(path, inertia[carried].reshape(-1, 3, 3))
        cells.masses.append((c[:, 0], value, J))
    return carried


def _section(path, m, i: int, cell_type: str, carried: np.ndarray, area: np.ndarray) -> BeamSection:
    """The section data of the beams of block i that have an area."""
    n = len(carried)
    I22, I33 = (_values(path, m, k, i, n, 1, cell_type=cell_type)[carried, 0] for k in ("I22", "I33"))
    if np.any(~np.isfinite(I22) | ~np.isfinite(I33) | (I22 < 0) | (I33 < 0)):
        raise BodyFileError(path, "cell_data/I22, I33", f"finite non-negative second moments for {cell_type} "
                            "cells with an area", "NaN or negative")
    skew = I22 != I33
    if not skew.any():
        return BeamSection(area, I22, I33)
    v = _values(path, m, "orientation", i, n, 3, cell_type=cell_type)[carried]
    if not np.all(np.isfinite(v[skew])):
        raise BodyFileError(path, "cell_data/orientation", f"a finite vector for {cell_type} cells with I22 != I33",
                            "NaN")
    return BeamSection(area, I22, I33, np.where(np.isfinite(v), v, 0.0))


def _inertia(path, J: np.ndarray) -> np.ndarray:
    """Point masses' inertia (k, 3, 3): finite, symmetric, positive semi-definite (round-off allowed)."""
    J = np.where(np.isnan(J), 0.0, J)
    scale = max(np.abs(J).max(), np.finfo(float).tiny)
    if not np.all(np.isfinite(J)) or np.abs(J - J.transpose(0, 2, 1)).max() > 1e-12 * scale \
            or np.linalg.eigvalsh((J + J.transpose(0, 2, 1)) / 2).min() < -1e-12 * scale:
        raise BodyFileError(path, "cell_data/inertia", "symmetric positive semi-definite 3 x 3 inertia of each "
                            "point mass about its node", "otherwise")
    return J


def _values(path, m, name: str, i: int, n: int, width: int, cell_type: str | None = None) -> np.ndarray | None:
    """Cell data ``name`` of block i as (n, width), else one value of field data for all, else None (or, for a
    ``cell_type`` that needs it, refused)."""
    if name in m.cell_data:
        a = np.asarray(m.cell_data[name][i], dtype=float)
        where = f"cell_data/{name}"
    elif name in m.field_data:
        where = f"field_data/{name}"
        a = np.asarray(m.field_data[name], dtype=float).ravel()
        if a.size != width:
            raise BodyFileError(path, where, f"{width} number{'s' if width > 1 else ''} for all cells", str(a.size))
        a = np.broadcast_to(a, (n, width))
    elif cell_type is not None:
        raise BodyFileError(path, f"cell_data/{name}", f"{name} of the {cell_type} cells (cell or field data)",
                            "missing")
    else:
        return None
    if a.size != n * width:
        raise BodyFileError(path, where, f"{width} number{'s' if width > 1 else ''} per cell of block {i}",
                            str(a.shape))
    return a.reshape(n, width)
