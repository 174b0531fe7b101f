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
from ..fe.elements import EDGES, element_type  # noqa: E402
from ..fe.mesh import Mesh  # noqa: E402
from ..io.atomic import atomic_path  # noqa: E402

# Faces of a VTK hexahedron by corner index, outward normals.
_HEX_FACES = ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7))
DEFLECTION_SHOWN = 0.06  # largest drawn deflection / largest body dimension


def boundary_polygons(mesh: Mesh) -> np.ndarray:
    """Node indices (nfaces, 4 or 8) of the outer faces; quadratic faces list corner, mid-side, corner, ..."""
    polys = []
    for cell_type, conn in mesh.cells.items():
        quadratic = element_type(cell_type).n_nodes > 8
        for face in _HEX_FACES:
            ring = []
            for a, b in zip(face, face[1:] + face[:1]):
                ring.append(conn[:, a])
                if quadratic:
                    edge = EDGES.index((a, b)) if (a, b) in EDGES else EDGES.index((b, a))
                    ring.append(conn[:, 8 + edge])
            polys.append(np.stack(ring, axis=1))
    polys = np.concatenate(polys)
    keys = np.sort(polys[:, ::2] if polys.shape[1] == 8 else polys, axis=1)
    _, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    return polys[counts[inverse.ravel()] == 1]


def _draw(ax, points: np.ndarray, polys: np.ndarray, colour: np.ndarray | None, title: str) -> None:
    faces = points[polys]
    coll = Poly3DCollection(faces, linewidths=0.15, edgecolors=(0, 0, 0, 0.35))
    if colour is None:
        coll.set_facecolor((0.75, 0.78, 0.85, 1.0))
    else:
        coll.set_facecolor(plt.cm.viridis(colour[polys].mean(axis=1) / max(colour.max(), 1e-300)))
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
