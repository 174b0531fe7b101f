"""Recipes of the shipped sample bodies (t-mm-N-s); see docs/samples.md."""
from __future__ import annotations

from typing import Callable

from .body import FlexibleBody
from .fe.build import modal_body
from .fe.material import STEEL
from .fe.mesh import box_mesh

N_MODES = 16


def beam(refine: int = 1) -> FlexibleBody:
    """Slender free-free steel beam 40 x 20 x 1000 mm, long axis 3, quadratic hexahedra."""
    mesh = box_mesh([40.0, 20.0, 1000.0], [2 * refine, refine, 40 * refine], "hexahedron20")
    return modal_body(mesh, STEEL, N_MODES, name="beam")


SAMPLES: dict[str, Callable[..., FlexibleBody]] = {"beam": beam}
