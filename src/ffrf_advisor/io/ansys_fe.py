"""FE data of an MAPDL run in the body's units (theory 2-4): the scalar nodal mass, the material, the free
body's stiffness, and nodal von Mises stress from the element corner stresses."""
from __future__ import annotations

import os

import numpy as np
import scipy.sparse as sp

from ..errors import BodyFileError
from ..fe.assembly import full_mass, stiffness_matrix
from ..fe.elements import EDGES, TETRA_EDGES, WEDGE_EDGES, element_type
from ..fe.material import Material
from ..fe.mesh import Mesh
from ..fe.modal import rigid_modes, rigid_residual
from ..fe.pyramid import PYRAMID_EDGES
from ..fe.stress import von_mises
from .ansys_files import AnsysRun

KRON_TOL = 1e-10  # |M - kron(Ms, I3)| / max |Ms|: solid elements give this form to round-off (as CalculiX's)
FREE_K_TOL = 1e-9  # |K r| / (|K|_F |r|) of a free body's K: double round-off is ~1e-16 (the example's
# constrained K gives 6e-3)
MATCH_TOL = 1e-9  # max |K_elements - K_full| / max |K| on the unconstrained DOFs: the example's SOLID186 at 2x2x2
# matches to 3e-13; 3x3x3 is off by 7e-2
GAUSS_ORDERS = (2, 3)  # SOLID186 bricks: 2x2x2 (KEYOPT(2)=0, the default) or 3x3x3 (KEYOPT(2)=1)
BRICKS = {"hexahedron", "hexahedron20"}  # the cells the Gauss orders apply to; other shapes: their own rule
MOMENT_TOL = 1e-3  # m, CoM and second moments of the .full's Ms against the elements': round-off (the example: 1e-12)
# where both integrate degree-2 fields exactly (straight elements); MAPDL's rules (SOLID187: 4 points) and the
# ones used here are not exact on curved ones: on a ring of 15-degree tetra10 at 2 points per direction the second
# moments move by 7e-5 (4e-6 at 7.5 degrees). A wrong density, form or missing part moves them by more.
STRAIGHT_ORDER = {"tetra": 2, "wedge": 3, "pyramid": 3, "hexahedron": 3}  # points per direction exact for rho x x^T
# det J of straight elements: degree 2 in total on a tetrahedron (affine), <= 4 per coordinate on a distorted brick
CHUNK = 20_000  # elements per block of quadrature points (ne x nq x 3 x 3 Jacobians: 39 MB at 27 points)
CELL_EDGES = {"hexahedron": EDGES, "wedge": WEDGE_EDGES, "pyramid": PYRAMID_EDGES, "tetra": TETRA_EDGES}  # VTK's
VOIGT = [[0, 3, 5], [3, 1, 4], [5, 4, 2]]  # the tensor's entries among MAPDL's SX, SY, SZ, SXY, SYZ, SXZ


def scalar_mass(run: AnsysRun) -> sp.csr_array:
    """Ms with M = kron(Ms, I3) (theory 2: solid elements, MASS21 with one mass in X, Y and Z), or one line
    naming the .full."""
    Ms = sp.csr_array(run.M[0::3, 0::3])
    scale = abs(Ms).max()
    if not scale > 0 or abs(run.M - full_mass(Ms)).max() > KRON_TOL * scale:
        points = " and MASS21 with MASSX = MASSY = MASSZ" if run.element_types.get("MASS21") else ""
        raise BodyFileError(run.full, "mass matrix", f"the form kron(Ms, I3) of solid elements{points} with a "
                            "positive mass")
    return Ms


def mass_agreement(run: AnsysRun, Ms: sp.csr_array, length: float, mass: float) -> str:
    """The .full's Ms against the elements (each material's DENS) on the nodal sums of theory 3: mass, centre of
    mass and second moments about it, 1^T Ms 1, X^T Ms 1, X^T Ms X, which are int rho (1, x, x x^T) dV for the
    isoparametric x (integrated here by rules exact on straight elements); MASS21's point masses are the .full's."""
    dens = {m: d.get("DENS", 0.0) * mass / length**3 for m, d in run.materials.items()}
    used = sorted({int(m) for ms in run.cell_material.values() for m in ms})
    if not run.cells or not all(dens.get(m, 0.0) > 0 for m in used):
        return "mass: the .full's (not checked against the elements: " + \
            ("no solid elements)" if not run.cells else "a material without DENS)")
    ones = np.ones(len(run.points))
    (m0, c0, S0), (m1, c1, S1) = _central(ones @ Ms @ ones, run.points.T @ (Ms @ ones),
                                          run.points.T @ (Ms @ run.points)), _central(*_element_moments(run, dens))
    if run.element_types.get("MASS21"):
        return (f"mass: the .full's; its solid elements' {m1:.6g} of it, {m0 - m1:.6g} the .full's own from "
                f"{run.element_types['MASS21']} MASS21")
    size = float(np.ptp(run.points, axis=0).max())
    off = max(abs(m0 - m1) / m0, float(np.abs(c0 - c1).max()) / size, float(np.abs(S0 - S1).max() / np.abs(S0).max()))
    return (f"mass: the .full's; the elements' (DENS of material {', '.join(map(str, used))}) give its mass, centre "
            f"of mass and second moments within {off:.2g}" + ("" if off <= MOMENT_TOL else
                                                              " (warning: the elements are not the .full's model)"))


def _element_moments(run: AnsysRun, dens: dict[int, float]) -> tuple[float, np.ndarray, np.ndarray]:
    """int rho dV, int rho x dV and int rho x x^T dV over the cells, exact on straight elements."""
    m, first, second = 0.0, np.zeros(3), np.zeros((3, 3))
    for name, conn in run.cells.items():
        etype = element_type(name)
        xi, w = etype.gauss_rule(STRAIGHT_ORDER[etype.family])
        N, dN = etype.shape(xi)
        rho = np.vectorize(dens.__getitem__, otypes=[float])(run.cell_material[name])
        for start in range(0, len(conn), CHUNK):
            coords = run.points[conn[start:start + CHUNK]]
            detJ = np.linalg.det(np.einsum("qna,enb->eqab", dN, coords, optimize=True))
            if np.any(detJ <= 0):
                raise BodyFileError(run.source, "elements", "elements with a positive Jacobian (MAPDL's node order)",
                                    f"element {run.cell_numbers[name][start + np.argwhere(detJ <= 0)[0, 0]]} "
                                    f"({name}) inverted")
            dV = detJ * w * rho[start:start + CHUNK, None]
            x = np.einsum("qn,enk->eqk", N, coords)
            m, first = m + dV.sum(), first + np.einsum("eq,eqk->k", dV, x)
            second = second + np.einsum("eq,eqk,eql->kl", dV, x, x)
    return m, first, second


def _central(m: float, first: np.ndarray, second: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, centre of mass and second moments about it from int rho (1, x, x x^T) dV."""
    c = first / m
    return float(m), c, second - m * np.outer(c, c)


def material_of(run: AnsysRun, length: float, mass: float) -> tuple[Material | None, str]:
    """The one isotropic material of the elements (EX, PRXY or NUXY, DENS), in the body's units."""
    used = sorted(run.cell_materials)
    props = run.materials.get(used[0], {}) if len(used) == 1 else {}
    E, rho = props.get("EX", 0.0), props.get("DENS", 0.0)
    nu = props.get("PRXY", props.get("NUXY", -2.0))
    isotropic = all(props.get(p, E) == E for p in ("EY", "EZ"))
    if not (E > 0 and rho > 0 and -1 < nu < 0.5 and isotropic):
        return None, (f"no single isotropic material (materials {', '.join(map(str, used))}: "
                      "EX, PRXY or NUXY, DENS): no static centrifugal response or geometric stiffness")
    name = f"{os.path.basename(run.source)} MP {used[0]}"
    return Material(name, E * mass / length, nu, rho * mass / length**3), \
        f"material {used[0]}: EX {E:g}, nu {nu:g}, DENS {rho:g} (file units)"


def free_stiffness(run: AnsysRun, mesh: Mesh, material: Material | None) -> tuple[sp.csr_array | None, str]:
    """The free body's K (theory 4): the .full's when it is free, else the elements' own stiffness where it
    reproduces the .full's on every DOF its run did not hold; None with the reason otherwise."""
    full = os.path.basename(run.full)
    residual = rigid_residual(run.K, rigid_modes(run.points - run.points.mean(axis=0)))
    if residual <= FREE_K_TOL:
        return run.K, f"K of {full}: the free body's (|K r| / |K| |r| = {residual:.2g})"
    why = (f"K of {full} is not the free body's (|K r| / |K| |r| = {residual:.2g}, "
           f"{int(run.constrained.sum())} DOFs held)")
    if material is None or not mesh.cells:
        return None, why + " and the elements cannot be assembled (solid elements and one isotropic material)"
    free = ~run.constrained
    for order in GAUSS_ORDERS if set(mesh.cells) <= BRICKS else (None,):
        K = stiffness_matrix(mesh, material, order)
        D = sp.coo_array(K - run.K)
        inside = free[D.row] & free[D.col]
        off = float(np.abs(D.data[inside]).max(initial=0.0)) / float(abs(K).max())
        if off <= MATCH_TOL:
            rule = "each element's own rule" if order is None else f"{order}x{order}x{order} Gauss points"
            return K, (why + f": the free K assembled from the elements ({rule}) reproduces it on the other DOFs "
                       f"within {off:.2g}")
    return None, why + f" and the elements' stiffness differs from it by more than {MATCH_TOL:g}"


def nodal_von_mises(run: AnsysRun, combine: np.ndarray) -> np.ndarray | None:
    """Von Mises stress (n, k) of the modes ``run.modes @ combine`` (nm x k) at each node, averaged over the
    elements that share it (as for Nastran, io.nastran_stress); a quadratic cell's mid-edge value is its
    edge's mean tensor. None without corner stresses."""
    if run.corner_stress is None:
        return None
    n, k = len(run.points), combine.shape[1]
    total, count = np.zeros((n, k)), np.zeros(n)
    for cell, conn in run.cells.items():
        s = run.corner_stress[cell].astype(float) @ combine  # (ne, corners, 6, k)
        if conn.shape[1] > s.shape[1]:
            edges = CELL_EDGES[cell.rstrip("0123456789")]
            s = np.concatenate([s, 0.5 * (s[:, [a for a, _ in edges]] + s[:, [b for _, b in edges]])], axis=1)
        np.add.at(total, conn.ravel(), von_mises(np.moveaxis(s[..., VOIGT, :], -1, -3)).reshape(-1, k))
        np.add.at(count, conn.ravel(), 1.0)
    return total / np.maximum(count, 1.0)[:, None]
