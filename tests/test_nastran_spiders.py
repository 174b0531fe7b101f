"""Masses on rigid (RBE2) and interpolating (RBE3) spiders through the Nastran reader (issue 48): the modes of a
tet10 part with its spider solved by the FE module's K and Ms, written as an OP2 with pyNastran, read back."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

pytest.importorskip("pyNastran", reason="the Nastran reader's optional extra (pip install '.[nastran]')")

from ffrf_advisor.checks import run_checks  # noqa: E402
from ffrf_advisor.fe.assembly import mass_matrix, stiffness_matrix  # noqa: E402
from ffrf_advisor.fe.material import Material  # noqa: E402
from ffrf_advisor.fe.mesh import Mesh  # noqa: E402
from ffrf_advisor.io import read_body  # noqa: E402

from .test_nastran_solids import (BOX, E, FLOAT32, N_FLEX, NU, RHO, _box_inertia, _corner_cells,  # noqa: E402
                                  _model, _quadratic, _write_op2)

HUB, TIP = np.array([20.0, 10.0, 25.0]), np.array([20.0, 10.0, 35.0])  # above the part's top face (z = 10)


def _skew(a: np.ndarray) -> np.ndarray:
    return np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])


def _rigid(x: np.ndarray, about: np.ndarray) -> np.ndarray:
    """(3 x 6): the translation at x of a rigid motion (u, theta) about ``about``: u - (x - about)~ theta."""
    return np.hstack([np.eye(3), -_skew(x - about)])


def _part():
    points, cells = _corner_cells("CTETRA", counts=(2, 1, 1))
    points, nastran, vtk = _quadratic("CTETRA", points, cells)
    return points, nastran, vtk, [i for i in range(len(points)) if points[i, 2] == BOX[2]]


def _modes(points, vtk, grids, T):
    """Free-free modes of the part with extra 6-DOF grids carrying (mass, inertia) each, their DOFs given by the
    reduced ones through T (full = T reduced): eigenvalues and modes (nm, n + k, 6), mass-normalised."""
    mesh = Mesh(points, {"tetra10": np.array(vtk)})
    n, k = len(points), len(grids)
    nd = 3 * n + 6 * k
    K, M = np.zeros((nd, nd)), np.zeros((nd, nd))
    K[:3 * n, :3 * n] = stiffness_matrix(mesh, Material("steel", E, NU, RHO)).toarray()
    M[:3 * n, :3 * n] = np.kron(mass_matrix(mesh, RHO).toarray(), np.eye(3))
    for j, (m, J) in enumerate(grids):
        M[3 * n + 6 * j:3 * n + 6 * j + 6, 3 * n + 6 * j:3 * n + 6 * j + 6] = sla.block_diag(m * np.eye(3), J)
    lam, V = sla.eigh(T.T @ K @ T, T.T @ M @ T, subset_by_index=[0, 5 + N_FLEX])
    full = T @ V
    modes = np.zeros((len(lam), n + k, 6))
    modes[:, :n, :3] = full[:3 * n].T.reshape(-1, n, 3)
    modes[:, n:] = full[3 * n:].T.reshape(-1, k, 6)
    lam[:6] = 0.0  # rigid: zero to round-off of the dense solve
    return lam, modes


def _rbe2(points, top) -> np.ndarray:
    """Reduced DOFs: the part's grids off the top face, then the hub's six; the top grids' translations and the
    tip's six DOFs follow the hub rigidly."""
    n = len(points)
    free = [i for i in range(n) if i not in set(top)]
    T = np.zeros((3 * n + 12, 3 * len(free) + 6))
    for j, i in enumerate(free):
        T[3 * i:3 * i + 3, 3 * j:3 * j + 3] = np.eye(3)
    hub = slice(3 * len(free), 3 * len(free) + 6)
    for i in top:
        T[3 * i:3 * i + 3, hub] = _rigid(points[i], HUB)
    T[3 * n:3 * n + 6, hub] = np.eye(6)
    T[3 * n + 6:3 * n + 9, hub] = _rigid(TIP, HUB)
    T[3 * n + 9:3 * n + 12, hub] = np.hstack([np.zeros((3, 3)), np.eye(3)])
    return T


def _rbe3(points, top) -> np.ndarray:
    """Reduced DOFs: the part's grids; the tip's six DOFs the least-squares rigid fit of the top grids'
    translations (equal weights), an interpolation as RBE3 makes."""
    n = len(points)
    A = np.vstack([_rigid(points[i], TIP) for i in top])
    G = np.linalg.solve(A.T @ A, A.T)  # (6, 3 n_top)
    T = np.zeros((3 * n + 6, 3 * n))
    T[:3 * n] = np.eye(3 * n)
    for j, i in enumerate(top):
        T[3 * n:, 3 * i:3 * i + 3] = G[:, 3 * j:3 * j + 3]
    return T


def _i6(J: np.ndarray) -> tuple:
    """A CONM2's I11, I21, I22, I31, I32, I33 of an inertia tensor (off-diagonals -I21, ...)."""
    return (J[0, 0], -J[1, 0], J[1, 1], -J[2, 0], -J[2, 1], J[2, 2])


def _expected(grids):
    """Mass and principal moments of the part (RHO in float32, as the OP2 holds it) and point masses."""
    part = float(np.float32(RHO)) * BOX.prod()
    masses = [(part, BOX / 2, _box_inertia(part)), *grids]
    total = sum(m for m, _, _ in masses)
    cg = sum(m * c for m, c, _ in masses) / total
    I = sum(J + m * (np.dot(c - cg, c - cg) * np.eye(3) - np.outer(c - cg, c - cg)) for m, c, J in masses)
    return total, np.linalg.eigvalsh(I)


def _read_and_check(path, grids, lam):
    body = read_body(path)
    total, moments = _expected(grids)
    assert body.mass == pytest.approx(total, rel=FLOAT32)  # the CONM2s' masses are float32 in the OP2 too
    assert np.allclose(np.linalg.eigvalsh(body.I0), moments, rtol=FLOAT32)
    assert np.allclose(body.eigenvalues, lam[6:], rtol=FLOAT32)
    checks = run_checks(body)
    assert all(c.passed for c in checks), [(c.name, c.value, c.tolerance) for c in checks if not c.passed]
    assert body.fe.rotary is not None and len(body.fe.rotary.nodes) == len(grids)  # the CONM2s' inertia
    notes = " ".join(body.provenance.notes)
    assert "warning" not in notes and "mass within" in notes, notes


def test_masses_on_an_rbe2_spider_are_carried_exactly_by_the_grids_recovered_motion(tmp_path):
    """A CONM2 on the spider's independent grid and one on a dependent grid above it: rigid elements carry no
    mass, and each CONM2 moves with its grid's motion in the OP2 (recovered by Nastran at dependent grids), so
    the modes' generalised masses come out exactly; without the dependent grid's CONM2 they do not."""
    points, nastran, vtk, top = _part()
    n, part = len(points), RHO * BOX.prod()
    hub, tip = (0.5 * part, np.diag([2e-3, 3e-3, 4e-3])), (0.8 * part, np.diag([5e-3, 1e-3, 2e-3]))
    lam, modes = _modes(points, vtk, [hub, tip], _rbe2(points, top))

    def write(path, with_tip: bool):
        conm2 = [(n, hub[0], _i6(hub[1]))] + ([(n + 1, tip[0], _i6(tip[1]))] if with_tip else [])
        model = _model(np.vstack([points, HUB, TIP]), nastran, "CTETRA", conm2)
        model.add_rbe2(800, n + 1, "123", [i + 1 for i in top])
        model.add_rbe2(801, n + 1, "123456", [n + 2])
        _write_op2(path, model, np.vstack([points, HUB, TIP]), lam, modes)

    write(tmp_path / "spider.op2", True)
    _read_and_check(tmp_path / "spider.op2", [(hub[0], HUB, hub[1]), (tip[0], TIP, tip[1])], lam)
    write(tmp_path / "dropped.op2", False)  # the same modes without the dependent grid's CONM2
    dropped = read_body(tmp_path / "dropped.op2")
    assert "warning: more than float32 round-off" in " ".join(dropped.provenance.notes)


def test_a_mass_on_an_rbe3_reference_grid_is_carried_exactly_by_its_interpolated_motion(tmp_path):
    points, nastran, vtk, top = _part()
    n, tip = len(points), (0.6 * RHO * BOX.prod(), np.diag([3e-3, 2e-3, 1e-3]))
    lam, modes = _modes(points, vtk, [tip], _rbe3(points, top))
    model = _model(np.vstack([points, TIP]), nastran, "CTETRA", [(n, tip[0], _i6(tip[1]))])
    model.add_rbe3(810, n + 1, "123456", [1.0], ["123"], [[i + 1 for i in top]])
    _write_op2(tmp_path / "rbe3.op2", model, np.vstack([points, TIP]), lam, modes)
    _read_and_check(tmp_path / "rbe3.op2", [(tip[0], TIP, tip[1])], lam)
