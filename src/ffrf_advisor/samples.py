"""Recipes of the shipped sample bodies (t-mm-N-s, free-free); see docs/samples.md.

Counterparts of the six structures of the guideline paper (G section 4).
Each recipe takes ``refine``, the factor by which the element size shrinks,
and returns the body with 16 flexible modes, nodal stress and the consistent
mass matrix. The stiffness matrix is not kept: the advisor needs only the
eigenvalues, and K would be most of the file.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

from .body import FlexibleBody
from .errors import FFRFError
from .fe_body import modal_body
from .fe.material import STEEL
from .fe.mesh import Box, Mesh, box_mesh, box_union_mesh, round_hole
from .names import SAMPLES
from .zoo import ZOO_PREFIX, parse_zoo_name, zoo_body

N_MODES = 16
MAX_REFINE = 4  # carbody at 4: about 370,000 nodes (walls: nodes grow with refine^2)
CELL = "hexahedron20"


def _square_ring(centre, a: float, b: float, thickness: float) -> list[Box]:
    """Four boxes forming a square frame in the 1-2 plane: outer half-width a, hole half-width b."""
    x, y, z = centre
    w = a - b
    return [Box.around((x, y - b - w / 2, z), (2 * a, w, thickness)), Box.around((x, y + b + w / 2, z), (2 * a, w, thickness)),
            Box.around((x - b - w / 2, y, z), (w, 2 * b, thickness)), Box.around((x + b + w / 2, y, z), (w, 2 * b, thickness))]


def _without_stiffness(body: FlexibleBody) -> FlexibleBody:
    return replace(body, fe=replace(body.fe, K=None))


# ------------------------------------------------------------------ recipes
def beam_mesh(refine: int = 1) -> Mesh:
    """Slender beam 40 x 20 x 1000 mm, long axis 3."""
    return box_mesh([40.0, 20.0, 1000.0], [2 * refine, refine, 40 * refine], CELL)


def plate_mesh(refine: int = 1) -> Mesh:
    """Thin plate 1000 x 900 x 0.5 mm, normal axis 3 (sides unequal: no repeated eigenvalues)."""
    return box_mesh([1000.0, 900.0, 0.5], [20 * refine, 18 * refine, 1], CELL)


def conrod_mesh(refine: int = 1) -> Mesh:
    """Connecting rod along axis 2, bores along axis 3.

    Big end: 84 x 84 x 24 mm block with a 56 mm bore at the origin; small end:
    36 x 36 x 24 mm with a 20 mm bore at y = 150 mm; shank 20 x 90 x 16 mm.
    """
    big, small = (0.0, 0.0, 0.0), (0.0, 150.0, 0.0)
    boxes = (_square_ring(big, 42.0, 28.0, 24.0) + _square_ring(small, 18.0, 10.0, 24.0)
             + [Box.around((0.0, 87.0, 0.0), (20.0, 90.0, 16.0))])
    mesh = box_union_mesh(boxes, 7.0 / refine, CELL)
    return mesh.mapped(round_hole(big, 2, 28.0, 28.0, 42.0)).mapped(round_hole(small, 2, 10.0, 10.0, 18.0))


@dataclass(frozen=True)
class GenStruct:
    """Hub, two arms along +-axis 2, and at each arm end a flexure strip along axis 1 carrying a flyweight.

    Spinning about axis 1 throws the flyweights outward (along +-2), which
    bends the strips across their thickness ``t``: the body widens, and its
    inertia about axis 1 grows linearly with the deflection.
    """

    t: float          # flexure thickness (bending direction, axis 2) [mm]
    R: float = 200.0  # radius of the flexures [mm]
    L: float = 180.0  # free length of the flexures [mm]

    def boxes(self) -> list[Box]:
        R, L, t = self.R, self.L, self.t
        parts = [Box.around((0.0, 0.0, 0.0), (60.0, 60.0, 60.0))]
        for s in (-1.0, 1.0):
            parts += [Box.around((0.0, s * (R + 30.0) / 2 + s * 5.0, 0.0), (40.0, R - 20.0, 40.0)),  # arm 30..R+10
                      Box.around((20.0 + L / 2, s * R, 0.0), (L, t, 30.0)),                          # flexure
                      Box.around((20.0 + L + 20.0, s * R, 0.0), (40.0, 40.0, 40.0))]                 # flyweight
        return parts

    def mesh(self, refine: int = 1) -> Mesh:
        return box_union_mesh(self.boxes(), 10.0 / refine, CELL)


GENSTRUCT1 = GenStruct(t=2.0)
GENSTRUCT2 = GenStruct(t=12.0)


def carbody_boxes() -> list[Box]:
    """Closed thin-walled box 4000 x 1600 x 1300 mm, 3 mm walls, with window and door openings.

    Floor and roof carry four 60 mm deep transverse ribs (3 mm), as a real
    body's cross members, so the first modes are global, not panel drumming.
    """
    Lx, Ly, Lz, w = 4000.0, 1600.0, 1300.0, 3.0
    X, Y = Lx / 2, Ly / 2
    boxes = [Box.around((0, 0, w / 2), (Lx, Ly, w)), Box.around((0, 0, Lz - w / 2), (Lx, Ly, w)),  # floor, roof
             Box.around((-X + w / 2, 0, Lz / 2), (w, Ly, Lz))]                             # rear wall
    # front wall with a windscreen opening above z = 700
    boxes += [Box.around((X - w / 2, 0, 350), (w, Ly, 700)), Box.around((X - w / 2, -Y + 100, 1000), (w, 200, 600)),
              Box.around((X - w / 2, Y - 100, 1000), (w, 200, 600))]
    for s in (-1.0, 1.0):  # side walls: sill below 400, posts, roof rail above 1100
        y = s * (Y - w / 2)
        boxes += [Box.around((0, y, 200), (Lx, w, 400)), Box.around((0, y, 1200), (Lx, w, 200))]
        for x in (-1800.0, -200.0, 1800.0):  # pillars between the door openings
            boxes.append(Box.around((x, y, 750), (400.0, w, 700)))
    for x in (-1200.0, -400.0, 400.0, 1200.0):  # cross members under the roof and on the floor
        boxes += [Box.around((x, 0, w + 30), (w, Ly, 60.0)), Box.around((x, 0, Lz - w - 30), (w, Ly, 60.0))]
    return boxes


def carbody_mesh(refine: int = 1) -> Mesh:
    return box_union_mesh(carbody_boxes(), 100.0 / refine, CELL)


RECIPES: dict[str, tuple[Callable[[int], Mesh], object, str]] = dict(zip(SAMPLES, (  # names.SAMPLES, in order
    (beam_mesh, STEEL, "slender steel beam, mass along axis 3"),
    (plate_mesh, STEEL, "thin steel plate 1000 x 900 x 0.5 mm"),
    (conrod_mesh, STEEL, "compact steel connecting rod"),
    (GENSTRUCT1.mesh, STEEL, "hub with flyweights on soft flexures (2 x 180 mm)"),
    (GENSTRUCT2.mesh, STEEL, "the same with stiff flexures (12 x 180 mm)"),
    (carbody_mesh, STEEL, "thin-walled closed box frame, 3 mm steel walls"),
), strict=True))


def sample(name: str, refine: int = 1, keep_stiffness: bool = False, report=None) -> FlexibleBody:
    """The sample body ``name`` at mesh refinement ``refine`` (1: the shipped one), K only when asked;
    ``report(step)`` hears of each step of the FE work. A name "zoo:FAMILY:SEED" gives that body of the zoo
    (``zoo``), whose mesh density is drawn from the seed (refine 1 only)."""
    if name.startswith(ZOO_PREFIX):
        if refine != 1:
            raise FFRFError(f"--refine {refine}: a zoo body's mesh density is drawn from its seed; expected 1")
        body = zoo_body(*parse_zoo_name(name), report=report)
    else:
        body = _recipe_body(name, refine, report)
    return body if keep_stiffness else _without_stiffness(body)


def _recipe_body(name: str, refine: int, report) -> FlexibleBody:
    if name not in RECIPES:
        raise FFRFError(f"sample {name!r}: expected one of {', '.join(SAMPLES)}, or zoo:FAMILY:SEED (docs/zoo.md)")
    if not 1 <= refine <= MAX_REFINE:
        raise FFRFError(f"--refine {refine}: expected an integer from 1 to {MAX_REFINE} "
                        "(the element count grows with its cube)")
    make_mesh, material, _ = RECIPES[name]
    return modal_body(make_mesh(refine), material, N_MODES, name=name, report=report)
