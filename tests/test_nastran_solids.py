"""Nastran solids (CTETRA, CPENTA, CPYRAM, CHEXA, linear and quadratic) through the Nastran reader (issue 48):
decks built with pyNastran, the assembled mass against analytic volume x rho and pyNastran's mass properties,
node orders from Nastran's own element definitions (not the reader's tables)."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

pytest.importorskip("pyNastran", reason="the Nastran reader's optional extra (pip install '.[nastran]')")

from ffrf_advisor.errors import BodyFileError  # noqa: E402
from ffrf_advisor.fe.assembly import mass_matrix  # noqa: E402
from ffrf_advisor.fe.elements import element_type  # noqa: E402
from ffrf_advisor.fe.mesh import Mesh  # noqa: E402
from ffrf_advisor.io import nastran_mass, nastran_props, nastran_solids  # noqa: E402
from ffrf_advisor.io.nastran_modes import NastranModes  # noqa: E402

RHO, E, NU = 7.85e-9, 2.1e5, 0.3
BOX = np.array([40.0, 20.0, 10.0])  # mm
ROUND = 1e-12  # relative round-off of sums over a few hundred elements in double
# Nastran's element definitions (MSC QRG, CTETRA/CPENTA/CPYRAM/CHEXA): grid k + 1 of a quadratic element lies on
# the edge between these two corners (1-based), listed in Nastran's order after the corners.
NASTRAN_EDGES = {
    "CTETRA": [(1, 2), (2, 3), (3, 1), (1, 4), (2, 4), (3, 4)],
    "CPENTA": [(1, 2), (2, 3), (3, 1), (1, 4), (2, 5), (3, 6), (4, 5), (5, 6), (6, 4)],
    "CPYRAM": [(1, 2), (2, 3), (3, 4), (4, 1), (1, 5), (2, 5), (3, 5), (4, 5)],
    "CHEXA": [(1, 2), (2, 3), (3, 4), (4, 1), (1, 5), (2, 6), (3, 7), (4, 8), (5, 6), (6, 7), (7, 8), (8, 5)],
}
CORNERS = {"CTETRA": 4, "CPENTA": 6, "CPYRAM": 5, "CHEXA": 8}
LINEAR = {"CTETRA": "tetra", "CPENTA": "wedge", "CPYRAM": "pyramid", "CHEXA": "hexahedron"}
QUADRATIC = {"CTETRA": "tetra10", "CPENTA": "wedge15", "CPYRAM": "pyramid13", "CHEXA": "hexahedron20"}
QUADRATIC_CORNERS = {"tetra10": 4, "wedge15": 6, "pyramid13": 5, "hexahedron20": 8}


def _vtk_edges(cell: str) -> list[tuple[int, int]]:
    """The corners (0-based) of each mid-side node of a quadratic cell, from the FE module's reference nodes."""
    ref = element_type(cell).ref_nodes
    corners = QUADRATIC_CORNERS.get(cell, len(ref))
    return [next((a, b) for a, b in itertools.combinations(range(corners), 2)
                 if np.allclose((ref[a] + ref[b]) / 2, ref[k])) for k in range(corners, len(ref))]


def _hex_grid(counts=(4, 2, 2)):
    """Points of a structured grid over BOX and its hexahedra's corners in VTK (and Nastran) order."""
    axes = [np.linspace(0, L, c + 1) for L, c in zip(BOX, counts)]
    points = np.array(list(itertools.product(*axes)))
    idx = np.arange(len(points)).reshape([c + 1 for c in counts])
    hexes = []
    for i, j, k in itertools.product(*(range(c) for c in counts)):
        hexes.append([idx[i, j, k], idx[i + 1, j, k], idx[i + 1, j + 1, k], idx[i, j + 1, k],
                      idx[i, j, k + 1], idx[i + 1, j, k + 1], idx[i + 1, j + 1, k + 1], idx[i, j + 1, k + 1]])
    return points, np.array(hexes)


def _signed(X) -> float:
    return float(np.dot(X[1] - X[0], np.cross(X[2] - X[0], X[3] - X[0])))


def _corner_cells(kind: str, counts=(4, 2, 2)):
    """Points and corner lists of a box meshed in one Nastran solid (right-handed, as Nastran's figures)."""
    points, hexes = _hex_grid(counts)
    if kind == "CHEXA":
        return points, [list(h) for h in hexes]
    if kind == "CPENTA":  # two right prisms per hexahedron
        return points, [[h[a] for a in w] for h in hexes for w in ((0, 1, 2, 4, 5, 6), (0, 2, 3, 4, 6, 7))]
    if kind == "CTETRA":  # six per hexahedron around its diagonal 0-6
        cells = [[h[a] for a in t] for h in hexes for t in ((0, 1, 2, 6), (0, 2, 3, 6), (0, 3, 7, 6),
                                                            (0, 7, 4, 6), (0, 4, 5, 6), (0, 5, 1, 6))]
        return points, [c if _signed(points[c]) > 0 else [c[0], c[2], c[1], c[3]] for c in cells]
    faces = ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7))  # outward normals
    centres = points[hexes].mean(axis=1)
    apex = len(points) + np.arange(len(hexes))
    points = np.vstack([points, centres])
    cells = [[h[f[0]], h[f[3]], h[f[2]], h[f[1]], a] for h, a in zip(hexes, apex) for f in faces]  # base towards apex
    return points, cells


def _quadratic(kind: str, points, cells, shift: float = 0.0, rng=None):
    """Mid-side grids added on every edge (shared), in Nastran's order and in VTK order; interior ones moved by
    ``shift`` x a random unit vector (curved edges inside, the box's surface kept)."""
    mids: dict[tuple[int, int], int] = {}
    extra = []
    vtk_edges = _vtk_edges(QUADRATIC[kind])
    for c in cells:
        for a, b in NASTRAN_EDGES[kind]:
            key = tuple(sorted((c[a - 1], c[b - 1])))
            if key not in mids:
                mids[key] = len(points) + len(extra)
                extra.append((points[key[0]] + points[key[1]]) / 2)
    extra = np.array(extra)
    if shift:
        inside = np.all((extra > 1e-9) & (extra < BOX - 1e-9), axis=1)
        step = rng.normal(size=extra.shape)
        extra[inside] += shift * step[inside] / np.linalg.norm(step[inside], axis=1)[:, None]
    nastran = [c + [mids[tuple(sorted((c[a - 1], c[b - 1])))] for a, b in NASTRAN_EDGES[kind]] for c in cells]
    vtk = [c + [mids[tuple(sorted((c[a], c[b])))] for a, b in vtk_edges] for c in cells]
    return np.vstack([points, extra]), nastran, vtk


def _model(points, cells, kind: str, conm2=()):
    """A pyNastran model: GRIDs 1.., the cells as ``kind`` (PSOLID, MAT1 with RHO), CONM2 (grid index, mass, I6)."""
    from cpylog import SimpleLogger
    from pyNastran.op2.op2_geom import OP2Geom

    model = OP2Geom(log=SimpleLogger(level="critical"))
    model.set_mode("msc")
    for i, x in enumerate(points):
        model.add_grid(i + 1, list(x))
    model.add_mat1(1, E, None, NU, rho=RHO)
    model.add_psolid(1, 1)
    add = {"CTETRA": model.add_ctetra, "CPENTA": model.add_cpenta, "CPYRAM": model.add_cpyram,
           "CHEXA": model.add_chexa}[kind]
    for e, c in enumerate(cells):
        add(e + 1, 1, [int(g) + 1 for g in c])
    for k, (g, mass, inertia) in enumerate(conm2):
        model.add_conm2(900 + k, int(g) + 1, mass, I=list(inertia))
    model.cross_reference()
    return model


def _run(points, types) -> NastranModes:
    """A run without modes, for the mass alone."""
    n = len(points)
    return NastranModes(np.arange(1, n + 1), points, np.zeros(0), np.zeros(0), np.zeros((n, 3, 0)),
                        np.zeros((n, 3, 0)), None, types)


def _box_inertia(mass: float) -> np.ndarray:
    a, b, c = BOX
    return mass / 12 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])


SOLID_CASES = [(k, q) for k in CORNERS for q in (False, True)]


@pytest.mark.parametrize("kind, quadratic", SOLID_CASES)
def test_a_box_in_each_solid_has_the_analytic_mass_cg_and_inertia_and_pyNastrans(kind, quadratic):
    points, cells = _corner_cells(kind)
    if quadratic:
        points, cells, _ = _quadratic(kind, points, cells)
    model = _model(points, cells, kind)
    mass = nastran_mass.assembled_mass("box.bdf", model, _run(points, {kind: len(cells)}))
    got = nastran_props.of_nodal_mass(mass, points)
    exact = RHO * BOX.prod()
    assert got.mass == pytest.approx(exact, rel=ROUND)
    assert np.allclose(got.cg, BOX / 2, rtol=0, atol=ROUND * BOX.max())
    assert np.allclose(got.inertia, _box_inertia(exact), rtol=0, atol=ROUND * _box_inertia(exact).max())
    notes = nastran_props.checked("box.bdf", model, mass, points, True)
    compared = all(f"{q} within" in notes[0] for q in ("mass", "CG", "inertia"))
    assert compared == (kind != "CPYRAM") and "mass within" in notes[0]  # pyNastran's pyramid centroid is off
    assert ("pyNastran approximates" in notes[0]) == (kind == "CPYRAM")


@pytest.mark.parametrize("kind", list(CORNERS))
def test_curved_quadratic_solids_keep_the_box_exactly_and_pyNastran_is_not_trusted_with_them(kind):
    """Interior mid-side grids moved (curved edges, det J of higher degree): the box's mass and moments are still
    exact (isoparametric elements reproduce x, and the FE module integrates N N det J exactly)."""
    points, cells = _corner_cells(kind)
    points, cells, _ = _quadratic(kind, points, cells, shift=0.4, rng=np.random.default_rng(3))
    model = _model(points, cells, kind)
    mass = nastran_mass.assembled_mass("box.bdf", model, _run(points, {kind: len(cells)}))
    got = nastran_props.of_nodal_mass(mass, points)
    exact = RHO * BOX.prod()
    assert got.mass == pytest.approx(exact, rel=ROUND)
    assert np.allclose(got.inertia, _box_inertia(exact), rtol=0, atol=ROUND * _box_inertia(exact).max())
    notes = nastran_props.checked("box.bdf", model, mass, points, True)
    assert "pyNastran approximates" in notes[0] and "nothing compared" in notes[0]


@pytest.mark.parametrize("kind", list(CORNERS))
def test_nastran_grid_order_maps_onto_the_fe_modules_reference_nodes(kind):
    """Each quadratic cell in Nastran's order, mapped by the reader, has every mid-side grid at the middle of
    the corners the FE module's reference element puts it between; the unmapped order does not (CPENTA15,
    CHEXA20) or coincides (CTETRA10, CPYRAM13)."""
    points, cells = _corner_cells(kind, counts=(1, 1, 1))
    points, nastran, vtk = _quadratic(kind, points, cells)
    mapped = [nastran_solids.to_vtk(QUADRATIC[kind], c) for c in nastran]
    assert mapped == vtk
    assert (nastran == vtk) == (kind in ("CTETRA", "CPYRAM"))


@pytest.mark.parametrize("cell", list(nastran_solids.MIRROR))
def test_a_mirrored_cell_is_renumbered_to_the_same_solid(cell):
    """A cell of the other handedness (reflected reference element, VTK numbering kept): oriented() renumbers it,
    its mid-side nodes stay at their edges' middles, and its mass is the reference element's."""
    ref = element_type(cell).ref_nodes
    assert nastran_solids.corner_volume(cell, ref[None])[0] > 0  # the reader's handedness is the FE module's
    mirrored = ref * [-1.0, 1.0, 1.0]
    conn, flipped = nastran_solids.oriented(cell, np.arange(len(ref))[None], mirrored)
    assert flipped.tolist() == [True]
    X = mirrored[conn[0]]
    edges = _vtk_edges(cell)
    for k, (a, b) in enumerate(edges, start=len(ref) - len(edges)):
        assert np.allclose(X[k], (X[a] + X[b]) / 2)
    volume = mass_matrix(Mesh(ref, {cell: np.arange(len(ref))[None]}), 1.0).sum()
    assert mass_matrix(Mesh(mirrored, {cell: conn}), 1.0).sum() == pytest.approx(volume, rel=ROUND)
    with pytest.raises(ValueError):
        mass_matrix(Mesh(mirrored, {cell: np.arange(len(ref))[None]}), 1.0)  # unrenumbered: inverted


def test_a_wrong_grid_order_gives_a_wrong_mass_or_an_inverted_element_named_by_its_id():
    points, cells = _corner_cells("CHEXA", counts=(1, 1, 1))
    points, nastran, _ = _quadratic("CHEXA", points, cells)
    right = nastran_solids.solid_mass("x.bdf", points, "hexahedron20",
                                      np.array([nastran_solids.to_vtk("hexahedron20", nastran[0])]), np.array([7]), RHO)
    assert right.sum() == pytest.approx(RHO * BOX.prod(), rel=ROUND)
    with pytest.raises(BodyFileError, match=r"x\.bdf: CHEXA 7: expected an element whose Jacobian is positive"):
        nastran_solids.solid_mass("x.bdf", points, "hexahedron20", np.array([nastran[0]]), np.array([7]), RHO)
    twisted = [nastran[0][k] for k in (0, 1, 3, 2, 4, 5, 7, 6)] + nastran[0][8:]  # corners 3, 4 swapped
    conn = np.array([nastran_solids.to_vtk("hexahedron20", twisted)])
    with pytest.raises(BodyFileError, match="CHEXA 7"):
        nastran_solids.solid_mass("x.bdf", points, "hexahedron20", conn, np.array([7]), RHO)


def test_the_inverted_element_is_found_among_many():
    points, cells = _corner_cells("CTETRA")
    conn = np.array(cells)
    conn[37] = conn[37][[0, 1, 2, 2]]  # degenerate: zero volume
    with pytest.raises(BodyFileError, match="CTETRA 1038"):
        nastran_solids.solid_mass("x.bdf", points, "tetra", conn, np.arange(1001, 1001 + len(conn)), RHO)


def test_grids_missing_from_a_quadratic_solid_are_refused_by_name():
    points, cells = _corner_cells("CPENTA", counts=(1, 1, 1))
    points, nastran, _ = _quadratic("CPENTA", points, cells)
    model = _model(points, [nastran[0][:6] + nastran[0][6:12]], "CPENTA")  # 12 of 15 grids
    with pytest.raises(BodyFileError, match=r"CPENTA 1: expected 6 or 15 grids"):
        nastran_mass.assembled_mass("p.bdf", model, _run(points, {"CPENTA": 1}))


def test_a_mismatch_with_pyNastrans_mass_properties_is_an_error_naming_both():
    points, cells = _corner_cells("CTETRA")
    model = _model(points, cells, "CTETRA", conm2=[(0, 1e-6, (0, 0, 0, 0, 0, 0))])
    mass = nastran_mass.assembled_mass("t.bdf", model, _run(points, {"CTETRA": len(cells), "CONM2": 1}))
    assert "mass within" in nastran_props.checked("t.bdf", model, mass, points, True)[0]
    mass.Ms = mass.Ms * (1 + 1e-5)  # 10 x the allowed disagreement
    with pytest.raises(BodyFileError, match=r"t\.bdf: mass properties: expected the assembled mass to agree with "
                                            r"pyNastran's .* got 6\.38006\d+e-05 against pyNastran's 6\.38e-05"):
        nastran_props.checked("t.bdf", model, mass, points, True)


# ---------------------------------------------------------------- full reads: modes of the FE module as an OP2
def _write_op2(path, model, points, lam, modes6) -> None:
    """The model's geometry (PARAM,POST,-1) and a SOL 103 eigenvector table: eigenvalues ``lam`` and modes
    (nm, n, 6) at the GRIDs 1..n, float32 as Nastran writes them."""
    from pyNastran.op2.tables.oug.oug_eigenvectors import RealEigenvectorArray

    n = len(points)
    ev = RealEigenvectorArray.add_modal_case("OUGV1", np.column_stack([np.arange(1, n + 1), np.ones(n, int)]),
                                             modes6.astype(np.float32), 1, np.arange(1, len(lam) + 1), lam,
                                             np.sqrt(np.abs(lam)) / (2 * np.pi))
    ev.table_code, ev.device_code, ev.approach_code = 7, 1, 21  # eigenvectors, as Nastran writes them
    model.eigenvectors[1] = ev
    model.write_op2(str(path), post=-1, endian=b"<")


FLOAT32 = 2e-7  # the OP2 holds modes and eigenvalues in float32: sums of their squares good to a few 6e-8
N_FLEX = 8


def _free_free_op2(path, kind: str, counts=(4, 2, 1), gpwg_mass: float | None = None) -> np.ndarray:
    """A free-free run of a quadratic ``kind`` box by the FE module (six rigid modes, N_FLEX flexible ones) as an
    OP2 with its geometry, optionally with a weight generator's table of that mass; its flexible eigenvalues."""
    from ffrf_advisor.fe.assembly import stiffness_matrix
    from ffrf_advisor.fe.material import Material
    from ffrf_advisor.fe.modal import free_free_modes, rigid_modes
    from pyNastran.op2.result_objects.grid_point_weight import GridPointWeight

    points, cells = _corner_cells(kind, counts)
    points, nastran, vtk = _quadratic(kind, points, cells)
    mesh = Mesh(points, {QUADRATIC[kind]: np.array(vtk)})
    modal = free_free_modes(stiffness_matrix(mesh, Material("steel", E, NU, RHO)), mass_matrix(mesh, RHO), points,
                            N_FLEX)
    n = len(points)
    modes = np.zeros((6 + N_FLEX, n, 6))
    modes[:, :, :3] = np.concatenate([rigid_modes(points).reshape(n, 3, 6), modal.Phi], axis=2).transpose(2, 0, 1)
    model = _model(points, nastran, kind)
    if gpwg_mass is not None:
        I = _box_inertia(gpwg_mass)
        model.grid_point_weight[""] = GridPointWeight(
            0, np.zeros((6, 6)), np.eye(3), np.full(3, gpwg_mass), np.tile(BOX / 2, (3, 1)), I, np.diag(I), np.eye(3))
    _write_op2(path, model, points, np.r_[np.zeros(6), modal.eigenvalues], modes)
    return modal.eigenvalues


@pytest.mark.parametrize("kind", list(CORNERS))
def test_a_free_free_run_of_each_quadratic_solid_reads_with_its_mass_inertia_frequencies_and_checks(kind, tmp_path):
    from ffrf_advisor.checks import run_checks
    from ffrf_advisor.io import read_body

    eigenvalues = _free_free_op2(tmp_path / "part.op2", kind)
    body = read_body(tmp_path / "part.op2")
    exact = float(np.float32(RHO)) * BOX.prod()  # the OP2 holds RHO in float32, the grids exactly (binary fractions)
    assert body.mass == pytest.approx(exact, rel=ROUND)
    assert np.allclose(np.linalg.eigvalsh(body.I0), np.sort(np.diag(_box_inertia(exact))), rtol=ROUND)
    assert np.allclose(body.eigenvalues, eigenvalues, rtol=FLOAT32)
    checks = run_checks(body)
    assert all(c.passed for c in checks), [(c.name, c.value, c.tolerance) for c in checks if not c.passed]
    notes = " ".join(body.provenance.notes)
    assert f"mass assembled from {len(_corner_cells(kind, (4, 2, 1))[1])} {kind}" in notes and "warning" not in notes


def test_the_weight_generators_mass_in_the_op2_is_checked_and_a_different_one_ends_in_one_line(tmp_path):
    from typer.testing import CliRunner

    from ffrf_advisor.cli import app
    from ffrf_advisor.io import read_body

    exact = float(np.float32(RHO)) * BOX.prod()
    _free_free_op2(tmp_path / "same.op2", "CHEXA", counts=(2, 1, 1), gpwg_mass=exact)
    assert "grid point weight generator" in " ".join(read_body(tmp_path / "same.op2").provenance.notes)
    _free_free_op2(tmp_path / "other.op2", "CHEXA", counts=(2, 1, 1), gpwg_mass=exact * 1.001)  # a mass Nastran had
    result = CliRunner().invoke(app, ["info", str(tmp_path / "other.op2")])
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1, result.output
    assert "other.op2: grid point weight generator (PARAM,GRDPNT): expected its mass to agree" in result.output
    assert f"Nastran's {exact * 1.001:.7g} against {exact:.7g}" in result.output


def test_a_deck_beside_the_op2_with_mirrored_wedges_reads_and_an_inverted_one_is_one_line(tmp_path):
    """Geometry from the input deck (no PARAM,POST,-1 geometry): CPENTA of both handednesses give the box's
    mass; a twisted one ends the CLI in one line naming it."""
    from typer.testing import CliRunner

    from ffrf_advisor.cli import app
    from ffrf_advisor.fe.modal import rigid_modes
    from ffrf_advisor.io import nastran

    points, cells = _corner_cells("CPENTA", counts=(2, 1, 1))
    cells = [c if k % 2 else [c[0], c[2], c[1], c[3], c[5], c[4]] for k, c in enumerate(cells)]  # half mirrored
    n = len(points)
    modes = np.zeros((6, n, 6))
    modes[:, :, :3] = rigid_modes(points).reshape(n, 3, 6).transpose(2, 0, 1)
    _write_op2(tmp_path / "part.op2", _model(np.zeros((0, 3)), [], "CPENTA"), points, np.zeros(6), modes)

    def deck(solids):
        _model(points, solids, "CPENTA").write_bdf(str(tmp_path / "part.bdf"))
        (tmp_path / "part.bdf").write_text("SOL 103\nCEND\n" + (tmp_path / "part.bdf").read_text())

    deck(cells)
    run, mass, _ = nastran.parse(tmp_path / "part.op2")
    assert nastran_props.of_nodal_mass(mass, run.points).mass == pytest.approx(RHO * BOX.prod(), rel=ROUND)
    notes = " ".join(mass.notes)
    assert f"{len(cells) // 2} solids of the other handedness renumbered" in notes
    assert all(f"{q} within" in notes for q in ("mass", "CG", "inertia"))  # pyNastran takes |volume| of CPENTA
    deck([[cells[1][k] for k in (0, 1, 2, 3, 5, 4)]] + cells[2:])  # top face turned against the bottom
    result = CliRunner().invoke(app, ["info", str(tmp_path / "part.op2")])
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1, result.output
    assert "part.op2: CPENTA 1: expected an element whose Jacobian is positive" in result.output


def test_param_wtmass_of_the_deck_scales_the_mass_as_nastran_does_and_the_checks_divide_it_out(tmp_path):
    from ffrf_advisor.fe.modal import rigid_modes
    from ffrf_advisor.io import nastran

    points, cells = _corner_cells("CHEXA", counts=(2, 1, 1))
    n = len(points)
    modes = np.zeros((6, n, 6))
    modes[:, :, :3] = rigid_modes(points).reshape(n, 3, 6).transpose(2, 0, 1)
    _write_op2(tmp_path / "part.op2", _model(np.zeros((0, 3)), [], "CHEXA"), points, np.zeros(6), modes)
    model = _model(points, cells, "CHEXA")
    model.add_param("WTMASS", [0.25])
    model.write_bdf(str(tmp_path / "part.bdf"))
    (tmp_path / "part.bdf").write_text("SOL 103\nCEND\n" + (tmp_path / "part.bdf").read_text())
    run, mass, _ = nastran.parse(tmp_path / "part.op2")
    assert nastran_props.of_nodal_mass(mass, run.points).mass == pytest.approx(0.25 * RHO * BOX.prod(), rel=ROUND)
    notes = " ".join(mass.notes)
    assert "times PARAM,WTMASS 0.25" in notes and all(f"{q} within" in notes for q in ("mass", "CG", "inertia"))


def test_a_solid_on_a_grid_without_a_mode_shape_is_refused_naming_both():
    points, cells = _corner_cells("CTETRA", counts=(1, 1, 1))
    model = _model(points, cells, "CTETRA")
    with pytest.raises(BodyFileError, match=r"t\.op2: CTETRA 1: expected grids with mode shapes in the OP2 "
                                            r"\(DISP=ALL\), got grid 8"):
        nastran_mass.assembled_mass("t.op2", model, _run(points[:-1], {"CTETRA": len(cells)}))


def test_modes_of_a_lumped_mass_are_flagged_against_the_assembled_consistent_one(tmp_path):
    """Nastran lumps the mass of solids unless PARAM,COUPMASS,1: modes normalised to a lumped mass disagree
    with the consistent mass the reader assembles, and the provenance and the checks say so."""
    from ffrf_advisor.checks import run_checks
    from ffrf_advisor.fe.assembly import stiffness_matrix
    from ffrf_advisor.fe.material import Material
    from ffrf_advisor.fe.modal import free_free_modes, rigid_modes
    from ffrf_advisor.io import read_body

    points, cells = _corner_cells("CTETRA", counts=(2, 1, 1))
    mesh = Mesh(points, {"tetra": np.array(cells)})
    modal = free_free_modes(stiffness_matrix(mesh, Material("steel", E, NU, RHO)),
                            mass_matrix(mesh, RHO, lumping="rowsum"), points, N_FLEX)
    n = len(points)
    modes = np.zeros((6 + N_FLEX, n, 6))
    modes[:, :, :3] = np.concatenate([rigid_modes(points).reshape(n, 3, 6), modal.Phi], axis=2).transpose(2, 0, 1)
    _write_op2(tmp_path / "lumped.op2", _model(points, cells, "CTETRA"), points,
               np.r_[np.zeros(6), modal.eigenvalues], modes)
    body = read_body(tmp_path / "lumped.op2")
    assert "PARAM,COUPMASS,1 or MAAX punched beside the OP2" in " ".join(body.provenance.notes)
    assert not next(c for c in run_checks(body) if c.name == "mass_normalisation").passed
