"""Solid meshes and the structured hexahedral generator for boxes and unions of boxes."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from .elements import element_type


@dataclass(frozen=True)
class Mesh:
    """Node coordinates (n, 3) and connectivity by meshio cell type, VTK node order."""

    points: np.ndarray
    cells: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def n_nodes(self) -> int:
        return len(self.points)

    @property
    def n_cells(self) -> int:
        return sum(len(c) for c in self.cells.values())

    def bounding_box(self) -> tuple[np.ndarray, np.ndarray]:
        return self.points.min(axis=0), self.points.max(axis=0)

    def largest_dimension(self) -> float:
        lo, hi = self.bounding_box()
        return float(np.max(hi - lo))

    def transformed(self, rotation: np.ndarray, shift: np.ndarray) -> "Mesh":
        """The same mesh with points x -> rotation @ x + shift."""
        return Mesh(self.points @ np.asarray(rotation).T + shift, dict(self.cells))

    def mapped(self, point_map: Callable[[np.ndarray], np.ndarray]) -> "Mesh":
        """The same connectivity with every node (corner and mid-side) moved by ``point_map``.

        Mid-side nodes follow the map too, so quadratic elements get curved
        (isoparametric) edges.
        """
        return Mesh(point_map(self.points.copy()), dict(self.cells))

    def welded(self, tol: float) -> "Mesh":
        """The mesh with nodes closer than ``tol`` merged into one and renumbered.

        Closes the seam of a box mesh mapped onto a full turn (``cylindrical``),
        where the faces at angle 0 and 2 pi land on each other.
        """
        import scipy.sparse as sp  # scipy here: only meshes that close a turn need it
        from scipy.sparse.csgraph import connected_components
        from scipy.spatial import cKDTree

        n = self.n_nodes
        pairs = cKDTree(self.points).query_pairs(tol, output_type="ndarray")
        graph = sp.coo_array((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
        _, label = connected_components(graph, directed=False)
        _, first = np.unique(label, return_index=True)  # one node of each group, by label
        return Mesh(self.points[first], {name: label[conn] for name, conn in self.cells.items()})

    def cells_where(self, inside: Callable[[np.ndarray], np.ndarray]) -> "Mesh":
        """The cells whose centroid (mean of their nodes) satisfies ``inside`` (points (k, 3) -> bool (k,)).

        All nodes are kept, so a matrix assembled on the part adds to the
        whole mesh's (e.g. the extra mass of denser parts).
        """
        cells = {name: conn[inside(self.points[conn].mean(axis=1))] for name, conn in self.cells.items()}
        return Mesh(self.points, {name: conn for name, conn in cells.items() if len(conn)})


@dataclass(frozen=True)
class Box:
    """An axis-aligned box [lo, hi] (model length units)."""

    lo: tuple[float, float, float]
    hi: tuple[float, float, float]

    @classmethod
    def around(cls, centre: Sequence[float], size: Sequence[float]) -> "Box":
        """The box of ``size`` centred at ``centre``."""
        c, h = np.asarray(centre, float), np.asarray(size, float) / 2
        return cls(tuple(c - h), tuple(c + h))

    def contains(self, x: np.ndarray) -> np.ndarray:
        return np.all((x >= np.asarray(self.lo)) & (x <= np.asarray(self.hi)), axis=-1)


def _grid_lines(boxes: Sequence[Box], axis: int, h: float) -> np.ndarray:
    """Grid coordinates along one axis: every box face, subdivided to spacing <= h."""
    breaks = np.unique(np.concatenate([[b.lo[axis], b.hi[axis]] for b in boxes]))
    lines = [breaks[:1]]
    for a, b in zip(breaks[:-1], breaks[1:]):
        n = max(1, int(np.ceil((b - a) / h - 1e-9)))
        lines.append(np.linspace(a, b, n + 1)[1:])
    return np.concatenate(lines)


def box_union_mesh(boxes: Sequence[Box], h: float | Sequence[float], cell_type: str = "hexahedron27") -> Mesh:
    """Conforming structured hexahedral mesh of a union of boxes.

    The grid lines along each axis are the union of all box faces, each
    interval split into equal parts no longer than ``h`` (a number or one per
    axis). A grid cell belongs to the mesh when its centre lies in a box.
    """
    etype = element_type(cell_type)
    if etype.family != "hexahedron":
        raise ValueError(f"a box union is meshed with hexahedra, not {cell_type}: fe.split.box_split_mesh splits them")
    hs = np.broadcast_to(np.asarray(h, float), (3,))
    lines = [_grid_lines(boxes, d, hs[d]) for d in range(3)]
    centres = np.stack(np.meshgrid(*[(l[:-1] + l[1:]) / 2 for l in lines], indexing="ij"), -1)
    inside = np.zeros(centres.shape[:3], bool)
    for box in boxes:
        inside |= box.contains(centres)
    ijk = np.argwhere(inside)  # (ne, 3) cell indices
    quadratic = np.any(etype.ref_nodes == 0)
    step = 2 if quadratic else 1
    offsets = ((etype.ref_nodes + 1) * step / 2).astype(int)  # (nn, 3) in the node grid
    node_ijk = ijk[:, None, :] * step + offsets[None]  # (ne, nn, 3)
    dims = np.array([step * (len(l) - 1) + 1 for l in lines])
    flat = np.ravel_multi_index(node_ijk.reshape(-1, 3).T, dims)
    used, conn = np.unique(flat, return_inverse=True)
    node_grid = np.array(np.unravel_index(used, dims)).T
    coords = [_refined(l, step) for l in lines]
    points = np.stack([coords[d][node_grid[:, d]] for d in range(3)], -1)
    return Mesh(points, {cell_type: conn.reshape(len(ijk), etype.n_nodes)})


def _refined(lines: np.ndarray, step: int) -> np.ndarray:
    """Grid lines with their midpoints inserted when step == 2."""
    if step == 1:
        return lines
    out = np.empty(2 * len(lines) - 1)
    out[0::2] = lines
    out[1::2] = (lines[:-1] + lines[1:]) / 2
    return out


def box_mesh(size: Sequence[float], divisions: Sequence[int], cell_type: str = "hexahedron27",
             centred: bool = True) -> Mesh:
    """Structured mesh of one box of ``size`` with ``divisions`` elements per axis."""
    size = np.asarray(size, float)
    box = Box.around(np.zeros(3) if centred else size / 2, size)
    return box_union_mesh([box], size / np.asarray(divisions, float), cell_type)


def round_hole(centre: Sequence[float], axis: int, r: float, b: float, a: float) -> Callable[[np.ndarray], np.ndarray]:
    """Point map turning a square hole into a round one (an "eye").

    In the plane normal to ``axis`` about ``centre``, points of the square
    ring b <= max(|u|, |v|) <= a move from the square of half-width ``b`` to
    the circle of radius ``r`` at the inner edge, blending linearly to the
    identity at the outer square (half-width ``a``), so elements outside the
    ring are untouched and stay conforming.
    """
    plane = [d for d in range(3) if d != axis]
    c = np.asarray(centre, float)[plane]

    def point_map(x: np.ndarray) -> np.ndarray:
        u = x[:, plane] - c
        s = np.abs(u).max(axis=1)
        ring = (s >= b - 1e-9 * a) & (s <= a + 1e-9 * a)
        u, s = u[ring], s[ring]
        t = (s - b) / (a - b)
        on_circle = r * u / np.linalg.norm(u, axis=1)[:, None]
        on_square = u * (a / s)[:, None]
        moved = (1 - t)[:, None] * on_circle + t[:, None] * on_square
        x[np.ix_(ring, plane)] = c + moved
        return x

    return point_map


def round_cross(axis: int, core: float, radius: float, centre: Sequence[float] = (0.0, 0.0, 0.0)
                ) -> Callable[[np.ndarray], np.ndarray]:
    """Point map turning a cross of boxes into a disc (an O-grid without degenerate cells).

    In the plane normal to ``axis`` about ``centre``, the core square
    |u|, |v| <= ``core`` stays; a point (u, v) of the arm along +u (u > core,
    |v| <= core; the other arms alike) goes to
    ``(1 - t) (core, v) + t max(u, radius) (cos phi, sin phi)`` with
    phi = (pi / 4) v / core and t = min(1, (u - core) / (radius - core)). The
    arms up to ``radius`` fill the ring between the core and the circle of
    that radius; beyond it the line u = const lands on the circle of radius u
    (a collar). The arms'
    sides land on the diagonals twice: weld the mapped mesh
    (``Mesh.welded``). Keeps the 90-degree symmetry of a centred grid.
    """
    plane = [d for d in range(3) if d != axis]
    c = np.asarray(centre, float)[plane]
    turns = np.array([[[1, 0], [0, 1]], [[0, 1], [-1, 0]], [[-1, 0], [0, -1]], [[0, -1], [1, 0]]], float)

    def point_map(x: np.ndarray) -> np.ndarray:
        uv = x[:, plane] - c
        arm = np.argmax(uv @ turns[:, 0].T, axis=1)  # the arm along +u, +v, -u, -v whose direction u leans to
        p, q = np.einsum("nij,nj->in", turns[arm], uv)  # along the arm and across it
        t = np.clip((p - core) / (radius - core), 0.0, 1.0)
        phi = np.pi / 4 * q / core
        rim = np.maximum(p, radius)
        along = np.where(p > core, (1 - t) * core + t * rim * np.cos(phi), p)
        across = np.where(p > core, (1 - t) * q + t * rim * np.sin(phi), q)
        x[:, plane] = c + np.einsum("nji,jn->ni", turns[arm], np.array([along, across]))
        return x

    return point_map


def cylindrical(x: np.ndarray) -> np.ndarray:
    """Point map (r, theta, z) -> (r cos theta, r sin theta, z): a box mesh in (r, theta, z) becomes a ring,
    an annular disc or a tube about axis 3 (``Mesh.welded`` closes the seam of a full turn)."""
    r, theta = x[:, 0].copy(), x[:, 1].copy()
    x[:, 0], x[:, 1] = r * np.cos(theta), r * np.sin(theta)
    return x
