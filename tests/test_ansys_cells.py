"""MAPDL elements as cells (io.ansys_cells): the meshes ansys-mapdl-reader ships (TetBeam.cdb: 3913 SOLID187
written with their corners only; sector.cdb: 101 SOLID185 bricks and 4 degenerate prisms; HexBeam.cdb: 40
SOLID186 bricks), every degenerate form of SOLID185/186 built on unit cubes, their corner stresses, and the
element types refused by name. Masses are checked against integrals that do not use the elements: the
divergence theorem on the mesh's boundary faces, or the cube's own."""
from __future__ import annotations

import itertools
import re
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from typer.testing import CliRunner

reader = pytest.importorskip("ansys.mapdl.reader", reason="the ANSYS reader's optional extra (pip install '.[ansys]')")

from ansys.mapdl.reader import examples  # noqa: E402

from ffrf_advisor.checks import run_checks  # noqa: E402
from ffrf_advisor.cli import app  # noqa: E402
from ffrf_advisor.errors import BodyFileError  # noqa: E402
from ffrf_advisor.fe.assembly import full_mass, mass_matrix, stiffness_matrix  # noqa: E402
from ffrf_advisor.fe.material import Material  # noqa: E402
from ffrf_advisor.fe.mesh import Mesh  # noqa: E402
from ffrf_advisor.io import ansys  # noqa: E402
from ffrf_advisor.io.ansys_cells import cells_of, refuse_unreadable  # noqa: E402
from ffrf_advisor.io.ansys_fe import nodal_von_mises  # noqa: E402
from ffrf_advisor.io.ansys_files import AnsysRun, _corner_stress  # noqa: E402
from ffrf_advisor.io.limits import Budget  # noqa: E402

EXAMPLES = Path(examples.__file__).parent
ROUND_OFF = 1e-12  # sums over a few thousand elements' quadrature points in double precision: ~1e-14, margin 100
ZERO_MODE = 1e-10  # a rigid mode's K eigenvalue against the largest: round-off of the assembly
FACES = {"tetra": [(0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2)],  # corner indices, outward by the right hand
         "pyramid": [(0, 3, 2, 1), (0, 1, 4), (1, 2, 4), (2, 3, 4), (3, 0, 4)],
         "wedge": [(0, 2, 1), (3, 4, 5), (0, 1, 4, 3), (1, 2, 5, 4), (2, 0, 3, 5)],
         "hexahedron": [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]}
runner = CliRunner()


def _archive(name: str):
    """Points sorted by node number, the node numbers, and the archive's element rows and routines."""
    a = reader.Archive(str(EXAMPLES / name), parse_vtk=False)
    order = np.argsort(a.nnum)
    return np.asarray(a.nodes, float)[order, :3], np.asarray(a.nnum)[order], a.elem, np.asarray(a.etype)


def _boundary_moments(points: np.ndarray, cells: dict[str, np.ndarray]) -> tuple[float, np.ndarray, np.ndarray]:
    """Volume, first moments and second moments int x_k x_l dV of straight-edged cells by the divergence
    theorem on the faces met once (each a bilinear patch of its corners, a triangle as one with a corner twice;
    4 x 4 Gauss points integrate the degree-4 integrands exactly): V = int x.n / 3, int x_k = int x_k^2 n_k / 2,
    int x_k^2 = int x_k^3 n_k / 3, int x_k x_l = int x_k x_l x_m n_m (m the third axis)."""
    count: dict[tuple, list] = {}
    for kind, conn in cells.items():
        base = kind.rstrip("0123456789")
        for face in FACES[base]:
            for corners in conn[:, face]:
                count.setdefault(tuple(sorted(corners)), []).append(corners)
    t, w = np.polynomial.legendre.leggauss(4)
    u, v = np.meshgrid((t + 1) / 2, (t + 1) / 2, indexing="ij")
    u, v, wt = u.ravel(), v.ravel(), np.outer(w, w).ravel() / 4
    V, m1, m2 = 0.0, np.zeros(3), np.zeros((3, 3))
    for faces in count.values():
        if len(faces) != 1:
            continue
        c = points[list(faces[0]) + ([faces[0][-1]] if len(faces[0]) == 3 else [])]
        x = np.outer((1 - u) * (1 - v), c[0]) + np.outer(u * (1 - v), c[1]) + np.outer(u * v, c[2]) \
            + np.outer((1 - u) * v, c[3])
        xu = np.outer(1 - v, c[1] - c[0]) + np.outer(v, c[2] - c[3])
        xv = np.outer(1 - u, c[3] - c[0]) + np.outer(u, c[2] - c[1])
        n = np.cross(xu, xv) * wt[:, None]
        V += np.sum(x * n) / 3
        m1 += np.sum(x**2 * n, axis=0) / 2
        for k, l in itertools.product(range(3), repeat=2):
            m2[k, l] += np.sum(x[:, k]**3 * n[:, k]) / 3 if k == l else np.sum(x[:, k] * x[:, l] * x[:, 3 - k - l]
                                                                                * n[:, 3 - k - l])
    return V, m1, m2


def _mass_moments(Ms, X: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """The nodal sums of theory 3: 1^T Ms 1, X^T Ms 1, X^T Ms X (exact for the isoparametric x)."""
    return float(Ms.sum()), X.T @ (Ms @ np.ones(len(X))), X.T @ (Ms @ X)


def _assert_moments(got, want) -> None:
    for g, w in zip(got, want):
        assert np.abs(np.asarray(g) - w).max() <= ROUND_OFF * np.abs(want[2]).max(), (g, w)


# ---------------------------------------------------------------- the meshes the package ships
@pytest.mark.parametrize("name,kinds", [("TetBeam.cdb", {"tetra": 3913}),
                                        ("sector.cdb", {"hexahedron": 101, "wedge": 4})])
def test_the_shipped_meshes_give_the_mass_of_their_boundary(name, kinds):
    X, nodes, elem, routines = _archive(name)
    cells, rows = cells_of(name, elem, routines, nodes)
    assert {t: len(c) for t, c in cells.items()} == kinds
    assert sorted(np.concatenate(list(rows.values()))) == list(range(len(elem)))  # every element once
    _assert_moments(_mass_moments(mass_matrix(Mesh(X, cells), 1.0), X), _boundary_moments(X, cells))


def test_the_shipped_prisms_are_those_with_repeated_nodes_k_l_and_o_p():
    X, nodes, elem, routines = _archive("sector.cdb")
    cells, rows = cells_of("sector.cdb", elem, routines, nodes)
    for conn, k in zip(cells["wedge"], rows["wedge"]):
        listed = np.asarray(elem[k][10:])
        assert listed[2] == listed[3] and listed[6] == listed[7]
        assert np.array_equal(nodes[conn], listed[[0, 1, 2, 4, 5, 6]])


def test_the_shipped_solid186_bar_has_the_box_mass_and_moments():
    X, nodes, elem, routines = _archive("HexBeam.cdb")
    cells, _ = cells_of("HexBeam.cdb", elem, routines, nodes)
    lo, hi = X.min(axis=0), X.max(axis=0)  # a 1 x 1 x 5 box of straight 20-node bricks
    V = np.prod(hi - lo)
    mean = (hi + lo) / 2
    second = V * (np.outer(mean, mean) + np.diag((hi - lo) ** 2 / 12))
    _assert_moments(_mass_moments(mass_matrix(Mesh(X, cells), 1.0), X), (V, V * mean, second))


# ---------------------------------------------------------------- every degenerate form on a unit cube
CUBE = np.array(list(itertools.product((0, 1), repeat=3)))[:, ::-1].astype(float)  # x fastest
A0, B0, C0, D0 = (0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)
A1, B1, C1, D1 = (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)
EDGES20 = [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)]


def _bricks(form: str) -> list[list[tuple]]:
    """The unit cube in one form, each element as MAPDL lists it: the brick's eight corners I..P, repeated."""
    if form == "brick":
        return [[A0, B0, C0, D0, A1, B1, C1, D1]]
    if form == "prism":
        return [[A0, B0, C0, C0, A1, B1, C1, C1], [A0, C0, D0, D0, A1, C1, D1, D1]]
    centre = (0.5, 0.5, 0.5)
    if form == "pyramid":  # a pyramid on each face, apex at the centre, base turned towards it
        bases = [(A0, B0, C0, D0), (A1, D1, C1, B1), (A0, D0, D1, A1), (B0, B1, C1, C0), (A0, A1, B1, B0),
                 (D0, C0, C1, D1)]
        return [[*b, centre, centre, centre, centre] for b in bases]
    tets = []  # Kuhn's six tetrahedra along the diagonal A0-C1
    for p in itertools.permutations(range(3)):
        v = [np.zeros(3)]
        for axis in p:
            v.append(v[-1] + np.eye(3)[axis])
        a, b, c, d = (tuple(x) for x in v)
        if np.linalg.det(np.array([b, c, d]) - np.array(a)) < 0:
            b, c = c, b
        tets.append([a, b, c, c, d, d, d, d])
    return tets


def _elements(form: str, quadratic: bool, apex_in_s: bool = False, cubes: int = 1):
    """Points, node numbers and MAPDL element rows (10 header words, then the nodes) of ``cubes`` unit cubes in a
    row along x in ``form``; SOLID186 lists the mid-points of the brick's edges (a collapsed edge's is its node).
    ``apex_in_s``: a tetrahedron's S written with its apex, as MAPDL's own archives hold it."""
    numbers: dict[tuple, int] = {}
    rows = []
    bricks = [np.array(b, float) + (i, 0, 0) for i in range(cubes) for b in _bricks(form)]
    for k, c in enumerate(bricks):
        pts = list(c) + ([(c[a] + c[b]) / 2 for a, b in EDGES20] if quadratic else [])
        listed = [numbers.setdefault(tuple(np.round(p, 9)), len(numbers) + 1) for p in pts]
        if apex_in_s:
            listed[10] = listed[4]
        rows.append(np.array([1, 1, 1, 1, 0, 0, 0, 0, k + 1, 0, *listed]))
    X = np.array(list(numbers), float)
    return X, np.arange(1, len(X) + 1), rows, np.full(len(rows), 186 if quadratic else 185)


KINDS = {"brick": ("hexahedron", "hexahedron20"), "prism": ("wedge", "wedge15"), "pyramid": ("pyramid", "pyramid13"),
         "tetrahedron": ("tetra", "tetra10")}
STEEL = Material("steel", 210e3, 0.3, 7.85e-9)


@pytest.mark.parametrize("quadratic", [False, True], ids=["SOLID185", "SOLID186"])
@pytest.mark.parametrize("form", list(KINDS))
def test_each_form_fills_the_cube_and_moves_only_rigidly_without_strain(form, quadratic):
    """The cube's mass and moments (1, 1/2, 1/3 and 1/4); K with exactly six zero eigenvalues (a node out of
    place leaves a mechanism or a gap) and the energy of a uniform strain: V (lambda tr(e)^2 + 2 mu e:e)."""
    X, nodes, elem, routines = _elements(form, quadratic)
    cells, _ = cells_of("cube", elem, routines, nodes)
    assert list(cells) == [KINDS[form][quadratic]]
    _assert_moments(_mass_moments(mass_matrix(Mesh(X, cells), 1.0), X),
                    (1.0, np.full(3, 0.5), np.full((3, 3), 0.25) + np.eye(3) / 12))
    K = stiffness_matrix(Mesh(X, cells), STEEL).toarray()
    lam = np.linalg.eigvalsh(K)
    assert np.sum(lam < ZERO_MODE * lam[-1]) == 6 and lam[6] > 1e-6 * lam[-1]
    e = np.array([[1.0, 0.2, -0.1], [0.2, -0.5, 0.3], [-0.1, 0.3, 0.7]]) * 1e-3
    u = (X @ e).ravel()
    lame, mu = STEEL.lame
    assert u @ K @ u == pytest.approx(lame * np.trace(e) ** 2 + 2 * mu * np.sum(e * e), rel=ROUND_OFF)


def test_a_tetrahedron_with_its_apex_in_s_reads_as_mapdl_writes_it():
    X, nodes, elem, routines = _elements("tetrahedron", True, apex_in_s=True)
    cells, _ = cells_of("cube", elem, routines, nodes)
    assert list(cells) == ["tetra10"] and mass_matrix(Mesh(X, cells), 1.0).sum() == pytest.approx(1, ROUND_OFF)


def test_solid187_with_and_without_mid_side_nodes():
    X, nodes, elem, _ = _elements("tetrahedron", True)
    tet10 = [np.r_[e[:10], e[10:][[0, 1, 2, 4, 8, 9, 11, 16, 17, 18]]] for e in elem]  # I J K L, then M..R
    cells, _ = cells_of("cube", tet10, np.full(len(elem), 187), nodes)
    assert mass_matrix(Mesh(X, cells), 1.0).sum() == pytest.approx(1, ROUND_OFF) and list(cells) == ["tetra10"]
    cells, _ = cells_of("cube", [e[:14] for e in tet10], np.full(len(elem), 187), nodes)
    assert list(cells) == ["tetra"] and mass_matrix(Mesh(X, cells), 1.0).sum() == pytest.approx(1, ROUND_OFF)


def test_point_masses_and_mesh_only_elements_make_no_cells():
    X, nodes, elem, routines = _elements("brick", False)
    mass = np.array([1, 2, 1, 1, 0, 0, 0, 0, 9, 0, 3])  # MASS21 on node 3
    cells, rows = cells_of("cube", [*elem, mass, mass], np.r_[routines, 21, 200], nodes)
    assert list(cells) == ["hexahedron"] and rows["hexahedron"].tolist() == [0]


@pytest.mark.parametrize("change,field", [
    (lambda e: e.__setitem__(13, e[12]), "SOLID185 element 1: expected a brick or one of MAPDL's degenerate"),  # K=L
    (lambda e: e.__setitem__(15, 0), "SOLID185 element 1: expected every node of the element"),
    (lambda e: e.__setitem__(15, 99), "elements: expected element nodes among the nodes, got node 99")])
def test_a_form_mapdl_does_not_define_is_refused_naming_the_element(change, field):
    X, nodes, elem, routines = _elements("brick", False)
    change(elem[0])
    with pytest.raises(BodyFileError, match="cube: " + field.replace("(", r"\(")):
        cells_of("cube", elem, routines, nodes)


# ---------------------------------------------------------------- element types refused by name
def test_shells_beams_and_rotary_masses_are_refused_by_name():
    with pytest.raises(BodyFileError) as e:
        refuse_unreadable("a.rst", ["SOLID187", "SHELL181", "BEAM188", "BEAM188", "MPC184"], ["UX", "UY", "UZ", "ROTX"])
    assert "got BEAM188 (2 elements), MPC184 (1 elements), SHELL181 (1 elements)" in str(e.value)
    assert "Nastran run" in str(e.value)
    with pytest.raises(BodyFileError, match=r"a\.rst: DOFs: .* got MASS21 with rotary inertia \(KEYOPT\(3\)=0\)"):
        refuse_unreadable("a.rst", ["SOLID186", "MASS21"], ["UX", "UY", "UZ", "ROTX", "ROTY", "ROTZ"])
    refuse_unreadable("a.rst", ["SOLID186", "MASS21", "MESH200"], ["UX", "UY", "UZ"])  # read


@pytest.mark.parametrize("routine,name", [(181, "SHELL181"), (281, "SHELL281"), (188, "BEAM188"),
                                          (189, "BEAM189")])
def test_the_cli_refuses_a_run_of_shells_or_beams_in_one_line_naming_them(tmp_path, routine, name):
    """The shipped run with its element type's routine rewritten (ETY record: type number 1, then 186)."""
    for suffix in ("rst", "full"):
        shutil.copy(EXAMPLES / f"file.{suffix}", tmp_path / f"job.{suffix}")
    words = np.fromfile(tmp_path / "job.rst", "<i4")
    r = reader.read_binary(str(tmp_path / "job.rst"))
    start = int(r._geometry_header["ptrETY"])
    at = start + next(i for i in range(len(words) - start) if words[start + i - 1] == 1 and words[start + i] == 186)
    words[at] = routine
    words.tofile(tmp_path / "job.rst")
    result = runner.invoke(app, ["info", str(tmp_path / "job.rst")])
    line = result.output.strip()
    assert result.exit_code == 2 and "\n" not in line, result.output
    assert "job.rst: element types: expected SOLID185, SOLID186, SOLID187" in line
    assert f"got {name} (40 elements)" in line


# ---------------------------------------------------------------- runs through the reader
def _run(name: str, X: np.ndarray, nodes: np.ndarray, elem, routines: np.ndarray, k: int = 14):
    """A free-free run of steel (lengths taken in m) as MAPDL would write it: the .full's M and K the elements'
    own (fe.assembly, consistent), the modes the first ``k`` of that free problem (six rigid), no element
    stresses (no MAPDL is at hand to write such files); and the boundary's volume and moments. Nodes no element
    uses (sector.cdb has 425) are left out: they have no DOFs in a .full."""
    cells, _ = cells_of(name, elem, routines, nodes)
    used = np.unique(np.concatenate([c.ravel() for c in cells.values()]))
    X, nodes = X[used], nodes[used]
    cells, rows = cells_of(name, elem, routines, nodes)
    steel = Material("steel", 2.1e11, 0.3, 7850.0)
    M, K = full_mass(mass_matrix(Mesh(X, cells), steel.rho)), stiffness_matrix(Mesh(X, cells), steel)
    lam, V = spla.eigsh(sp.csc_array(K), k=k, M=sp.csc_array(M), sigma=-1.0)
    names = [f"SOLID{int(t)}" for t in routines]
    run = AnsysRun(source=name, full=name.replace(".rst", ".full"), nodes=nodes, points=X, cells=cells,
                   cell_material={t: np.ones(len(c), np.int64) for t, c in cells.items()},
                   cell_numbers={t: np.array([elem[k][8] for k in r]) for t, r in rows.items()},
                   element_types={t: names.count(t) for t in set(names)},
                   materials={1: {"EX": 2.1e11, "NUXY": 0.3, "DENS": 7850.0}}, cell_materials={1},
                   units="User Defined", eigenvalues=lam, modes=V.reshape(len(X), 3, -1), corner_stress=None,
                   M=sp.csr_array(M), K=sp.csr_array(K), constrained=np.zeros(3 * len(X), bool))
    return run, _boundary_moments(X, cells)


@pytest.fixture(scope="module")
def tet_run():
    """The shipped TetBeam mesh (3913 SOLID187, a 10 x 1 x 1 bar) as a run."""
    return _run("tet.rst", *_archive("TetBeam.cdb"))


def _agreement(body) -> float:
    """The note's relative difference of the .full's mass, centre and second moments from the elements'."""
    return float(re.search(r"second moments within (\S+)", " ".join(body.provenance.notes)).group(1))


def _inertia(rho: float, moments, extra=None) -> np.ndarray:
    """Principal moments of inertia about the centre of mass from int 1, int x, int x x^T (and point masses)."""
    V, m1, m2 = (rho * np.asarray(q) for q in moments)
    if extra is not None:
        m, x = extra
        V, m1, m2 = V + m, m1 + m * x, m2 + m * np.outer(x, x)
    S = m2 - np.outer(m1, m1) / V
    return np.linalg.eigvalsh(np.trace(S) * np.eye(3) - S)


def test_a_solid187_run_reads_with_its_mass_inertia_and_frequencies(tet_run):
    run, moments = tet_run
    body = _read_and_checked(run, moments, "3913 tetra")
    assert body.mass == pytest.approx(7850.0 * 10.0, rel=ROUND_OFF)  # the 10 x 1 x 1 box the mesh fills


@pytest.mark.parametrize("form,cells", [("prism", "12 wedge15"), ("pyramid", "36 pyramid13"),
                                        ("tetrahedron", "36 tetra10")])
def test_a_run_of_degenerate_solid186_reads_with_the_bar_s_mass_and_inertia(form, cells):
    """Six unit cubes in a row, each split into one degenerate SOLID186 form, as a run."""
    body = _read_and_checked(*_run("bar.rst", *_elements(form, True, cubes=6)), cells)
    assert body.mass == pytest.approx(7850.0 * 6.0, rel=ROUND_OFF)


def test_a_run_of_solid185_bricks_and_prisms_reads_with_the_mass_of_its_boundary():
    _read_and_checked(*_run("sector.rst", *_archive("sector.cdb")), "101 hexahedron, 4 wedge")


def _read_and_checked(run, moments, cells: str):
    """The run through the reader: every check passing, I0 the boundary's, the run's flexible eigenvalues, the
    cells named, the mass note agreeing, the static centrifugal response there and no stresses."""
    body = ansys.body_of(run.source, run)
    assert [c.name for c in run_checks(body) if not c.passed] == []
    assert body.mass == pytest.approx(7850.0 * moments[0], rel=ROUND_OFF)
    assert np.allclose(np.linalg.eigvalsh(body.I0), _inertia(7850.0, moments), rtol=ROUND_OFF)
    assert np.allclose(body.eigenvalues, run.eigenvalues[6:], rtol=ROUND_OFF)  # the six rigid modes dropped
    notes = " ".join(body.provenance.notes)
    assert f"cells {cells}" in notes and f"K of {run.full}: the free body's" in notes
    assert _agreement(body) <= ROUND_OFF and "warning" not in notes  # straight elements: exact both ways
    assert body.static_centrifugal is not None and body.fe.stress_nodal is None
    return body


def test_a_point_mass_in_the_full_is_read_and_named(tet_run):
    """MASS21 without rotary inertia adds m to UX, UY, UZ of its node in the .full's M (the kron form)."""
    run, moments = tet_run
    node, m = int(np.argmax(run.points[:, 0])), 500.0
    M = run.M + sp.csr_array((np.full(3, m), (3 * node + np.arange(3), 3 * node + np.arange(3))), shape=run.M.shape)
    lam, V = spla.eigsh(sp.csc_array(run.K), k=12, M=sp.csc_array(M), sigma=-1.0)
    body = ansys.body_of("tet.rst", replace(run, M=M, eigenvalues=lam, modes=V.reshape(len(run.points), 3, -1),
                                           element_types={"SOLID187": 3913, "MASS21": 1}))
    assert body.mass == pytest.approx(7850.0 * 10.0 + m, rel=ROUND_OFF)
    assert np.allclose(np.linalg.eigvalsh(body.I0), _inertia(7850.0, moments, (m, run.points[node])), rtol=ROUND_OFF)
    assert "its solid elements' 78500 of it, 500 the .full's own from 1 MASS21" in " ".join(body.provenance.notes)


def test_an_anisotropic_point_mass_is_refused_naming_mass21(tet_run):
    run, _ = tet_run
    M = run.M + sp.csr_array(([500.0], ([0], [0])), shape=run.M.shape)  # MASSX only
    with pytest.raises(BodyFileError, match=r"tet\.full: mass matrix: expected the form kron\(Ms, I3\) of solid "
                       "elements and MASS21 with MASSX = MASSY = MASSZ"):
        ansys.body_of("tet.rst", replace(run, M=M, element_types={"SOLID187": 3913, "MASS21": 1}))


def test_elements_that_do_not_give_the_full_s_mass_are_named_in_a_warning(tet_run):
    """DENS twice what the .full's M holds: the elements' mass is twice the .full's; the .full's is used."""
    run, moments = tet_run
    body = ansys.body_of("tet.rst", replace(run, materials={1: {**run.materials[1], "DENS": 2 * 7850.0}}))
    assert body.mass == pytest.approx(7850.0 * moments[0], rel=ROUND_OFF)
    assert _agreement(body) == pytest.approx(1, abs=0.01) and "(warning: the elements are not the .full's model)" \
        in body.provenance.notes[5]


def test_an_inverted_element_is_refused_in_one_line(tet_run):
    """Before the elements' K or G is assembled (fe.assembly would raise a ValueError)."""
    run, _ = tet_run
    conn = run.cells["tetra"].copy()
    conn[7, [1, 2]] = conn[7, [2, 1]]
    with pytest.raises(BodyFileError, match=r"tet\.rst: elements: expected elements with a positive Jacobian "
                       r"\(MAPDL's node order\), got element 8 \(tetra\) inverted"):
        ansys.body_of("tet.rst", replace(run, cells={"tetra": conn}))


# ---------------------------------------------------------------- corner stresses of every form
class _Stresses:
    """A result's element stresses as ansys-mapdl-reader returns them: per element (by number) the six
    components at its first listed nodes (8 for SOLID185/186 in every form, 4 for SOLID187) with those nodes;
    here the uniaxial field SX = x (a linear field: a mid-edge node's value is its edge's mean)."""

    def __init__(self, X, nodes, elem, routines):
        self.rows = [(e[8], e[10:10 + (4 if t == 187 else 8)]) for e, t in zip(elem, routines)]
        self.x = dict(zip(nodes.tolist(), X[:, 0]))

    def element_stress(self, mode: int):
        rows = sorted(self.rows, key=lambda r: r[0])
        values = [np.array([[self.x[int(n)], 0, 0, 0, 0, 0] for n in listed]) for _, listed in rows]
        return np.array([r[0] for r in rows]), values, [np.asarray(listed) for _, listed in rows]


@pytest.mark.parametrize("mesh", ["TetBeam.cdb", "sector.cdb", "prism", "pyramid", "tetrahedron", "solid187"])
def test_corner_stresses_of_every_form_give_the_field_at_every_node(mesh):
    """The nodal von Mises of SX = x is |x| at every node, mid-edge nodes included: each cell's corners
    picked from the element's listed nodes, mid-edge values from their edge's corners."""
    if mesh.endswith(".cdb"):
        X, nodes, elem, routines = _archive(mesh)
    else:
        X, nodes, elem, routines = _elements("tetrahedron" if mesh == "solid187" else mesh, True, cubes=3)
        if mesh == "solid187":
            elem = [np.r_[e[:10], e[10:][[0, 1, 2, 4, 8, 9, 11, 16, 17, 18]]] for e in elem]
            routines = np.full(len(elem), 187)
        X = X - (1.5, 0.0, 0.0)  # SX changes sign inside the bar
    cells, rows = cells_of(mesh, elem, routines, nodes)
    enum = np.array([e[8] for e in elem])
    stress = _corner_stress(mesh, _Stresses(X, nodes, elem, routines), cells, rows, enum, nodes, 1, Budget(mesh))
    run = replace(_run_stub(X, cells), corner_stress=stress)
    used = np.unique(np.concatenate([c.ravel() for c in cells.values()]))
    vm = nodal_von_mises(run, np.eye(1))[:, 0]
    # corner stresses are kept in float32, as the file holds them: 6e-8 of the largest
    assert np.abs(vm[used] - np.abs(X[used, 0])).max() < 1e-6 * np.abs(X[:, 0]).max()


def _run_stub(X: np.ndarray, cells: dict) -> AnsysRun:
    """A run holding only what nodal_von_mises reads: points and cells."""
    empty = sp.csr_array((0, 0))
    return AnsysRun(source="", full="", nodes=np.arange(len(X)), points=X, cells=cells, cell_material={},
                    cell_numbers={}, element_types={}, materials={}, cell_materials=set(), units="",
                    eigenvalues=np.zeros(1), modes=np.zeros((len(X), 3, 1)), corner_stress=None, M=empty, K=empty,
                    constrained=np.zeros(0, bool))
