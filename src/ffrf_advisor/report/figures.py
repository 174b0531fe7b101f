"""Pictures of a body's mesh and its mode shapes (matplotlib, no screen needed)."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

from ..body import FlexibleBody  # noqa: E402
from ..errors import FFRFError  # noqa: E402
from ..fe.elements import element_faces  # noqa: E402
from ..fe.mesh import Mesh  # noqa: E402
from ..io.atomic import atomic_path  # noqa: E402

DEFLECTION_SHOWN = 0.06  # largest drawn deflection / largest body dimension


def boundary_polygons(mesh: Mesh) -> list[np.ndarray]:
    """The outer faces as rings of node indices, one array (nfaces, k) per ring length k: 3 or 4 corners, or 6
    or 8 for quadratic faces (corner, mid-side, corner, ...; fe.elements.element_faces). A face is outer when
    no other face of the mesh has its corners: that holds across cell types (a hexahedron against a pyramid)."""
    rings: dict[int, list[np.ndarray]] = {}
    for cell_type, conn in mesh.cells.items():
        for face in element_faces(cell_type):
            rings.setdefault(len(face), []).append(conn[:, face])
    groups = [np.concatenate(parts) for _, parts in sorted(rings.items())]
    keys = [np.sort(g[:, ::2] if g.shape[1] > 4 else g, axis=1) for g in groups]
    padded = np.concatenate([np.pad(k, ((0, 0), (0, 4 - k.shape[1])), constant_values=-1) for k in keys])
    _, inverse, counts = np.unique(padded, axis=0, return_inverse=True, return_counts=True)
    outer = np.split(counts[inverse.ravel()] == 1, np.cumsum([len(g) for g in groups])[:-1])
    return [g[keep] for g, keep in zip(groups, outer) if keep.any()]


def _draw(ax, points: np.ndarray, polys: list[np.ndarray], colour: np.ndarray | None, title: str) -> None:
    faces = [face for group in polys for face in points[group]]
    coll = Poly3DCollection(faces, linewidths=0.15, edgecolors=(0, 0, 0, 0.35))
    if colour is None:
        coll.set_facecolor((0.75, 0.78, 0.85, 1.0))
    else:
        mean = np.concatenate([colour[group].mean(axis=1) for group in polys])
        coll.set_facecolor(plt.cm.viridis(mean / max(colour.max(), 1e-300)))
    ax.add_collection3d(coll)
    lo, hi = points.min(axis=0), points.max(axis=0)
    span = np.maximum(hi - lo, 1e-3 * (hi - lo).max())
    centre = (lo + hi) / 2
    for setter, c, s in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre, span):
        setter(c - s / 2, c + s / 2)
    ax.set_box_aspect(span)
    ax.set_axis_off()
    ax.set_title(title, fontsize=8)


def modes_figure(body: FlexibleBody, q: np.ndarray | None = None, modes: int = 3, name: str | None = None):
    """The undeformed mesh and the first ``modes`` mode shapes at modal coordinates ``q`` (1 when None),
    coloured by deflection; each drawing's exaggeration and its true deflection are in its title."""
    if body.fe is None:
        raise FFRFError(f"{body.name}: no mesh to draw (invariants-only body)")
    mesh, Phi = body.fe.mesh, body.fe.Phi
    polys = boundary_polygons(mesh)
    n = min(modes, body.nf)
    fig = plt.figure(figsize=(3.2 * (n + 1), 3.2))
    _draw(fig.add_subplot(1, n + 1, 1, projection="3d"), mesh.points, polys, None,
          f"{name or body.name}: {mesh.n_cells} elements")
    for p in range(n):
        u = (1.0 if q is None else q[p]) * Phi[:, :, p]
        size = np.linalg.norm(u, axis=1)
        true = size.max() / mesh.largest_dimension()
        scale = DEFLECTION_SHOWN / max(true, 1e-300)
        ax = fig.add_subplot(1, n + 1, p + 2, projection="3d")
        _draw(ax, mesh.points + scale * u, polys, size,
              f"mode {p + 1}: {body.frequencies_hz[p]:.4g} {body.units.frequency}"
              f"{'' if q is None else ' at q_max'}, x{scale:.3g}\n(true deflection {true:.2g} of size)")
        colours = plt.cm.ScalarMappable(plt.Normalize(0.0, size.max()), plt.cm.viridis)
        fig.colorbar(colours, ax=ax, orientation="horizontal", shrink=0.7, pad=0.02).set_label(
            f"true deflection |u| [{body.units.length}]", fontsize=7)
    fig.tight_layout()
    return fig


def body_picture(body: FlexibleBody, path: Path, modes: int = 3, overwrite: bool = True) -> None:
    """PNG: the undeformed mesh and the first ``modes`` mode shapes at unit modal coordinate."""
    fig = modes_figure(body, modes=modes)
    with atomic_path(path, overwrite) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
