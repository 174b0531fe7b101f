"""The body zoo: seeded, reproducible FE bodies by family, to try the advisor on bodies it was not tuned on.

``zoo_body(family, seed)`` draws the dimensions and proportions of a body of
the family, its material (steel, aluminium, titanium), cell type (20- or
27-node hexahedra) and mesh fineness from a numpy Generator seeded by the
seed with the family's fixed offset, ``default_rng((crc32(family), seed))``,
so a body is a pure function of (family, seed). It is built with the
project's FE toolkit like the samples: free-free, in t-mm-N-s, in its CoM
principal frame with N_MODES mass-normalised free-surface modes (theory
sections 1-4; the six rigid modes checked and dropped), consistent mass,
nodal von Mises stress, the static centrifugal response and the modal
geometric stiffness (theory 9, 11), at most MAX_NODES nodes, a few seconds.

Split by seed (``zoo_split``): seeds 0-999 are the calibration set (tune
on them), seeds 1000 and above the test set (judge on them only).
Names are "zoo:FAMILY:SEED" (``parse_zoo_name``); ``ffrf-advisor sample
zoo:ring:1003 -o ring.ffrf.h5`` builds one. docs/zoo.md lists the families
and their parameter ranges.
"""
from __future__ import annotations

import re
import zlib
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from .body import FlexibleBody
from .errors import FFRFError
from .fe.assembly import mass_matrix
from .fe_body import modal_body
from .fe.material import ALUMINIUM, STEEL, TITANIUM, Material
from .fe.mesh import Box, Mesh, box_mesh, box_union_mesh, cylindrical, round_cross

N_MODES = 12
MAX_NODES = 2500
TEST_SEEDS_FROM = 1000  # seeds below: calibration set; from here on: test set
MATERIALS = (STEEL, ALUMINIUM, TITANIUM)
CELLS = ("hexahedron20", "hexahedron27")
FINENESS = (0.5, 1.0)  # drawn range of the element-count factor; coarsened further to keep MAX_NODES
ZOO_PREFIX = "zoo:"
CORE = 0.55  # round bars: half-width of the square core / radius (fe.mesh.round_cross)


@dataclass(frozen=True)
class Shape:
    """One draw of a family: its parameters (mm and ratios) and its mesh for a cell type and a fineness in (0, 1]
    (element counts scale with it); ``heavy`` boxes hold parts of ``heavy_factor`` times the material's density."""

    params: dict[str, object]
    mesh: Callable[[str, float], Mesh]
    heavy: tuple[Box, ...] = ()
    heavy_factor: float = 1.0


def _n(count: int, fineness: float, least: int = 1) -> int:
    """``count`` elements scaled by ``fineness``, at least ``least``."""
    return max(least, round(count * fineness))


def _log(rng: np.random.Generator, lo: float, hi: float) -> float:
    """Log-uniform in [lo, hi] (sizes spanning a decade)."""
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def _annulus(r_in: float, r_out: float, z: tuple[float, float], counts: tuple[int, int, int],
             cell: str) -> Mesh:
    """A full turn about axis 3, r_in <= r <= r_out, z[0] <= z <= z[1]: a box in (r, theta, z) mapped and welded."""
    box = box_mesh([r_out - r_in, 2 * np.pi, z[1] - z[0]], counts, cell, centred=False)
    turned = box.transformed(np.eye(3), np.array([r_in, 0.0, z[0]])).mapped(cylindrical)
    return turned.welded(1e-9 * r_out)


def _twisted(rate: float, length: float) -> Callable[[np.ndarray], np.ndarray]:
    """Point map turning each section normal to axis 3 by ``rate * z`` about the axis, z clipped to [0, length]."""
    def point_map(x: np.ndarray) -> np.ndarray:
        a = rate * np.clip(x[:, 2], 0.0, length)
        c, s = np.cos(a), np.sin(a)
        x[:, 0], x[:, 1] = c * x[:, 0] - s * x[:, 1], s * x[:, 0] + c * x[:, 1]
        return x
    return point_map


def _round_bar(radius: float, z0: float, z1: float, reach: float | None = None) -> list[Box]:
    """The cross of boxes along axis 3 that ``_rounded`` turns into a round bar of ``radius`` (or, with arms
    out to ``reach``, a collar of that radius on it): core square of half-width CORE * radius, four arms."""
    b, a = CORE * radius, reach or radius
    return [Box((-a, -b, z0), (a, b, z1)), Box((-b, -a, z0), (b, a, z1))]


def _rounded(mesh: Mesh, radius: float) -> Mesh:
    """A mesh of ``_round_bar`` crosses of this radius (and collars) mapped onto round sections."""
    return mesh.mapped(round_cross(2, CORE * radius, radius)).welded(1e-9 * radius)


# ------------------------------------------------------------------ families
def shaft(rng) -> Shape:
    """Slender round shaft along axis 3: bending modes in equal pairs (90-degree symmetric mesh)."""
    L = _log(rng, 300.0, 2000.0)
    D = L / rng.uniform(10.0, 40.0)

    def mesh(cell, f):
        h = CORE * D / _n(3, f, 2)
        return _rounded(box_union_mesh(_round_bar(D / 2, 0.0, L), (h, h, L / _n(20, f, 8)), cell), D / 2)
    return Shape({"L": L, "D": D}, mesh)


def rotor(rng) -> Shape:
    """Round shaft along axis 3 with a round disc somewhere along it (axisymmetric)."""
    L = _log(rng, 300.0, 1500.0)
    d = L / rng.uniform(8.0, 25.0)
    D = d * rng.uniform(2.0, 4.0)
    t = D * rng.uniform(0.05, 0.25)
    z = L * rng.uniform(0.3, 0.7)
    boxes = _round_bar(d / 2, 0.0, L) + _round_bar(d / 2, z - t / 2, z + t / 2, D / 2)

    def mesh(cell, f):
        h = CORE * d / 2  # two core cells: the disc's arms get (D - d) / (2 h) cells radially
        return _rounded(box_union_mesh(boxes, (h, h, L / _n(20, f, 6)), cell), d / 2)
    return Shape({"L": L, "d_shaft": d, "D_disc": D, "t_disc": t, "z_disc": z}, mesh)


def blade(rng) -> Shape:
    """Pretwisted blade along axis 3 (chord along 1) with a root block and a heavy tip shroud."""
    L = _log(rng, 100.0, 600.0)
    c = L * rng.uniform(0.15, 0.4)
    t = c * rng.uniform(0.04, 0.12)
    tip = (c * rng.uniform(1.0, 1.6), t * rng.uniform(3.0, 8.0), L * rng.uniform(0.03, 0.08))
    twist = np.radians(rng.uniform(0.0, 45.0))
    boxes = [Box((-c / 2, -t / 2, 0), (c / 2, t / 2, L)),  # faces given exactly: shared ones must coincide
             Box((-tip[0] / 2, -tip[1] / 2, L), (tip[0] / 2, tip[1] / 2, L + tip[2])),
             Box((-c / 2, -1.5 * t, -0.1 * L), (c / 2, 1.5 * t, 0))]

    def mesh(cell, f):
        return box_union_mesh(boxes, (c / _n(6, f, 2), t, L / _n(16, f, 6)), cell).mapped(_twisted(twist / L, L))
    return Shape({"L": L, "chord": c, "t": t, "tip_chord": tip[0], "tip_t": tip[1], "tip_h": tip[2],
                  "twist_deg": np.degrees(twist)}, mesh)


def l_bracket(rng) -> Shape:
    """Angle bracket: legs a (along 1) and b (along 2) of thickness t, width w along 3."""
    a = _log(rng, 80.0, 400.0)
    b = a * rng.uniform(0.4, 1.0)
    w = a * rng.uniform(0.2, 0.6)
    t = a * rng.uniform(0.03, 0.1)
    boxes = [Box((0, 0, 0), (a, t, w)), Box((0, 0, 0), (t, b, w))]

    def mesh(cell, f):
        return box_union_mesh(boxes, (a / _n(12, f, 4), b / _n(10, f, 3), w / _n(4, f, 1)), cell)
    return Shape({"a": a, "b": b, "w": w, "t": t}, mesh)


def t_bracket(rng) -> Shape:
    """T section along axis 3 whose web is off the flange's centre and shorter than it: CoM off the
    geometry's centre, no symmetry plane, bending coupled with torsion."""
    L = _log(rng, 100.0, 500.0)
    b = L * rng.uniform(0.25, 0.6)
    tf = b * rng.uniform(0.05, 0.15)
    hw = b * rng.uniform(0.4, 1.0)
    tw = tf * rng.uniform(0.6, 1.5)
    e = b * rng.uniform(0.1, 0.35)
    Lw = L * rng.uniform(0.5, 1.0)
    boxes = [Box((-b / 2, 0, 0), (b / 2, tf, L)), Box((e - tw / 2, tf, 0), (e + tw / 2, tf + hw, Lw))]

    def mesh(cell, f):
        return box_union_mesh(boxes, (b / _n(6, f, 3), hw / _n(4, f, 2), L / _n(10, f, 4)), cell)
    return Shape({"L": L, "flange_b": b, "flange_t": tf, "web_h": hw, "web_t": tw, "web_offset": e,
                  "web_L": Lw}, mesh)


def ring(rng) -> Shape:
    """Thin circular ring, axis 3 its symmetry axis: its in-plane n = 2 modes form an equal pair."""
    R = _log(rng, 50.0, 500.0)
    t = R * rng.uniform(0.03, 0.12)
    h = t * rng.uniform(1.2, 4.0)

    def mesh(cell, f):
        return _annulus(R - t / 2, R + t / 2, (-h / 2, h / 2), (1, _n(48, f, 16), _n(2, f)), cell)
    return Shape({"R": R, "t_radial": t, "h_axial": h}, mesh)


def disc(rng) -> Shape:
    """Annular disc about axis 3."""
    Ro = _log(rng, 50.0, 400.0)
    Ri = Ro * rng.uniform(0.2, 0.6)
    t = Ro * rng.uniform(0.02, 0.1)

    def mesh(cell, f):
        return _annulus(Ri, Ro, (-t / 2, t / 2), (_n(4, f, 2), _n(40, f, 16), 1), cell)
    return Shape({"R_out": Ro, "R_in": Ri, "t": t}, mesh)


def tube(rng) -> Shape:
    """Thin-walled circular tube along axis 3."""
    R = _log(rng, 20.0, 200.0)
    t = R * rng.uniform(0.05, 0.15)
    L = R * rng.uniform(4.0, 20.0)

    def mesh(cell, f):
        return _annulus(R - t / 2, R + t / 2, (0.0, L), (1, _n(20, f, 12), _n(16, f, 6)), cell)
    return Shape({"R": R, "t": t, "L": L}, mesh)


def channel(rng) -> Shape:
    """Thin-walled C section along axis 3 (web along 2, flanges along 1): shear centre off the centroid."""
    L = _log(rng, 300.0, 1500.0)
    H = L / rng.uniform(6.0, 15.0)
    B = H * rng.uniform(0.3, 0.6)
    t = H * rng.uniform(0.04, 0.1)
    boxes = [Box((0, -H / 2, 0), (t, H / 2, L)), Box((0, -H / 2, 0), (B, -H / 2 + t, L)),
             Box((0, H / 2 - t, 0), (B, H / 2, L))]

    def mesh(cell, f):
        return box_union_mesh(boxes, (B / _n(3, f, 2), H / _n(5, f, 3), L / _n(20, f, 8)), cell)
    return Shape({"L": L, "H": H, "B": B, "t": t}, mesh)


def block(rng) -> Shape:
    """Stubby block: all sides within a factor of two."""
    a = _log(rng, 80.0, 400.0)
    b, c = a * rng.uniform(0.5, 1.0, 2)

    def mesh(cell, f):
        return box_mesh([a, b, c], [_n(5, f, 2), _n(4, f, 1), _n(4, f, 1)], cell)
    return Shape({"a": a, "b": b, "c": c}, mesh)


def strip(rng) -> Shape:
    """Thin strip along axis 1: length L, width w, thickness t."""
    L = _log(rng, 100.0, 600.0)
    w = L * rng.uniform(0.03, 0.12)
    t = L * rng.uniform(0.004, 0.02)

    def mesh(cell, f):
        return box_mesh([L, w, t], [_n(32, f, 12), _n(2, f), 1], cell)
    return Shape({"L": L, "w": w, "t": t}, mesh)


def plate(rng) -> Shape:
    """Rectangular plate a x b (unequal) of thickness t, normal axis 3."""
    a = _log(rng, 200.0, 1000.0)
    b = a * rng.uniform(0.5, 0.95)
    t = a * rng.uniform(0.003, 0.02)

    def mesh(cell, f):
        n = _n(16, f, 6)
        return box_mesh([a, b, t], [n, max(2, round(n * b / a)), 1], cell)
    return Shape({"a": a, "b": b, "t": t}, mesh)


def _ladder(L: float, W: float, s: float, bays: int, z: float) -> list[Box]:
    """Two rails along axis 1 (L long, W apart outside) and bays + 1 cross members between them, square
    section s, bottom at height z."""
    rails = [Box((0, y, z), (L, y + s, z + s)) for y in (0.0, W - s)]
    return rails + [Box((x, s, z), (x + s, W - s, z + s)) for x in np.linspace(0.0, L - s, bays + 1)]


def frame(rng) -> Shape:
    """Frame of square beams (side s): a ladder of two rails and bays + 1 cross members, or (one draw in two)
    two ladders joined by four corner posts, a space frame H high."""
    L = _log(rng, 300.0, 1500.0)
    W = L * rng.uniform(0.3, 0.8)
    s = L * rng.uniform(0.02, 0.05)
    bays = int(rng.integers(1, 5))
    H = L * rng.uniform(0.2, 0.6) if rng.random() < 0.5 else 0.0
    boxes = _ladder(L, W, s, bays, 0.0)
    if H:
        boxes += _ladder(L, W, s, bays, H - s) + [Box((x, y, s), (x + s, y + s, H - s))
                                                  for x in (0.0, L - s) for y in (0.0, W - s)]

    def mesh(cell, f):
        return box_union_mesh(boxes, max(s, L / _n(24, f, 8)), cell)
    return Shape({"L": L, "W": W, "s": s, "bays": bays, "H": H}, mesh)


def masses(rng) -> Shape:
    """A beam or plate of n1 x n2 squares of side a, thickness T, with one to four dense cubes (side a,
    height hb) on top: point-like heavy parts of ``heavy_factor`` times the density and the base's stiffness."""
    a = _log(rng, 10.0, 50.0)
    n1, n2 = int(rng.integers(6, 15)), int(rng.integers(1, 5))
    T = a * rng.uniform(0.2, 0.6)
    hb = a * rng.uniform(0.5, 1.0)
    spots = [divmod(int(k), n2) for k in np.sort(rng.choice(n1 * n2, size=int(rng.integers(1, 5)), replace=False))]
    heavy = tuple(Box((i * a, j * a, T), ((i + 1) * a, (j + 1) * a, T + hb)) for i, j in spots)
    factor = rng.uniform(3.0, 12.0)

    def mesh(cell, f):
        h = a / _n(2, f)
        return box_union_mesh([Box((0, 0, 0), (n1 * a, n2 * a, T)), *heavy], (h, h, T), cell)
    return Shape({"a": a, "n1": n1, "n2": n2, "T": T, "block_h": hb,
                  "blocks": " ".join(f"({i},{j})" for i, j in spots)}, mesh, heavy, factor)


FAMILY_SHAPES: dict[str, Callable[[np.random.Generator], Shape]] = {
    f.__name__: f for f in (shaft, rotor, blade, l_bracket, t_bracket, ring, disc, tube, channel, block, strip,
                            plate, frame, masses)}
FAMILIES = tuple(FAMILY_SHAPES)


# ------------------------------------------------------------------ the zoo
def zoo_split(seed: int) -> str:
    """"calibration" for seeds 0-999, "test" from 1000 on (module docstring)."""
    if seed < 0:
        raise ValueError(f"zoo seed {seed}: expected a whole number >= 0")
    return "calibration" if seed < TEST_SEEDS_FROM else "test"


def parse_zoo_name(name: str) -> tuple[str, int]:
    """(family, seed) of "zoo:FAMILY:SEED"; an FFRFError naming the expected form otherwise."""
    match = re.fullmatch(r"zoo:([a-z_]+):([0-9]+)", name)
    if match is None or match[1] not in FAMILY_SHAPES:
        raise FFRFError(f"zoo name {name!r}: expected zoo:FAMILY:SEED with FAMILY one of {', '.join(FAMILIES)} "
                        "and SEED a whole number >= 0")
    return match[1], int(match[2])


def zoo_rng(family: str, seed: int) -> np.random.Generator:
    """The Generator of (family, seed): the seed with the family's fixed offset, its CRC-32."""
    return np.random.default_rng((zlib.crc32(family.encode()), seed))


def _within_budget(shape: Shape, cell: str, fineness: float) -> tuple[Mesh, float]:
    """The shape's mesh at ``fineness``, coarsened by 10 % steps until it has at most MAX_NODES nodes."""
    mesh = shape.mesh(cell, fineness)
    while mesh.n_nodes > MAX_NODES:
        if fineness < 0.05:  # the family's least element counts are too many: a bug in its recipe
            raise ValueError(f"no mesh of {shape.params} with {cell} within {MAX_NODES} nodes")
        fineness *= 0.9
        mesh = shape.mesh(cell, fineness)
    return mesh, fineness


@dataclass(frozen=True)
class Draw:
    """What a zoo body is built from: the material, the mesh, the family's shape and every drawn value."""

    material: Material
    mesh: Mesh
    shape: Shape
    params: dict[str, object]

    def added_mass(self):
        """The extra scalar mass of the heavy parts (their cells at (heavy_factor - 1) rho; theory 2), or None."""
        shape = self.shape
        if not shape.heavy:
            return None
        part = self.mesh.cells_where(lambda x: np.any([b.contains(x) for b in shape.heavy], axis=0))
        return mass_matrix(part, (shape.heavy_factor - 1.0) * self.material.rho)

    def described(self) -> str:
        """The drawn values as one line of key=value."""
        return ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in self.params.items())


def zoo_draw(family: str, seed: int) -> Draw:
    """The draw of (family, seed) and its mesh, without the FE analysis (cheap: milliseconds)."""
    if family not in FAMILY_SHAPES:
        raise FFRFError(f"zoo family {family!r}: expected one of {', '.join(FAMILIES)}")
    rng = zoo_rng(family, seed)
    material = MATERIALS[rng.integers(len(MATERIALS))]
    cell = CELLS[rng.integers(len(CELLS))]
    fineness = rng.uniform(*FINENESS)
    shape = FAMILY_SHAPES[family](rng)
    mesh, fineness = _within_budget(shape, cell, fineness)
    params = {**shape.params, **({"heavy_factor": shape.heavy_factor} if shape.heavy else {}),
              "material": material.name, "cell": cell, "fineness": fineness}
    return Draw(material, mesh, shape, params)


def zoo_body(family: str, seed: int, report=None) -> FlexibleBody:
    """The zoo body of (family, seed) with its stiffness matrix (module docstring); ``report(step)`` hears of
    each step of the FE work. Its provenance records the family, the seed, the split and every drawn value."""
    split = zoo_split(seed)
    draw = zoo_draw(family, seed)
    body = modal_body(draw.mesh, draw.material, N_MODES, name=f"{ZOO_PREFIX}{family}:{seed}", report=report,
                      added_mass=draw.added_mass())
    provenance = replace(body.provenance, source="ffrf_advisor.zoo (fe generator)",
                         notes=(f"zoo: family={family}, seed={seed}, split={split}", f"drawn: {draw.described()}",
                                *body.provenance.notes))
    return replace(body, provenance=provenance)
