"""The solid element library (hexahedra, tetrahedra, wedges, pyramids) against analytic integrals and scikit-fem.

Meshes are boxes split into each type (``fe.split``), then moved by a polynomial map F that every element of the
type represents exactly (affine for tetra and pyramid, multilinear for hexahedron and wedge, quadratic for the
quadratic types), so the mesh IS the mapped box and every integral over it is an integral over the box of a
polynomial times det grad F: exact by a tensor Gauss rule on the whole box, not on the elements. Round-off of the
nodal sums (a few hundred terms of eps each) is 1e-13 of their size; TOL = 1e-11 leaves a margin of 100.
"""
from __future__ import annotations

import shutil
import subprocess
from math import factorial

import numpy as np
import pytest
import scipy.sparse as sp

from ffrf_advisor.fe import quadrature
from ffrf_advisor.fe.assembly import mass_matrix, stiffness_matrix
from ffrf_advisor.fe.elements import ELEMENT_TYPES, element_type
from ffrf_advisor.fe.lagrange import tetra_exponents
from ffrf_advisor.fe.material import STEEL
from ffrf_advisor.fe.mesh import Mesh, box_mesh
from ffrf_advisor.fe.modal import free_free_modes, rigid_modes
from ffrf_advisor.fe.split import box_split_mesh, quadratic, split_hexahedra
from ffrf_advisor.fe.stress import nodal_stress

TOL = 1e-11  # round-off of nodal sums (module docstring)
SIZE = np.array([3.0, 2.0, 1.5])
DIV = (3, 2, 2)
QUADRATIC = {"tetra10", "wedge15", "pyramid13", "hexahedron20", "hexahedron27"}
A = np.array([[1.0, 0.2, 0.1], [-0.1, 1.1, 0.15], [0.05, -0.2, 0.9]])


def affine(x):
    return x @ A.T + [0.3, 0.1, -0.2], np.broadcast_to(A, (len(x), 3, 3))


def multilinear(x):
    """x + (0.1 yz, 0.08 xz, 0.07 xz): multilinear in each hexahedron, P1(x, y) x P1(z) in each wedge."""
    X, Y, Z = x.T
    F = x + np.column_stack([0.1 * Y * Z, 0.08 * X * Z, 0.07 * X * Z])
    J = np.zeros((len(x), 3, 3)) + np.eye(3)
    J[:, 0, 1], J[:, 0, 2] = 0.1 * Z, 0.1 * Y
    J[:, 1, 0], J[:, 1, 2] = 0.08 * Z, 0.08 * X
    J[:, 2, 0], J[:, 2, 2] = 0.07 * Z, 1 + 0.07 * X
    return F, J


def curved(x):
    """A quadratic map: every quadratic element's edges become parabolas."""
    X, Y, Z = x.T
    F = x + np.column_stack([0.1 * Y**2 + 0.05 * Y * Z, 0.08 * X * Z - 0.06 * Z**2, 0.07 * X**2 + 0.04 * X * Y])
    J = np.zeros((len(x), 3, 3)) + np.eye(3)
    J[:, 0, 1], J[:, 0, 2] = 0.2 * Y + 0.05 * Z, 0.05 * Y
    J[:, 1, 0], J[:, 1, 2] = 0.08 * Z, 0.08 * X - 0.12 * Z
    J[:, 2, 0], J[:, 2, 1] = 0.14 * X + 0.04 * Y, 0.04 * X
    return F, J


def map_of(name):
    if name in QUADRATIC:
        return curved
    return multilinear if name in ("hexahedron", "wedge") else affine


def mapped_mesh(name, div=DIV):
    mesh = box_split_mesh(SIZE, div, name)
    return mesh, mesh.mapped(lambda x: map_of(name)(x)[0])


def over_box(F, f):
    """int over the box of f(x0) det grad F(x0) dx0, f: (nq, 3) -> (nq, ...): 8 Gauss points per axis (degree 15,
    above every integrand here: at most 4 + 3 + 4 = 11 per axis)."""
    xi, w = quadrature.hexahedron(8)
    x0 = xi * SIZE / 2
    _, J = F(x0)
    return np.einsum("q,q...->...", w * np.prod(SIZE) / 8 * np.linalg.det(J), f(x0))


def monomials(x, degree):
    return np.stack([np.prod(x ** e, axis=1) for e in tetra_exponents(degree)], axis=1)


def relative(a, b):
    return np.abs(np.asarray(a) - b).max() / np.abs(b).max()


@pytest.mark.parametrize("name", list(ELEMENT_TYPES))
def test_shape_functions_interpolate_are_complete_and_differentiate(name):
    e = element_type(name)
    assert np.abs(e.shape(e.ref_nodes)[0] - np.eye(e.n_nodes)).max() < 1e-14
    xi, _ = e.gauss_rule(3)
    N, dN = e.shape(xi)
    degree = 2 if name in QUADRATIC else 1  # every polynomial of this total degree is reproduced
    P = monomials(e.ref_nodes, degree)
    assert np.abs(N @ P - monomials(xi, degree)).max() < 1e-13
    h = 1e-6  # central differences: truncation h^2 ~ 1e-12, round-off eps / h ~ 1e-10
    fd = np.stack([(e.shape(xi + h * s)[0] - e.shape(xi - h * s)[0]) / (2 * h) for s in np.eye(3)], axis=-1)
    assert np.abs(fd - dN).max() < 1e-8


def _monomial_integral(family, i, j, k):
    """Exact int x^i y^j z^k over a family's reference domain (quadrature's docstring)."""
    f = factorial
    if family == "tetra":
        return f(i) * f(j) * f(k) / f(i + j + k + 3)
    line = (1 + (-1) ** k) / (k + 1)
    if family == "wedge":
        return f(i) * f(j) / f(i + j + 2) * line
    if family == "hexahedron":
        return np.prod([(1 + (-1) ** m) / (m + 1) for m in (i, j, k)])
    # pyramid: x = a (1 - z), y = b (1 - z): int a^i b^j da db * int z^k (1 - z)^(i + j + 2) dz
    return (1 + (-1) ** i) / (i + 1) * (1 + (-1) ** j) / (j + 1) * f(k) * f(i + j + 2) / f(i + j + k + 3)


@pytest.mark.parametrize("family", list(quadrature.RULES))
@pytest.mark.parametrize("n", [1, 2, 3, 5])
def test_rules_integrate_their_degree_exactly_and_not_one_more(family, n):
    xi, w = quadrature.RULES[family](n)

    def errors(degree):
        exps = tetra_exponents(degree)
        exact = np.array([_monomial_integral(family, *e) for e in exps])
        return np.abs(np.array([w @ np.prod(xi ** e, axis=1) for e in exps]) - exact), np.abs(exact)

    err, size = errors(2 * n - 1)
    assert err.max() < 1e-14 * size.max()  # round-off of n^3 products
    err, size = errors(2 * n)  # z^2n, non-zero on every domain, is not integrated exactly
    assert (err / np.where(size > 0, size, 1)).max() > 1e-6


@pytest.mark.parametrize("name", list(ELEMENT_TYPES))
def test_mass_moments_of_a_mapped_box_are_exact(name):
    """1^T Ms 1, x^T Ms 1, x^T Ms x against the mapped box's volume, first and second moments."""
    _, mesh = mapped_mesh(name)
    F = map_of(name)
    Ms = mass_matrix(mesh, 1.0)
    X, one = mesh.points, np.ones(mesh.n_nodes)
    assert abs(one @ Ms @ one / over_box(F, lambda x: np.ones(len(x))) - 1) < TOL
    assert relative(X.T @ (Ms @ one), over_box(F, lambda x: F(x)[0])) < TOL
    assert relative(X.T @ (Ms @ X), over_box(F, lambda x: np.einsum("qi,qj->qij", F(x)[0], F(x)[0]))) < TOL


@pytest.mark.parametrize("name", list(ELEMENT_TYPES))
def test_whole_mass_matrix_on_the_element_space_is_exact(name):
    """The element space holds the polynomials P of the unmapped coordinates, so P^T Ms P = int P P^T dV exactly:
    the mass matrix on every direction of that space, not only its moments."""
    mesh0, mesh = mapped_mesh(name)
    degree = 2 if name in QUADRATIC else 1
    P = monomials(mesh0.points, degree)
    exact = over_box(map_of(name), lambda x: np.einsum("qa,qb->qab", monomials(x, degree), monomials(x, degree)))
    assert relative(P.T @ (mass_matrix(mesh, 1.0) @ P), exact) < TOL


def _element_mass(etype, coords, order):
    xi, w = etype.gauss_rule(order)
    N, dN = etype.shape(xi)
    detJ = np.linalg.det(np.einsum("qna,nb->qab", dN, coords))
    return np.einsum("q,qa,qb->ab", w * detJ, N, N)


@pytest.mark.parametrize("name", list(ELEMENT_TYPES))
def test_mass_rule_has_the_degree_of_a_generic_curved_element(name, rng):
    """Nodes moved at random (every coefficient of the isoparametric map non-zero): the mass rule gives what a
    rule of three more points per direction gives, and one point fewer does not (the stated degree is needed)."""
    e = element_type(name)
    coords = e.ref_nodes + 0.08 * rng.standard_normal(e.ref_nodes.shape)
    M = _element_mass(e, coords, e.mass_order)
    assert np.abs(M - _element_mass(e, coords, e.mass_order + 3)).max() < 1e-13 * np.abs(M).max()  # sums of 500
    assert np.abs(M - _element_mass(e, coords, e.mass_order - 1)).max() > 1e-8 * np.abs(M).max()


# scikit-fem's own assembly of the same elements: its element, its mesh class, its node order against VTK's.
def _skfem_hex_order(element):
    from ffrf_advisor.fe.split import _VERTEX
    return [_VERTEX[tuple(p)] for p in element.doflocs[:8].astype(int)]


def _skfem_case(name):
    import skfem
    cases = {"tetra": (skfem.MeshTet, None, skfem.ElementTetP1, None),
             "tetra10": (skfem.MeshTet, skfem.MeshTet2, skfem.ElementTetP2, None),
             "wedge": (skfem.MeshWedge1, None, skfem.ElementWedge1, None),
             "hexahedron": (skfem.MeshHex, None, skfem.ElementHex1, skfem.ElementHex1),
             "hexahedron20": (skfem.MeshHex, None, skfem.ElementHexS2, skfem.ElementHex1),
             "hexahedron27": (skfem.MeshHex, skfem.MeshHex2, skfem.ElementHex2, skfem.ElementHex1)}
    return cases[name]


def _wedge_rule():
    """Our wedge rule of degree 9 on scikit-fem's reference wedge (z in [0, 1]): scikit-fem 12.0.2's own wedge
    rules put the line's coordinate first and weigh its reference wedge as 0.25 (it is 0.5); ours is checked
    against exact monomial integrals in test_rules_integrate_their_degree_exactly_and_not_one_more."""
    xi, w = quadrature.wedge(5)
    return np.column_stack([xi[:, :2], (xi[:, 2] + 1) / 2]).T, w / 2


SKFEM_TYPES = ["tetra", "tetra10", "wedge", "hexahedron", "hexahedron20", "hexahedron27"]  # no wedge15, no pyramids


def _skfem_matrices(name, mesh0, F):
    """scikit-fem's Ms and K of the same mapped mesh, rows and columns in our node numbering."""
    import skfem
    from scipy.spatial import cKDTree
    from skfem.models.elasticity import lame_parameters, linear_elasticity
    linear_cls, quadratic_cls, element, hex_order = _skfem_case(name)
    corners = {"tetra": "tetra", "tetra10": "tetra", "wedge": "wedge"}.get(name, "hexahedron")
    lin = box_split_mesh(SIZE, DIV, corners)
    conn = lin.cells[corners] if hex_order is None else lin.cells[corners][:, _skfem_hex_order(hex_order)]
    m = linear_cls(lin.points.T.copy(), conn.T.copy())
    if quadratic_cls is not None:
        m = quadratic_cls.from_mesh(m)
    m = type(m)(F(m.doflocs.T)[0].T.copy(), m.t)
    rule = {"quadrature": _wedge_rule()} if corners == "wedge" else {"intorder": 9}
    mass_basis = skfem.Basis(m, element(), **rule)
    Ms = skfem.BilinearForm(lambda u, v, w: u * v).assemble(mass_basis)
    stiff_rule = {"quadrature": _wedge_rule()} if corners == "wedge" else {"intorder": 5}  # affine: degree <= 4
    K = linear_elasticity(*lame_parameters(STEEL.E, STEEL.nu)).assemble(
        skfem.Basis(m, skfem.ElementVector(element()), **stiff_rule))
    order = cKDTree(mass_basis.doflocs.T).query(F(mesh0.points)[0])[1]
    dofs = (3 * order[:, None] + np.arange(3)).ravel()  # skfem's vector DOFs: node-interleaved too
    return Ms[order][:, order], K[dofs][:, dofs]


@pytest.mark.parametrize("name", SKFEM_TYPES)
def test_mass_matrix_is_scikit_fems(name):
    """Entry by entry; scikit-fem integrates with its rule of degree 9 (exact for every mass here: at most 7 on
    tetra10, 9 per axis on hexahedron27; the wedge with ours, ``_wedge_rule``)."""
    F = multilinear if name == "hexahedron20" else map_of(name)  # scikit-fem has no 20-node geometry: trilinear
    mesh0 = box_split_mesh(SIZE, DIV, name)
    Ms_sk, _ = _skfem_matrices(name, mesh0, F)
    Ms = mass_matrix(mesh0.mapped(lambda x: F(x)[0]), 1.0)
    assert abs(Ms - Ms_sk).max() < TOL * abs(Ms).max()


@pytest.mark.parametrize("name", SKFEM_TYPES)
def test_stiffness_of_an_affine_mesh_is_scikit_fems(name):
    """On the affine map both rules are exact (the stiffness integrands are polynomials there)."""
    mesh0 = box_split_mesh(SIZE, DIV, name)
    mesh = mesh0.mapped(lambda x: affine(x)[0])
    _, K_sk = _skfem_matrices(name, mesh0, affine)
    K = stiffness_matrix(mesh, STEEL)
    assert abs(K - K_sk).max() < TOL * abs(K).max()


@pytest.mark.parametrize("name", list(ELEMENT_TYPES))
def test_stiffness_has_exactly_six_rigid_modes(name):
    _, mesh = mapped_mesh(name, (2, 1, 1))
    K = stiffness_matrix(mesh, STEEL).toarray()
    lam = np.linalg.eigvalsh((K + K.T) / 2)
    assert np.all(np.abs(lam[:6]) < 1e-10 * lam[-1])  # rigid: round-off of K's entries (eps times its norm)
    assert lam[6] > 1e-6 * lam[-1]  # the first deformation: no spurious zero-energy mode
    R = rigid_modes(mesh.points)
    assert np.abs(K @ R).max() < 1e-10 * np.abs(K).max() * np.abs(R).max()


def _boundary(points0):
    return np.any(np.isclose(np.abs(points0), SIZE / 2), axis=1)


@pytest.mark.parametrize("name", list(ELEMENT_TYPES))
def test_patch_a_linear_field_gives_constant_strain_and_no_interior_force(name):
    """u = G x + c: the recovered stress is C : sym(G) at every node (the curved mesh included: isoparametric
    elements reproduce linear fields); on a straight-sided distorted mesh K u vanishes at interior nodes."""
    G = np.array([[1.0, 0.3, -0.2], [0.1, -0.5, 0.4], [0.25, 0.05, 0.7]]) * 1e-3
    lam, mu = STEEL.lame
    eps = (G + G.T) / 2
    sigma = 2 * mu * eps + lam * np.trace(eps) * np.eye(3)
    mesh0, mesh = mapped_mesh(name)
    u = mesh.points @ G.T + [0.1, -0.2, 0.3]
    s = nodal_stress(mesh, STEEL, u[:, :, None])[..., 0]
    assert np.abs(s - sigma).max() < 1e-10 * np.abs(sigma).max()
    straight = mesh0.mapped(lambda x: affine(x)[0]) if name in QUADRATIC else mesh
    u = straight.points @ G.T
    f = (stiffness_matrix(straight, STEEL) @ u.ravel()).reshape(-1, 3)
    inner = ~_boundary(mesh0.points)
    assert inner.sum() > 0
    scale = np.abs(sigma).max() * np.prod(SIZE) / np.prod(DIV)  # a cell's stress resultant
    assert np.abs(f[inner]).max() < 1e-11 * scale


def _mixed(kinds_by_cell, div):
    """A box of hexahedral cells, each split into the kind given by kinds_by_cell(ijk)."""
    hexes = box_mesh(SIZE, div, "hexahedron")
    centres = (hexes.points[hexes.cells["hexahedron"]].mean(axis=1) / (SIZE / np.array(div)) + np.array(div) / 2)
    kinds = np.array([kinds_by_cell(np.floor(c).astype(int)) for c in centres])
    cells, points = {}, hexes.points
    for kind in np.unique(kinds):
        part = Mesh(points, {"hexahedron": hexes.cells["hexahedron"][kinds == kind]})
        piece = part if kind == "hexahedron" else split_hexahedra(part, kind)
        extra = piece.points[len(points):]
        conn = piece.cells[kind]
        conn = np.where(conn >= len(part.points), conn - len(part.points) + len(points), conn)
        points = np.vstack([points, extra])
        cells[kind] = conn
    return Mesh(points, cells)


MIXES = {"hexahedra and pyramids": lambda ijk: "pyramid" if ijk.sum() % 2 else "hexahedron",
         "tetrahedra and wedges": lambda ijk: "wedge" if ijk[2] % 2 else "tetra"}


@pytest.mark.parametrize("mix", list(MIXES))
@pytest.mark.parametrize("quad", [False, True])
def test_conforming_mixed_meshes(mix, quad):
    """Hexahedra with pyramids (quadrilateral faces), tetrahedra with wedges in layers (triangular faces):
    exact mass moments, and a free-free solve whose six lowest modes are rigid (a gap would add more)."""
    mesh0 = _mixed(MIXES[mix], (4, 2, 2))
    mesh0 = quadratic(mesh0) if quad else mesh0
    F = curved if quad else affine
    mesh = mesh0.mapped(lambda x: F(x)[0])
    Ms = mass_matrix(mesh, 1.0)
    X, one = mesh.points, np.ones(mesh.n_nodes)
    assert abs(one @ Ms @ one / over_box(F, lambda x: np.ones(len(x))) - 1) < TOL
    assert relative(X.T @ (Ms @ X), over_box(F, lambda x: np.einsum("qi,qj->qij", F(x)[0], F(x)[0]))) < TOL
    modes = free_free_modes(stiffness_matrix(mesh, STEEL), Ms * STEEL.rho, X, 3)
    assert modes.eigenvalues[0] > 1e3 * np.abs(modes.rigid_eigenvalues).max()


def test_element_types_are_named():
    assert set(ELEMENT_TYPES) == {"hexahedron", "hexahedron20", "hexahedron27", "tetra", "tetra10", "wedge",
                                  "wedge15", "pyramid", "pyramid13"}
    with pytest.raises(ValueError, match="tetra10"):
        element_type("tetra4")


def test_a_mirrored_element_is_refused():
    mesh = box_split_mesh(SIZE, (1, 1, 1), "tetra10")
    conn = mesh.cells["tetra10"].copy()
    conn[0] = conn[0][[0, 2, 1, 3, 6, 5, 4, 7, 9, 8]]
    with pytest.raises(ValueError, match="tetra10.*inverted"):
        mass_matrix(Mesh(mesh.points, {"tetra10": conn}), 1.0)


def test_box_split_meshes_have_the_expected_sizes():
    n = box_split_mesh(SIZE, (2, 2, 2), "tetra10")
    assert n.n_cells == 48 and n.n_nodes == 125  # Kuhn: 7 edges per vertex of the 3^3 grid -> every grid point


def _frequencies(name, div, size=(120.0, 50.0, 30.0)):
    mesh = box_split_mesh(size, div, name)
    modes = free_free_modes(stiffness_matrix(mesh, STEEL), mass_matrix(mesh, STEEL.rho), mesh.points, 6)
    return np.sqrt(modes.eigenvalues)


def test_a_tetra10_box_and_a_hexahedron27_box_vibrate_alike():
    """Both are conforming with a consistent mass, so every frequency is an upper bound that falls as the mesh is
    refined, and for quadratic elements (eigenvalue error ~ h^4) it falls by far more than half its error per
    halving: a mesh's error is below its own change from the mesh of twice the size. The two bodies of the same
    cells then differ by less than the larger of those changes."""
    coarse, fine = (4, 2, 1), (8, 4, 2)
    tet = _frequencies("tetra10", coarse), _frequencies("tetra10", fine)
    hexa = _frequencies("hexahedron27", coarse), _frequencies("hexahedron27", fine)
    for f in (tet, hexa):
        assert np.all(f[1] < f[0])
    bound = np.maximum(tet[0] - tet[1], hexa[0] - hexa[1])
    assert np.all(np.abs(tet[1] - hexa[1]) < bound)
    assert np.abs(tet[1] / hexa[1] - 1).max() < 0.01  # 9339 against 9326 Hz for the first


CCX_CASES = [("C3D4", "tetra"), ("C3D10", "tetra10"), ("C3D6", "wedge"), ("C3D15", "wedge15"),
             ("C3D8", "hexahedron"), ("C3D20", "hexahedron20"), ("C3D20R", "hexahedron20")]


@pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (ccx) is not installed")
@pytest.mark.parametrize("ccx_name,name", CCX_CASES)
def test_calculix_rules_give_its_stored_matrices_and_ours_the_exact_mass(ccx_name, name, tmp_path):
    """CalculiX's .mas/.sti of a curved mesh (its *FREQUENCY, SOLVER=MATRIXSTORAGE) are ours with its rules
    (fe.code_rules.CALCULIX) to 1e-12 (the files print 14 digits). Every one of its rules is below the degree of
    the curved mass, so our exact mass differs from its .mas, with the same total."""
    from ffrf_advisor.fe.code_rules import CALCULIX
    from ffrf_advisor.io.calculix_deck import write_deck
    mesh = box_split_mesh([60.0, 30.0, 20.0], (3, 2, 1), name).mapped(
        lambda x: x + np.column_stack([2e-3 * x[:, 1] ** 2 + 1e-3 * x[:, 1] * x[:, 2], 1.6e-3 * x[:, 0] * x[:, 2],
                                       3.5e-4 * x[:, 0] ** 2 + 7e-4 * x[:, 0] * x[:, 1]]))
    write_deck(mesh, STEEL, 2, tmp_path / "job.inp", matrix_storage=True)
    deck = (tmp_path / "job.inp").read_text()
    (tmp_path / "job.inp").write_text(deck.replace(f"TYPE={ccx_name.rstrip('R')},", f"TYPE={ccx_name},"))
    done = subprocess.run(["ccx", "job"], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert "Job finished" in done.stdout, done.stdout[-500:]
    M, K = (_calculix_matrix(tmp_path / "job", suffix, mesh.n_nodes) for suffix in (".mas", ".sti"))
    rules = {name: CALCULIX[ccx_name][1]}
    Ms = M[0::3, 0::3]
    assert abs(mass_matrix(mesh, STEEL.rho, rules=rules) - Ms).max() < 1e-12 * abs(Ms).max()
    assert abs(stiffness_matrix(mesh, STEEL, rules=rules) - K).max() < 1e-12 * abs(K).max()
    exact = mass_matrix(mesh, STEEL.rho)
    assert abs(exact - Ms).max() > 1e-6 * abs(Ms).max()
    assert abs(exact.sum() / Ms.sum() - 1) < 1e-12


def _calculix_matrix(stem, suffix, n):
    """A .mas or .sti (upper triangle, 1-based rows of the .dof's node.direction labels) as a full matrix."""
    labels = [w.split(".") for w in stem.with_suffix(".dof").read_text().split()]
    rows = np.array([3 * (int(a) - 1) + int(b) - 1 for a, b in labels])
    i, j, v = np.loadtxt(stem.with_suffix(suffix), ndmin=2).T
    i, j = rows[i.astype(int) - 1], rows[j.astype(int) - 1]
    off = i != j
    return sp.coo_array((np.r_[v, v[off]], (np.r_[i, j[off]], np.r_[j, i[off]])), shape=(3 * n, 3 * n)).tocsr()


def test_a_box_union_of_tetrahedra_is_refused_with_the_way_forward():
    with pytest.raises(ValueError, match="tetra10.*box_split_mesh"):
        box_mesh(SIZE, DIV, "tetra10")


@pytest.mark.parametrize("name", list(ELEMENT_TYPES))
def test_faces_point_outward_and_the_boundary_of_a_box_is_its_six_sides(name):
    """Each face's normal (Newell's, over its ring) points away from the reference element's centroid; on a box
    split into the type, the faces that occur once are the box's outer faces, covering its area."""
    from ffrf_advisor.fe.elements import element_faces
    e = element_type(name)
    centre = e.ref_nodes.mean(axis=0)
    for face in element_faces(name):
        ring = e.ref_nodes[list(face)]
        normal = np.cross(ring, np.roll(ring, -1, axis=0)).sum(axis=0)
        assert normal @ (ring.mean(axis=0) - centre) > 0, face
    mesh = box_split_mesh(SIZE, DIV, name)
    faces = [mesh.cells[name][:, list(f)] for f in element_faces(name)]
    keys = [tuple(sorted(row)) for block in faces for row in block]
    once = [k for k in set(keys) if keys.count(k) == 1]
    assert set(keys) and all(keys.count(k) <= 2 for k in set(keys))  # conforming: no face shared by three
    X = mesh.points
    on_side = [np.any(np.all(np.isclose(np.abs(X[list(k)]), SIZE / 2), axis=0)) for k in once]
    assert all(on_side)
    area = sum(0.5 * np.linalg.norm(np.cross(X[list(r)], X[np.roll(list(r), -1)]).sum(axis=0))
               for block in faces for r in block if tuple(sorted(r)) in set(once))
    assert abs(area / (2 * (SIZE[0] * SIZE[1] + SIZE[1] * SIZE[2] + SIZE[0] * SIZE[2])) - 1) < 1e-12
