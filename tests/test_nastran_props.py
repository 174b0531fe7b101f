"""The Nastran reader's mass checked against the model's own mass data (issue 48): the grid point weight
generator's table of a real OP2 (../shared/data/nastran, read-only) and pyNastran's mass properties."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

pytest.importorskip("pyNastran", reason="the Nastran reader's optional extra (pip install '.[nastran]')")

from ffrf_advisor.errors import BodyFileError  # noqa: E402
from ffrf_advisor.io import nastran, nastran_mass, nastran_props  # noqa: E402

from .test_nastran_solids import (BOX, CORNERS, E, NU, RHO, ROUND, _box_inertia, _corner_cells, _model,  # noqa: E402
                                  _quadratic, _run)

BEAM = Path(__file__).resolve().parents[2] / "shared" / "data" / "nastran" / "beam_modes_m1.op2"
needs_data = pytest.mark.skipif(not BEAM.is_file(), reason=f"the shared Nastran file is not at {BEAM}")


@needs_data
def test_a_real_beams_mass_agrees_with_its_weight_generator_and_pyNastran_and_a_wrong_one_is_named():
    """CBAR, CBEAM and a CONM2 of a real MSC run: the assembled mass against PARAM,GRDPNT's table and
    pyNastran's mass properties (the elements' own inertia added: lumped at the grids, CBEAM's torsion)."""
    m = nastran._load(BEAM)
    run = nastran._modes(BEAM, m)
    mass = nastran_mass.assembled_mass(BEAM, m, run)
    notes = nastran_props.checked(BEAM, m, mass, run.points, True)
    assert "grid point weight generator" in notes[0]
    assert all(f"{q} within" in notes[1] for q in ("mass", "CG", "inertia")) and "approximates" not in notes[1]
    m.add_param("WTMASS", [0.5])  # Nastran's mass halved; its weight generator divides WTMASS out
    halved = nastran_mass.assembled_mass(BEAM, m, run)
    assert halved.Ms.sum() == pytest.approx(0.5 * mass.Ms.sum(), rel=ROUND)
    notes = nastran_props.checked(BEAM, m, halved, run.points, True)
    assert "grid point weight generator" in notes[0] and all(f"{q} within" in notes[1] for q in ("mass", "inertia"))
    del m.params["WTMASS"]
    gpwg = next(iter(m.grid_point_weight.values()))
    gpwg.mass = np.asarray(gpwg.mass) * (1 + 1e-5)  # 10 x the tolerance
    with pytest.raises(BodyFileError, match=r"beam_modes_m1\.op2: grid point weight generator \(PARAM,GRDPNT\): "
                                            r"expected its mass to agree with the assembled mass within 1e-06, "
                                            r"got Nastran's [\d.e-]+ against [\d.e-]+"):
        nastran_props.checked(BEAM, m, mass, run.points, True)


@pytest.mark.parametrize("kind", [k for k in CORNERS if k != "CPYRAM"])
def test_a_turned_box_with_a_point_mass_agrees_with_pyNastran_in_every_product_of_inertia(kind):
    Q = Rotation.from_rotvec([0.3, -0.5, 0.8]).as_matrix()
    points, cells = _corner_cells(kind)
    points, cells, _ = _quadratic(kind, points, cells)
    points = points @ Q.T + [100.0, -50.0, 30.0]
    model = _model(points, cells, kind, conm2=[(3, 1e-5, (1e-3, 0, 2e-3, 0, 0, 3e-3))])
    mass = nastran_mass.assembled_mass("box.bdf", model, _run(points, {kind: len(cells), "CONM2": 1}))
    note = nastran_props.checked("box.bdf", model, mass, points, True)[0]
    assert all(f"{q} within" in note for q in ("mass", "CG", "inertia")), note
    box = nastran_props.of_nodal_mass(nastran_mass.assembled_mass("box.bdf", _model(points, cells, kind),
                                                                  _run(points, {kind: len(cells)})), points)
    exact = RHO * BOX.prod()
    assert np.allclose(box.cg, Q @ BOX / 2 + [100.0, -50.0, 30.0], rtol=0, atol=ROUND * 100)
    assert np.allclose(box.inertia, Q @ _box_inertia(exact) @ Q.T, rtol=0, atol=ROUND * _box_inertia(exact).max())
    mass.J[5] += 1e-4 * np.abs(box.inertia).max() * np.eye(3)  # 100 x the tolerance on one grid
    with pytest.raises(BodyFileError, match=r"box\.bdf: mass properties: expected the assembled inertia"):
        nastran_props.checked("box.bdf", model, mass, points, True)


def test_a_conm2_in_a_turned_frame_keeps_its_inertia():
    """pyNastran's CONM2.Inertia gives zeros for a CID frame: the reader turns I to basic itself."""
    points, cells = _corner_cells("CHEXA", counts=(1, 1, 1))
    model = _model(points, cells, "CHEXA")
    Q = Rotation.from_rotvec([0.0, 0.0, np.pi / 2]).as_matrix()  # x' = y, y' = -x
    model.add_cord2r(5, [0.0, 0.0, 0.0], [0.0, 0.0, 1.0], list(Q[:, 0]))
    model.add_conm2(901, 1, 1e-5, cid=5, I=[1e-3, 0, 2e-3, 0, 0, 3e-3])
    model.cross_reference()
    mass = nastran_mass.assembled_mass("c.bdf", model, _run(points, {"CHEXA": 1, "CONM2": 1}))
    assert np.allclose(mass.J[0], np.diag([2e-3, 1e-3, 3e-3]), rtol=1e-12)  # I11 about x' = y
    note = nastran_props.checked("c.bdf", model, mass, points, True)[0]
    assert "1 CONM2" in note and "mass within" in note


def _plate_model(quadratic: bool):
    """A 40 x 20 plate, thickness 2, half CQUAD4 (CQUAD8) and half CTRIA3 (CTRIA6), PSHELL with MAT1 RHO."""
    from cpylog import SimpleLogger
    from pyNastran.bdf.bdf import BDF

    step = 5.0 if quadratic else 10.0  # quadratic elements take every other grid as a mid-side grid
    xs, ys = np.arange(0, 40.0 + step / 2, step), np.arange(0, 20.0 + step / 2, step)
    grid = {(i, j): k + 1 for k, (i, j) in enumerate((i, j) for j in range(len(ys)) for i in range(len(xs)))}
    model = BDF(log=SimpleLogger(level="critical"))
    for (i, j), g in grid.items():
        model.add_grid(g, [xs[i], ys[j], 0.0])
    model.add_mat1(1, E, None, NU, rho=RHO)
    model.add_pshell(1, mid1=1, t=2.0, mid2=1)
    s = 2 if quadratic else 1
    for e, (i, j) in enumerate((i, j) for i in range(0, len(xs) - 1, s) for j in range(0, len(ys) - 1, s)):
        c = [grid[i, j], grid[i + s, j], grid[i + s, j + s], grid[i, j + s]]
        if i < (len(xs) - 1) // 2:
            mids = [grid[i + 1, j], grid[i + 2, j + 1], grid[i + 1, j + 2], grid[i, j + 1]] if quadratic else []
            (model.add_cquad8 if quadratic else model.add_cquad4)(10 * e + 1, 1, c + mids)
        else:
            for t, (a, b, d) in enumerate(((0, 1, 2), (0, 2, 3))):
                tri = [c[a], c[b], c[d]]
                if quadratic:
                    corner = [(i, j), (i + 2, j), (i + 2, j + 2), (i, j + 2)]
                    edges = ((a, b), (b, d), (d, a))
                    tri += [grid[tuple((np.add(corner[p], corner[q]) // 2).tolist())] for p, q in edges]
                (model.add_ctria6 if quadratic else model.add_ctria3)(10 * e + 2 + t, 1, tri)
    model.cross_reference()
    return model


@pytest.mark.parametrize("quadratic", [False, True])
def test_a_plate_of_quads_and_triangles_has_the_analytic_mass_and_pyNastrans_properties(quadratic):
    model = _plate_model(quadratic)
    gids = np.array(sorted(model.nodes))
    points = np.array([model.nodes[g].get_position() for g in gids])
    types = {}
    for e in model.elements.values():
        types[e.type] = types.get(e.type, 0) + 1
    run = _run(points, types)
    run.grids = gids
    mass = nastran_mass.assembled_mass("plate.bdf", model, run)
    got = nastran_props.of_nodal_mass(mass, points)
    exact = RHO * 40.0 * 20.0 * 2.0
    assert got.mass == pytest.approx(exact, rel=ROUND)
    assert np.allclose(got.cg, [20.0, 10.0, 0.0], rtol=0, atol=ROUND * 40)
    assert np.abs(mass.J).max() == 0  # shells lumped without rotary inertia (as Nastran's lumped mass)
    note = nastran_props.checked("plate.bdf", model, mass, points, True)[0]
    assert all(f"{q} within" in note for q in ("mass", "CG", "inertia")), note


def test_a_model_over_the_element_limit_is_not_compared_and_says_so(monkeypatch):
    points, cells = _corner_cells("CTETRA")
    model = _model(points, cells, "CTETRA")
    mass = nastran_mass.assembled_mass("t.bdf", model, _run(points, {"CTETRA": len(cells)}))
    monkeypatch.setattr(nastran_props, "MAX_ELEMENTS", len(cells) - 1)
    note = nastran_props.checked("t.bdf", model, mass, points, True)[-1]
    assert note.startswith(f"pyNastran's mass properties not compared: {len(cells)} cards")


def test_mirrored_tetrahedra_keep_the_mass_and_are_not_compared_with_pyNastrans_signed_volumes():
    points, cells = _corner_cells("CTETRA")
    cells = [c if k % 3 else [c[0], c[2], c[1], c[3]] for k, c in enumerate(cells)]
    model = _model(points, cells, "CTETRA")
    mass = nastran_mass.assembled_mass("t.bdf", model, _run(points, {"CTETRA": len(cells)}))
    assert nastran_props.of_nodal_mass(mass, points).mass == pytest.approx(RHO * BOX.prod(), rel=ROUND)
    note = nastran_props.checked("t.bdf", model, mass, points, True)[0]
    assert f"approximates {len(cells[::3])} CTETRA with 4 grids" in note and "nothing compared" in note


@pytest.mark.parametrize("kind, warp", [(k, w) for k in ("CPENTA", "CHEXA") for w in ("shear", "heights")])
def test_oblique_or_tapered_prisms_keep_the_mass_and_are_not_compared_with_pyNastrans_right_prisms(kind, warp):
    """x += 0.3 z (oblique prisms), or the middle layer of grids moved up and down (top faces not the bottom
    moved): the box's volume is kept, which pyNastran measures as mean face area times the distance of the
    face centres (a few % off)."""
    points, cells = _corner_cells(kind)
    if warp == "shear":
        points = points + 0.3 * points[:, 2:3] * [1.0, 0.0, 0.0]
    else:
        middle = points[:, 2] == BOX[2] / 2
        points[middle, 2] += np.random.default_rng(4).uniform(-1.0, 1.0, middle.sum())
    model = _model(points, cells, kind)
    mass = nastran_mass.assembled_mass("s.bdf", model, _run(points, {kind: len(cells)}))
    assert nastran_props.of_nodal_mass(mass, points).mass == pytest.approx(RHO * BOX.prod(), rel=ROUND)
    note = nastran_props.checked("s.bdf", model, mass, points, True)[0]
    assert f"approximates {len(cells)} {kind} with " in note and "nothing compared" in note


@pytest.mark.parametrize("kind", ["CPENTA", "CHEXA"])
def test_right_prisms_on_uneven_bases_are_compared_where_pyNastrans_centroid_holds(kind):
    """Interior columns of grids moved sideways (the same in every layer): right prisms on uneven bases.
    pyNastran's CPENTA centroid (mean of the triangles' corners) is right, its CHEXA one (mean of the quads'
    corners) is not the centroid of an uneven quadrilateral."""
    points, cells = _corner_cells(kind, counts=(4, 3, 2))
    inside = (points[:, 0] > 0) & (points[:, 0] < BOX[0]) & (points[:, 1] > 0) & (points[:, 1] < BOX[1])
    columns = {tuple(p[:2]) for p in points[inside]}
    shift = dict(zip(sorted(columns), np.random.default_rng(5).uniform(-1.5, 1.5, (len(columns), 2))))
    points[inside, :2] += [shift[tuple(p[:2])] for p in points[inside]]
    model = _model(points, cells, kind)
    mass = nastran_mass.assembled_mass("u.bdf", model, _run(points, {kind: len(cells)}))
    assert nastran_props.of_nodal_mass(mass, points).mass == pytest.approx(RHO * BOX.prod(), rel=ROUND)
    note = nastran_props.checked("u.bdf", model, mass, points, True)[0]
    assert all(f"{q} within" in note for q in ("mass", "CG", "inertia")) == (kind == "CPENTA"), note


MULTI = BEAM.parent / "modes_elements.op2"


@needs_data
def test_the_solids_of_a_real_msc_model_have_pyNastrans_element_masses():
    """modes_elements.op2 (MSC): CHEXA, two CPENTA, two CTETRA; each element alone through the reader's map."""
    from ffrf_advisor.io import nastran_solids

    m = nastran._load(MULTI)
    run = nastran._modes(MULTI, m)
    index = {int(g): i for i, g in enumerate(run.grids)}
    solids = [e for e in m.elements.values() if e.type in nastran_solids.SOLIDS]
    assert sorted(e.type for e in solids) == ["CHEXA", "CPENTA", "CPENTA", "CTETRA", "CTETRA"]
    for e in solids:
        nodes = [index[g] for g in e.nodes if g is not None]
        cell = nastran_solids.cell_of(MULTI, e, nodes)
        conn, _ = nastran_solids.oriented(cell, np.array([nastran_solids.to_vtk(cell, nodes)]), run.points)
        block = nastran_solids.solid_mass(MULTI, run.points, cell, conn, np.array([e.eid]), float(e.Rho()))
        assert block.sum() == pytest.approx(float(e.Mass()), rel=ROUND), e.eid  # right prisms and tetrahedra
