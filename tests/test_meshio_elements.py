"""meshio bodies of every cell type the reader carries: solids with the built-in solver's modes, shells and
beams with mode rotations, point masses; what has no data or no mass is refused or named."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from ffrf_advisor.checks import density_warnings, run_checks
from ffrf_advisor.cli import app
from ffrf_advisor.errors import BodyFileError
from ffrf_advisor.fe.material import STEEL
from ffrf_advisor.fe.assembly import mass_matrix, stiffness_matrix
from ffrf_advisor.fe.mesh import Mesh, box_mesh
from ffrf_advisor.fe.modal import free_free_modes
from ffrf_advisor.fe.split import box_split_mesh
from ffrf_advisor.fe.structural import BeamSection, StructuralMass, beam_mass, point_mass, shell_mass
from ffrf_advisor.fe_body import modal_body
from ffrf_advisor.io import read_body, write_body
from ffrf_advisor.io.meshio_modes import meshio_module
from tests.test_structural import grid

runner = CliRunner()
SIZE = np.array([40.0, 20.0, 10.0])
SOLIDS = ["tetra", "tetra10", "wedge", "wedge15", "pyramid", "pyramid13", "hexahedron", "hexahedron20",
          "hexahedron27"]
ROUND = 1e-12  # sums over a few hundred nodes and elements of one sign, the modes' rescaling: ~1e3 eps
LAM = np.array([1.0e6, 2.5e6, 4.0e6])


def _write(path: Path, points, cells, modes, rotations=None, cell_data=None) -> Path:
    """A VTU file of the cells with modes (n, 3, nf) and optional rotations as point data."""
    point_data = {f"mode_{p + 1}": modes[:, :, p] for p in range(modes.shape[2])}
    if rotations is not None:
        point_data |= {f"rotation_{p + 1}": rotations[:, :, p] for p in range(modes.shape[2])}
    meshio = meshio_module()  # wedge15 and pyramid13 need it
    meshio.write(path, meshio.Mesh(points, cells, point_data=point_data, cell_data=cell_data or {}))
    return path


def _principal(I0: np.ndarray) -> np.ndarray:
    return np.sort(np.linalg.eigvalsh(I0))


def _box_inertia(m: float, size) -> np.ndarray:
    a, b, c = size
    return np.sort(m / 12 * np.array([b * b + c * c, a * a + c * c, a * a + b * b]))


def _same_invariants(body, ref) -> None:
    """W1, W2, W3 of the body read as the solver's, against their scales (theory 3, Cauchy-Schwarz: |W1| <=
    2 sqrt(trace I0), |W2|, |W3| <= 2): the modes' rescaling and the reassembled mass leave ~1e-15 of them; a box's
    W1 is itself near round-off, so no relative comparison."""
    scale = {"W1": np.sqrt(np.trace(ref.I0)), "W2": 1.0, "W3": 1.0}
    for name, size in scale.items():
        assert np.abs(getattr(body, name) - getattr(ref, name)).max() <= 1e-12 * size, name


def _passes(body) -> None:
    failed = [(c.name, c.value) for c in run_checks(body) if not c.passed]
    assert not failed, failed


@pytest.mark.parametrize("cell_type", SOLIDS)
def test_solid_cells_read_with_their_mass(tmp_path, cell_type):
    """The built-in solver's free-free modes of a 40 x 20 x 10 box of each solid type, scaled and moved, with an
    edge and a point of the mesh as cells without data: the mass rho V and the box's I0 (exact: the consistent
    mass integrates x x^T exactly), the invariants of the solver's body, every check passing, and the edge and
    point named."""
    mesh = (box_mesh if cell_type.startswith("hexahedron") else box_split_mesh)(SIZE, (2, 1, 1), cell_type)
    ref = modal_body(mesh, STEEL, 3)
    first = ref.fe.mesh.cells[cell_type][0]
    cells = [*ref.fe.mesh.cells.items(), ("line", first[None, :2]), ("vertex", first[None, :1])]
    path = _write(tmp_path / f"{cell_type}.vtu", ref.fe.mesh.points + [10.0, 20.0, 30.0], cells,
                  ref.fe.Phi * np.array([2.0, -3.0, 0.5]))
    body = read_body(path, eigenvalues=ref.eigenvalues, density=STEEL.rho)
    mass = STEEL.rho * SIZE.prod()
    assert body.mass == pytest.approx(mass, rel=ROUND)
    assert _principal(body.I0) == pytest.approx(_box_inertia(mass, SIZE), rel=ROUND)
    _same_invariants(body, ref)
    _passes(body)
    assert "cells without mass of their own: 1 line, 1 vertex (no area/mass data" in " ".join(body.provenance.notes)


def _rigid6(points: np.ndarray) -> np.ndarray:
    """The six rigid-body modes of 6-DOF nodes (n, 6, 6): translations e_k; rotations e_k x x with rotation e_k."""
    R = np.zeros((len(points), 6, 6))
    for k in range(3):
        R[:, k, k] = 1.0
        R[:, :3, 3 + k] = np.cross(np.eye(3)[k], points)
        R[:, 3 + k, 3 + k] = 1.0
    return R


def _synthetic_modes(points: np.ndarray, mass: StructuralMass, nf: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Smooth translation and rotation fields made M-orthogonal to the rigid modes and to each other with the
    6-DOF mass (theory 3b), so the free-surface checks hold; scaled by 2, 3, 4 (the reader normalises them)."""
    x = (points - points.mean(axis=0)) / np.ptp(points, axis=0).max()
    V = np.stack([np.concatenate([np.cos((3 + p) * x @ [1.0, 0.4, 0.2] + p)[:, None] * [0.2, 0.5, 1.0],
                                  np.sin((2 + p) * x @ [0.3, 1.0, 0.5] + p)[:, None] * [0.4, 0.3, 0.2]], axis=1)
                  for p in range(nf)], axis=-1)  # (n, 6, nf)
    def m6(U):  # noqa: E306
        return np.concatenate([mass.Ms @ U[:, :3], np.einsum("iab,ib->ia", mass.J, U[:, 3:])], axis=1)
    R = _rigid6(points)
    MR = np.stack([m6(R[:, :, k]) for k in range(6)], axis=-1)
    G = np.einsum("iak,ial->kl", R, MR)
    V = V - np.einsum("iak,kp->iap", R, np.linalg.solve(G, np.einsum("iak,iap->kp", MR, V)))
    MV = np.stack([m6(V[:, :, p]) for p in range(nf)], axis=-1)
    L = np.linalg.cholesky(np.einsum("iap,iaq->pq", V, MV))  # M-orthonormal like a solver's modes, then scaled
    V = np.einsum("iap,pq->iaq", V, np.linalg.inv(L).T) * np.arange(2.0, 2.0 + nf)
    return V[:, :3], V[:, 3:]


def _plate(cell_type: str):
    """A plate 200 x 80 x 6 of ``cell_type`` in the x-y plane, uneven elements."""
    uv, cells = grid(cell_type, 4, 2)
    points = np.column_stack([200.0 * uv[:, 0] ** 1.2, 80.0 * uv[:, 1], np.zeros(len(uv))])
    return points, cells


@pytest.mark.parametrize("cell_type", ["triangle", "triangle6", "quad", "quad8", "quad9"])
def test_shells_read_with_thickness_and_rotations(tmp_path, cell_type):
    """A plate of shells with cell data thickness and modes with rotations: mass rho a b t and I0 of the box
    (fibre inertia included: exact to round-off, test_structural), the modes normalised with their rotary part
    (the mass-normalisation check fails otherwise: the rotary part carries a share of each mode's modal mass)."""
    points, cells = _plate(cell_type)
    t = 6.0
    T, R = _synthetic_modes(points, shell_mass(points, cell_type, cells, t, STEEL.rho))
    path = _write(tmp_path / "plate.vtu", points, [(cell_type, cells)], T, R,
                  {"thickness": [np.full(len(cells), t)]})
    body = read_body(path, eigenvalues=LAM, density=STEEL.rho, young=STEEL.E, poisson=STEEL.nu)
    assert body.static_centrifugal is None and "not used for the static centrifugal response: nodes with rotary " \
        "inertia need 6-DOF stiffness" in body.provenance.notes[-1]
    mass = STEEL.rho * 200.0 * 80.0 * t
    assert body.mass == pytest.approx(mass, rel=ROUND)
    assert _principal(body.I0) == pytest.approx(_box_inertia(mass, (200.0, 80.0, t)), rel=ROUND)
    assert np.diag(body.integrals.rotary.modal_mass).min() > 0.01  # the rotations matter
    assert np.sort(body.equivalent_box()) == pytest.approx([t, 80.0, 200.0], rel=1e-12)  # fibres give the thickness
    assert density_warnings(body) == ()  # a box of zero thickness was infinitely dense
    _passes(body)
    assert f"{len(cells)} {cell_type} shells" in body.provenance.notes[2]


@pytest.mark.parametrize("cell_type", ["line", "line3"])
def test_beams_read_with_sections_and_rotations(tmp_path, cell_type):
    """A beam 300 long of section 20 x 8 along x, section data as cell data, orientation off the normal plane:
    mass and I0 of the solid box, the rotary inertia (torsion, section) in the normalisation, checks pass."""
    n = 13 if cell_type == "line3" else 7
    x = 300.0 * np.linspace(0, 1, n) ** 1.1
    points = np.column_stack([x, np.zeros(n), np.zeros(n)])
    cells = (np.column_stack([np.arange(0, n - 2, 2), np.arange(2, n, 2), np.arange(1, n - 1, 2)])
             if cell_type == "line3" else np.column_stack([np.arange(n - 1), np.arange(1, n)]))
    w, h = 20.0, 8.0
    data = {"area": w * h, "I22": w * h**3 / 12, "I33": h * w**3 / 12}
    section = BeamSection(*data.values(), [0.3, 1.0, 0.0])
    T, R = _synthetic_modes(points, beam_mass(points, cell_type, cells, section, STEEL.rho))
    cell_data = {k: [np.full(len(cells), v)] for k, v in data.items()} | {"orientation": [np.tile([0.3, 1.0, 0.0],
                                                                                                 (len(cells), 1))]}
    body = read_body(_write(tmp_path / "beam.vtu", points, [(cell_type, cells)], T, R, cell_data), eigenvalues=LAM,
                     density=STEEL.rho)
    mass = STEEL.rho * 300.0 * w * h
    assert body.mass == pytest.approx(mass, rel=ROUND)
    assert _principal(body.I0) == pytest.approx(_box_inertia(mass, (300.0, h, w)), rel=ROUND)
    assert np.diag(body.integrals.rotary.modal_mass).min() > 0.01
    _passes(body)


def test_point_masses_read_with_the_mass_right(tmp_path):
    """A box of hexahedra with a point mass of half its mass at a corner: the solver's modes with that mass
    added, read back with mass rho V + m and I0 of box plus point about their joint CoM (analytic), the
    solver's invariants and static centrifugal response (with --young, --poisson), checks passing."""
    mesh = box_mesh(SIZE, (2, 1, 1), "hexahedron20")
    box_mass = STEEL.rho * SIZE.prod()
    corner = int(np.argmax(mesh.points @ [1.0, 1.0, 1.0]))
    m = box_mass / 2
    ref = modal_body(mesh, STEEL, 3, added_mass=point_mass(mesh.n_nodes, [corner], [m]).Ms)
    cells = [*ref.fe.mesh.cells.items(), ("vertex", np.array([[corner]]))]  # nodes keep their numbers
    cell_data = {"mass": [np.full(len(c), np.nan) for _, c in cells[:-1]] + [np.array([m])]}
    path = _write(tmp_path / "pm.vtu", ref.fe.mesh.points, cells, ref.fe.Phi, cell_data=cell_data)
    body = read_body(path, eigenvalues=ref.eigenvalues, density=STEEL.rho, young=STEEL.E, poisson=STEEL.nu)
    # the static centrifugal response with the point mass's load, as the solver's (one refactorisation apart)
    assert body.static_centrifugal.compliance == pytest.approx(ref.static_centrifugal.compliance, rel=1e-10)
    d = mesh.points[corner]  # the box centred at 0: the corner at d, the joint CoM at d m / (M + m)
    com = d * m / (box_mass + m)
    a, b, c = SIZE
    want = (box_mass / 12 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
            + box_mass * (com @ com * np.eye(3) - np.outer(com, com))
            + m * ((d - com) @ (d - com) * np.eye(3) - np.outer(d - com, d - com)))
    assert body.mass == pytest.approx(box_mass + m, rel=ROUND)
    assert _principal(body.I0) == pytest.approx(_principal(want), rel=ROUND)
    _same_invariants(body, ref)
    _passes(body)
    assert "1 point masses (vertex cells)" in " ".join(body.provenance.notes)


@pytest.fixture(scope="module")
def box():
    """The solver's body of a box of hexahedra (its principal frame)."""
    return modal_body(box_mesh(SIZE, (2, 1, 1), "hexahedron"), STEEL, 3)


def _box_file(path: Path, box, cells=(), cell_data=None, rotations=None) -> Path:
    """The box's hexahedra and modes with more cells; cell data given for the extra blocks (NaN on the box)."""
    blocks = [*box.fe.mesh.cells.items(), *cells]
    n = len(box.fe.mesh.cells["hexahedron"])
    data = {k: [np.full((n, *v[0].shape[1:]), np.nan), *v] for k, v in (cell_data or {}).items()}
    return _write(path, box.fe.mesh.points, blocks, box.fe.Phi, rotations, data)


def _read(path: Path, box):
    return read_body(path, eigenvalues=box.eigenvalues, density=STEEL.rho)


def test_a_point_mass_with_inertia_adds_it(tmp_path, box):
    """A point mass with inertia J at a node, with rotations (zero) at every node: I0 grows by J and the parallel
    axis term exactly, the mass by m; without the rotations the file is refused naming them."""
    node, m = 0, 1e-5
    J = np.array([[3.0, 0.5, 0.0], [0.5, 2.0, 0.1], [0.0, 0.1, 1.0]]) * 1e-3
    extra = dict(cells=[("vertex", np.array([[node]]))], cell_data={"mass": [np.array([m])],
                                                                       "inertia": [J.reshape(1, 9)]})
    body = _read(_box_file(tmp_path / "pm.vtu", box, **extra, rotations=np.zeros_like(box.fe.Phi)), box)
    d = box.fe.mesh.points[node]
    com = d * m / (box.mass + m)
    want = (box.I0 + box.mass * (com @ com * np.eye(3) - np.outer(com, com))
            + m * ((d - com) @ (d - com) * np.eye(3) - np.outer(d - com, d - com)) + J)
    assert body.mass == pytest.approx(box.mass + m, rel=ROUND)
    assert _principal(body.I0) == pytest.approx(_principal(want), rel=ROUND)
    with pytest.raises(BodyFileError, match=r"point_data/rotation_1: expected mode rotations rotation_1 \.\. "
                                            r"rotation_3 \(theory 3b\) for the 1 nodes with rotary inertia"):
        _read(_box_file(tmp_path / "norot.vtu", box, **extra), box)
    write_body(body, tmp_path / "written.vtu")  # the point mass as a vertex cell, its inertia and rotations
    back = read_body(tmp_path / "written.vtu")
    assert back.mass == pytest.approx(body.mass, rel=ROUND)
    assert np.abs(back.I0 - body.I0).max() <= ROUND * np.abs(body.I0).max()
    _same_invariants(back, body)
    assert np.abs(back.integrals.rotary.J - body.integrals.rotary.J).max() <= ROUND * np.abs(J).max()


def test_cells_without_their_data(tmp_path, box):
    """A vertex with no mass at a node of the box, a face without thickness: named, no mass of their own (the
    mass stays the box's); a vertex without mass at a node of no cell, a shell without thickness reaching off the
    solid, a beam without I22 or without orientation, a negative mass: refused naming cell type and field, and
    `info` exits 2 on them (never 0 with a mass off)."""
    far = len(box.fe.mesh.points)
    points = np.vstack([box.fe.mesh.points, [[500.0, 0.0, 0.0], [600.0, 0.0, 0.0]]])
    Phi = np.concatenate([box.fe.Phi, np.zeros((2, 3, 3))])
    hexes = box.fe.mesh.cells["hexahedron"]
    nan = np.full(len(hexes), np.nan)

    def write(name, cells, data=None):
        data = {k: [nan, *v] for k, v in (data or {}).items()}
        return _write(tmp_path / name, points, [("hexahedron", hexes), *cells], Phi, cell_data=data)

    named = _read(write("named.vtu", [("vertex", np.array([[1]])), ("quad", hexes[:1, :4])],
                        {"mass": [np.array([np.nan]), np.array([np.nan])]}), box)
    assert named.mass == pytest.approx(box.mass, rel=ROUND)
    assert "cells without mass of their own: 1 vertex, 1 quad (no mass/thickness data" in " ".join(
        named.provenance.notes)
    refused = {
        "vertex.vtu": ([("vertex", np.array([[far]]))], None,
                       r"cells/vertex: expected cell data mass for point masses .*got none for 1 cells"),
        "shell.vtu": ([("quad8", np.array([[*hexes[0, :4], far, far + 1, 2, 3]]))], None,
                      "cells/quad8: expected cell data thickness for shells"),
        "i22.vtu": ([("line", np.array([[0, far]]))], {"area": [np.array([10.0])]},
                    "cell_data/I22: expected I22 of the line cells"),
        "orientation.vtu": ([("line", np.array([[0, far]]))], {k: [np.array([v])] for k, v in
                                                               (("area", 10.0), ("I22", 2.0), ("I33", 1.0))},
                            "cell_data/orientation: expected orientation of the line cells"),
        "negative.vtu": ([("vertex", np.array([[far]]))], {"mass": [np.array([-1.0])]},
                         "cell_data/mass: expected positive values for vertex cells, got -1"),
    }
    for name, (cells, data, message) in refused.items():
        path = write(name, cells, data)
        with pytest.raises(BodyFileError, match=message):
            _read(path, box)
    lam = ",".join(repr(float(x)) for x in box.eigenvalues)
    result = runner.invoke(app, ["info", str(tmp_path / "vertex.vtu"), "--eigenvalues", lam, "--density",
                                 repr(STEEL.rho)])
    assert result.exit_code == 2 and "cells/vertex" in result.output and "Traceback" not in result.output


def test_vtu_writer_round_trip_and_refusal(tmp_path):
    """A tetra10 body written by `convert` to VTU reads back to the same integrals (round-off: the mass is
    reassembled); a shell body cannot be held by a mesh file (rotary inertia: refused in one line), and goes
    through .ffrf.h5 unchanged."""
    ref = modal_body(box_split_mesh(SIZE, (2, 1, 1), "tetra10"), STEEL, 3)
    src = _write(tmp_path / "tet.vtu", ref.fe.mesh.points, list(ref.fe.mesh.cells.items()), ref.fe.Phi)
    lam = ",".join(repr(float(x)) for x in ref.eigenvalues)
    opts = ["--eigenvalues", lam, "--density", repr(STEEL.rho)]
    out = tmp_path / "out.vtu"
    assert runner.invoke(app, ["convert", str(src), str(out), *opts]).exit_code == 0
    back = read_body(out)
    assert np.abs(back.integrals.I - ref.integrals.I).max() <= ROUND * np.abs(ref.integrals.I).max()
    _same_invariants(back, ref)
    points, cells = _plate("quad8")
    T, R = _synthetic_modes(points, shell_mass(points, "quad8", cells, 6.0, STEEL.rho))
    plate = _write(tmp_path / "plate.vtu", points, [("quad8", cells)], T, R, {"thickness": [np.full(len(cells),
                                                                                                    6.0)]})
    opts = ["--eigenvalues", ",".join(repr(float(x)) for x in LAM), "--density", repr(STEEL.rho)]
    refused = runner.invoke(app, ["convert", str(plate), str(tmp_path / "plate_out.vtu"), *opts])
    assert refused.exit_code == 2 and "not the consistent mass of a uniform density plus masses on nodes" \
        in refused.output
    h5 = tmp_path / "plate.ffrf.h5"
    assert runner.invoke(app, ["convert", str(plate), str(h5), *opts]).exit_code == 0
    shell = read_body(plate, eigenvalues=LAM, density=STEEL.rho)
    again = read_body(h5)
    assert np.abs(again.I0 - shell.I0).max() <= ROUND * np.abs(shell.I0).max()
    assert np.abs(again.integrals.rotary.modal_mass - shell.integrals.rotary.modal_mass).max() <= ROUND


def test_a_gmsh_mesh_with_its_points_edges_and_faces(tmp_path):
    """gmsh meshes a box in tetra10 and writes every entity (its corner points, edges and faces as vertex,
    line3 and triangle6 cells); with the solver's modes as node data in that .msh, the body has rho V and the
    box's I0 (exact: straight-edged tetrahedra), passes every check, and names the cells that carry no mass."""
    gmsh = pytest.importorskip("gmsh")
    gmsh.initialize(["-noenv"], readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.occ.addBox(0, 0, 0, *SIZE)
        gmsh.model.occ.synchronize()
        gmsh.model.mesh.setSize(gmsh.model.getEntities(0), 20.0)
        gmsh.option.setNumber("Mesh.SaveAll", 1)
        gmsh.model.mesh.generate(3)
        gmsh.model.mesh.setOrder(2)
        gmsh.write(str(tmp_path / "box.msh"))
    finally:
        gmsh.finalize()
    meshio = meshio_module()
    m = meshio.read(tmp_path / "box.msh")
    tets = np.concatenate([c.data for c in m.cells if c.type == "tetra10"])
    mesh = Mesh(m.points, {"tetra10": tets})
    ref = modal_body(mesh, STEEL, 3)
    modes = free_free_modes(stiffness_matrix(mesh, STEEL), mass_matrix(mesh, STEEL.rho), mesh.points, 3)
    m.point_data |= {f"mode_{p + 1}": modes.Phi[:, :, p] for p in range(3)}  # the file's axes
    m.cell_data["gmsh:physical"] = [np.zeros(len(c.data), int) for c in m.cells]  # meshio's writer wants them
    meshio.write(tmp_path / "modes.msh", m, file_format="gmsh")
    body = read_body(tmp_path / "modes.msh", eigenvalues=ref.eigenvalues, density=STEEL.rho)
    mass = STEEL.rho * SIZE.prod()
    assert body.mass == pytest.approx(mass, rel=ROUND)
    assert _principal(body.I0) == pytest.approx(_box_inertia(mass, SIZE), rel=ROUND)
    _same_invariants(body, ref)
    _passes(body)
    counts = {t: sum(len(c.data) for c in m.cells if c.type == t) for t in ("vertex", "line3", "triangle6")}
    assert (f"cells without mass of their own: {counts['vertex']} vertex, {counts['line3']} line3, "
            f"{counts['triangle6']} triangle6") in " ".join(body.provenance.notes)


def test_section_data_as_field_data(tmp_path):
    """One thickness for all shells as field data (a VTU's <FieldData>, as the VTU writer adds it) gives the
    same body as the thickness per cell; a field with the wrong count is refused naming it."""
    from ffrf_advisor.io.meshio_modes import _add_field_data

    points, cells = _plate("quad")
    T, R = _synthetic_modes(points, shell_mass(points, "quad", cells, 6.0, STEEL.rho))
    per_cell = _write(tmp_path / "cell.vtu", points, [("quad", cells)], T, R, {"thickness": [np.full(len(cells),
                                                                                                      6.0)]})
    uniform = _write(tmp_path / "field.vtu", points, [("quad", cells)], T, R)
    _add_field_data(uniform, {"thickness": np.array([6.0])})
    a, b = (read_body(p, eigenvalues=LAM, density=STEEL.rho) for p in (per_cell, uniform))
    assert np.array_equal(a.I0, b.I0) and np.array_equal(a.W2, b.W2)
    wrong = _write(tmp_path / "wrong.vtu", points, [("quad", cells)], T, R)
    _add_field_data(wrong, {"thickness": np.array([6.0, 7.0])})
    with pytest.raises(BodyFileError, match="field_data/thickness: expected 1 number for all cells, got 2"):
        read_body(wrong, eigenvalues=LAM, density=STEEL.rho)
