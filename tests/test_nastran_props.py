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

from .test_nastran_solids import (BOX, CORNERS, RHO, ROUND, _box_inertia, _corner_cells, _model,  # noqa: E402
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
