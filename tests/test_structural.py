"""Mass of shells, beams and point masses (fe.structural) against analytic inertia tensors, classic element
matrices and scikit-fem's own assembly."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from ffrf_advisor.fe.structural import BEAMS, SHELLS, BeamSection, beam_mass, point_mass, shell_mass

RHO = 7.85e-9
TURN = Rotation.from_euler("xyz", [0.4, -0.7, 1.1]).as_matrix()  # a general orientation
SHIFT = np.array([120.0, -40.0, 75.0])
ROUND = 1e-13  # nodal sums of a few hundred terms of the same sign: ~100 eps relative


def nodal_inertia(points: np.ndarray, mass) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, centre of mass and I0 about it by nodal sums (theory 3, 3b), independent of the package."""
    m = mass.Ms.sum()
    c = (mass.Ms @ points).sum(axis=0) / m
    x = points - c
    I = x.T @ (mass.Ms @ x)
    return m, c, np.trace(I) * np.eye(3) - I + mass.J.sum(axis=0)


def _close(got, want, tol):
    assert np.abs(np.asarray(got) - want).max() <= tol * np.abs(want).max(), (got, want)


def grid(cell_type: str, nx: int, ny: int) -> tuple[np.ndarray, np.ndarray]:
    """Parameter points (u, v) in [0, 1]^2 and cells of a structured grid of ``cell_type`` (VTK order)."""
    quadratic = SHELLS[cell_type].n_nodes > 4
    s = 2 if quadratic else 1
    mx, my = s * nx + 1, s * ny + 1
    u, v = np.meshgrid(np.linspace(0, 1, mx), np.linspace(0, 1, my), indexing="ij")
    idx = np.arange(mx * my).reshape(mx, my)
    cells = []
    for i, j in np.ndindex(nx, ny):
        a, b = s * i, s * j
        c = [idx[a, b], idx[a + s, b], idx[a + s, b + s], idx[a, b + s]]
        if cell_type == "quad":
            cells.append(c)
        elif cell_type == "triangle":
            cells += [[c[0], c[1], c[2]], [c[0], c[2], c[3]]]
        elif cell_type == "triangle6":
            cells += [[c[0], c[1], c[2], idx[a + 1, b], idx[a + 2, b + 1], idx[a + 1, b + 1]],
                      [c[0], c[2], c[3], idx[a + 1, b + 1], idx[a + 1, b + 2], idx[a, b + 1]]]
        else:
            mids = [idx[a + 1, b], idx[a + 2, b + 1], idx[a + 1, b + 2], idx[a, b + 1]]
            cells.append(c + mids + ([idx[a + 1, b + 1]] if cell_type == "quad9" else []))
    return np.stack([u.ravel(), v.ravel()], axis=1), np.array(cells)


def warp(t: np.ndarray) -> np.ndarray:
    """A monotone map of [0, 1] onto itself: uneven element sizes and mid-side nodes off the middle."""
    return t + 0.12 * np.sin(np.pi * t)


@pytest.mark.parametrize("cell_type", list(SHELLS))
def test_a_thin_plate_has_the_inertia_of_a_box(cell_type):
    """A plate a x b x t (uneven elements, mid-side nodes off centre, turned and moved): mass rho a b t and
    I0 = m/12 diag(b^2 + t^2, a^2 + t^2, a^2 + b^2) in its axes, by nodal sums. The mid-surface terms are
    exact (the isoparametric map reproduces x, the area element is a polynomial the rule integrates), the
    fibre terms give the t^2 parts exactly."""
    a, b, t = 300.0, 120.0, 4.0
    uv, cells = grid(cell_type, 6, 3)
    flat = np.column_stack([a * (warp(uv[:, 0]) - 0.5), b * (warp(uv[:, 1]) - 0.5), np.zeros(len(uv))])
    points = flat @ TURN.T + SHIFT
    m, c, I0 = nodal_inertia(points, shell_mass(points, cell_type, cells, t, RHO))
    want = RHO * a * b * t
    assert m == pytest.approx(want, rel=ROUND)
    _close(c, SHIFT, ROUND)
    _close(I0, TURN @ np.diag([b**2 + t**2, a**2 + t**2, a**2 + b**2]) @ TURN.T * want / 12, ROUND)


def test_thickness_per_cell():
    """Two halves of a plate, 2 and 6 thick: mass and I0 of the two boxes (the grid line x = 0 splits them)."""
    a, b = 200.0, 100.0
    uv, cells = grid("quad", 4, 2)
    points = np.column_stack([a * (uv[:, 0] - 0.5), b * (uv[:, 1] - 0.5), np.zeros(len(uv))])
    t = np.where(points[cells, 0].mean(axis=1) < 0, 2.0, 6.0)
    m, c, I0 = nodal_inertia(points, shell_mass(points, "quad", cells, t, RHO))
    halves = [(RHO * a / 2 * b * h, x, h) for h, x in ((2.0, -a / 4), (6.0, a / 4))]
    assert m == pytest.approx(sum(mh for mh, _, _ in halves), rel=ROUND)
    com = sum(mh * x for mh, x, _ in halves) / m
    want = sum(mh / 12 * np.diag([b**2 + h**2, (a / 2)**2 + h**2, (a / 2)**2 + b**2])
               + mh * (x - com) ** 2 * np.diag([0, 1, 1]) for mh, x, h in halves)
    _close(c, [com, 0, 0], ROUND)
    _close(I0, want, ROUND)


def test_element_matrices_are_the_classic_ones():
    """A triangle's consistent mass rho t A / 12 [[2, 1, 1], [1, 2, 1], [1, 1, 2]], a bar's rho A L / 6
    [[2, 1], [1, 2]] (exact rules: round-off of sums over 16 points and of the nodal basis's inverse, a few
    eps: 4e-15)."""
    tri = np.array([[1.0, 2.0, 3.0], [4.0, 2.5, 3.5], [2.0, 6.0, 2.0]])
    area = np.linalg.norm(np.cross(tri[1] - tri[0], tri[2] - tri[0])) / 2
    Ms = shell_mass(tri, "triangle", [[0, 1, 2]], 3.0, RHO).Ms.toarray()
    _close(Ms, RHO * 3.0 * area / 12 * (np.ones((3, 3)) + np.eye(3)), 4e-15)
    bar = beam_mass(tri, "line", [[0, 2]], BeamSection(5.0, 1.0, 1.0), RHO).Ms.toarray()
    length = np.linalg.norm(tri[2] - tri[0])
    _close(bar[np.ix_([0, 2], [0, 2])], RHO * 5.0 * length / 6 * (np.ones((2, 2)) + np.eye(2)), 4e-15)


@pytest.mark.parametrize("cell_type", ["triangle", "triangle6", "quad", "quad8", "quad9"])
def test_flat_shell_mass_matrix_equals_scikit_fem(cell_type):
    """On a plane mesh with moved inner corners (straight edges, mid-side nodes in the middle) the matrix
    int N_a N_b dA equals scikit-fem's assembly of the same elements entry by entry (both exact rules:
    round-off of sums over the quadrature points)."""
    skfem = pytest.importorskip("skfem")
    uv, cells = grid(cell_type, 3, 3)
    quadratic = SHELLS[cell_type].n_nodes > 4
    rng = np.random.default_rng(4)
    inner = np.all((uv > 0.01) & (uv < 0.99), axis=1)
    corner = np.zeros(len(uv), bool)
    corner[cells[:, :3 if cell_type.startswith("triangle") else 4].ravel()] = True
    uv = uv + np.where((inner & corner)[:, None], rng.uniform(-0.08, 0.08, uv.shape), 0.0)
    if quadratic:  # mid-side (and centre) nodes back to the middle of their straight edges
        n_corner = 3 if cell_type.startswith("triangle") else 4
        for cell in cells:
            ring = cell[:n_corner]
            for k, mid in enumerate(cell[n_corner:2 * n_corner]):
                uv[mid] = (uv[ring[k]] + uv[ring[(k + 1) % n_corner]]) / 2
            if cell_type == "quad9":
                uv[cell[8]] = uv[ring].mean(axis=0)
    points = np.column_stack([uv, np.zeros(len(uv))])
    Ms = shell_mass(points, cell_type, cells, 1.0, 1.0).Ms.toarray()
    corners = cells[:, :3 if cell_type.startswith("triangle") else 4]
    used = np.unique(corners)
    mesh_type, element = {"triangle": ("MeshTri", "ElementTriP1"), "triangle6": ("MeshTri", "ElementTriP2"),
                          "quad": ("MeshQuad", "ElementQuad1"), "quad8": ("MeshQuad", "ElementQuadS2"),
                          "quad9": ("MeshQuad", "ElementQuad2")}[cell_type]
    relabel = np.full(len(uv), -1)
    relabel[used] = np.arange(len(used))
    mesh = getattr(skfem, mesh_type)(uv[used].T, relabel[corners].T)
    basis = skfem.Basis(mesh, getattr(skfem, element)(), intorder=8)
    ref = skfem.BilinearForm(lambda u, v, w: u * v).assemble(basis).toarray()
    mine = np.unique(cells)
    dist, where = cKDTree(points[mine, :2]).query(basis.doflocs.T)
    assert dist.max() < 1e-12
    _close(Ms[np.ix_(mine[where], mine[where])], ref, 1e-13)


def _parabola(c: float) -> dict:
    """Integrals over x in [-1, 1] along the parabolic arc z = c x^2, with the arc length element s(x)."""
    s = lambda x: np.sqrt(1 + 4 * c * c * x * x)  # noqa: E731
    return {k: quad(f, -1, 1, epsabs=0, epsrel=1e-13, limit=200)[0] for k, f in {
        "s": s, "x2s": lambda x: x * x * s(x), "z2s": lambda x: (c * x * x) ** 2 * s(x),
        "zs": lambda x: c * x * x * s(x),
        "n_xx": lambda x: 4 * c * c * x * x / s(x), "n_zz": lambda x: 1 / s(x)}.items()}


# The reference's relative precision (quad's epsrel); the Gauss error of the elements is far below it: s(x) is
# analytic up to x = +-i/(2c) = +-i, and 8 points on elements 1/4 wide (8 elements on [-1, 1]) converge like
# rho^-16 with the Bernstein ellipse rho ~ 8.1: ~3e-15 (measured: 3e-16).
CURVED = 1e-13


@pytest.mark.parametrize("cell_type", ["triangle6", "quad8", "quad9"])
def test_a_curved_shell_against_its_analytic_inertia(cell_type):
    """A parabolic cylinder z = c x^2, x in [-1, 1], y in [-b/2, b/2], thickness t (quadratic elements hold
    it exactly): mass, centre and I0 (with the fibre inertia rho t^3/12 int (I - n n^T) dA) against adaptive
    quadrature of the exact surface."""
    c, b, t = 0.5, 0.6, 0.02
    uv, cells = grid(cell_type, 8, 3)
    x = 2 * uv[:, 0] - 1
    points = np.column_stack([x, b * (uv[:, 1] - 0.5), c * x * x])
    m, com, I0 = nodal_inertia(points, shell_mass(points, cell_type, cells, t, 1.0))
    P = _parabola(c)
    assert m == pytest.approx(t * b * P["s"], rel=CURVED)
    zc = P["zs"] / P["s"]
    _close(com, [0, 0, zc], CURVED)
    xx, yy, zz = t * b * P["x2s"], t * b**3 / 12 * P["s"], t * b * (P["z2s"] - zc * zc * P["s"])
    fibre = t**3 / 12 * b * (P["s"] * np.eye(3) - np.diag([P["n_xx"], 0, P["n_zz"]]))
    _close(I0, np.diag([yy + zz, xx + zz, xx + yy]) + fibre, CURVED)


@pytest.mark.parametrize("cell_type", list(BEAMS))
def test_a_slender_beam_has_the_inertia_of_a_box(cell_type):
    """A straight beam L along a turned axis, section w x h (A = w h, I22 = w h^3/12 about e2, I33 = h w^3/12),
    orientation given off the normal plane, uneven elements: I0 of the solid box, m/12 (w^2 + h^2), (L^2 + h^2),
    (L^2 + w^2) about e1, e2, e3 (exact: straight elements have a polynomial length element)."""
    L, w, h = 500.0, 30.0, 12.0
    nodes = 2 * 7 + 1 if cell_type == "line3" else 8
    s = L * (warp(np.linspace(0, 1, nodes)) - 0.5)
    e1, e2, e3 = TURN.T
    points = SHIFT + s[:, None] * e1
    cells = (np.column_stack([np.arange(0, nodes - 2, 2), np.arange(2, nodes, 2), np.arange(1, nodes - 1, 2)])
             if cell_type == "line3" else np.column_stack([np.arange(nodes - 1), np.arange(1, nodes)]))
    section = BeamSection(w * h, w * h**3 / 12, h * w**3 / 12, e2 + 0.7 * e1)
    m, c, I0 = nodal_inertia(points, beam_mass(points, cell_type, cells, section, RHO))
    want = RHO * L * w * h
    assert m == pytest.approx(want, rel=ROUND)
    _close(c, SHIFT, ROUND)
    axes = np.column_stack([e1, e2, e3])
    _close(I0, axes @ np.diag([w**2 + h**2, L**2 + h**2, L**2 + w**2]) @ axes.T * want / 12, ROUND)


def test_a_curved_beam_against_its_analytic_inertia():
    """A round bar (I22 = I33 = I, no orientation needed) along z = c x^2: mass rho A int s dx and I0 with the
    section's rho I (I3 + e1 e1^T) per length, e1 the tangent, against adaptive quadrature (tolerance as
    CURVED: 8 line3 elements)."""
    c, A, I = 0.5, 1e-3, 2e-7
    x = np.linspace(-1, 1, 17)
    points = np.column_stack([x, np.zeros_like(x), c * x * x])
    cells = np.column_stack([np.arange(0, 15, 2), np.arange(2, 17, 2), np.arange(1, 16, 2)])
    m, com, I0 = nodal_inertia(points, beam_mass(points, "line3", cells, BeamSection(A, I, I), 1.0))
    P = _parabola(c)
    assert m == pytest.approx(A * P["s"], rel=CURVED)
    zc = P["zs"] / P["s"]
    xx, zz = A * P["x2s"], A * (P["z2s"] - zc * zc * P["s"])
    # e1 e1^T integrated: (1, 0, 2 c x) (1, 0, 2 c x)^T / s^2 * s = diag(n_zz, 0, n_xx) + off-diagonal odd terms
    section = I * (P["s"] * np.eye(3) + np.diag([P["n_zz"], 0, P["n_xx"]]))
    _close(I0, np.diag([zz, xx + zz, xx]) + section, CURVED)


def test_quadratic_elements_lump_positive_rotary_inertia():
    """Every node's J_p is positive semi-definite (HRZ lumping; the integral of a quad8 corner's shape function
    is negative, so lumping by it would make corner nodes' rotary inertia negative)."""
    for cell_type in ("triangle6", "quad8", "quad9"):
        uv, cells = grid(cell_type, 2, 2)
        points = np.column_stack([uv, 0.1 * uv[:, 0] ** 2])
        J = shell_mass(points, cell_type, cells, 0.05, 1.0).J
        used = np.unique(cells)
        assert np.linalg.eigvalsh(J[used]).min() >= -1e-15 * np.abs(J).max(), cell_type
        assert np.all(np.trace(J[used], axis1=1, axis2=2) > 0), cell_type


def test_point_masses_add_their_inertia_and_parallel_axis_term():
    """Two point masses with inertia J_k at p_k: I0 = sum J_k + m_k (|d_k|^2 I - d_k d_k^T) about the CoM."""
    p = np.array([[0.0, 0.0, 0.0], [100.0, 20.0, -30.0]])
    J = np.array([np.diag([1.0, 2.0, 3.0]), [[4.0, 0.5, 0.0], [0.5, 5.0, 0.2], [0.0, 0.2, 6.0]]])
    m, c, I0 = nodal_inertia(p, point_mass(2, [0, 1], [0.3, 0.1], J))
    assert m == pytest.approx(0.4, rel=1e-15)
    com = (0.3 * p[0] + 0.1 * p[1]) / 0.4
    _close(c, com, 1e-15)
    d = p - com
    want = J.sum(axis=0) + sum(mk * (dk @ dk * np.eye(3) - np.outer(dk, dk)) for mk, dk in zip((0.3, 0.1), d))
    _close(I0, want, 1e-14)


def test_bad_geometry_and_sections_are_refused():
    p = np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0, 0]])
    with pytest.raises(ValueError, match=r"element 0 \(triangle\) is degenerate \(zero area\)"):
        shell_mass(p, "triangle", [[0, 1, 2]], 1.0, 1.0)
    with pytest.raises(ValueError, match="needs an orientation"):
        beam_mass(p, "line", [[0, 1]], BeamSection(1.0, 2.0, 1.0), 1.0)
    with pytest.raises(ValueError, match="orientation of beam 1 is \\(nearly\\) along its axis"):
        beam_mass(p, "line", [[0, 1], [1, 2]], BeamSection(1.0, 2.0, 1.0, [[0, 1, 0], [1, 0, 0]]), 1.0)
