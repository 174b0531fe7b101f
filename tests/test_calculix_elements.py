"""CalculiX's results of one L-bracket with a hole (tests/gmsh_parts.py) in each solid element type, with a point
mass and with a spider carrying a mass, solved free-free by ``ccx`` and read through both routes: CalculiX's
stored matrices (.mas/.dof) and the deck alone (.frd + .dat + .inp). Checked against what CalculiX wrote: its
.mas (parsed here on its own), its .dat frequencies and effective-mass total."""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from ffrf_advisor.analysis import Options, analyze
from ffrf_advisor.amplitudes import q_max
from ffrf_advisor.checks import run_checks
from ffrf_advisor.errors import BodyFileError
from ffrf_advisor.fe.material import STEEL
from ffrf_advisor.guidelines import Situation
from ffrf_advisor.io import read_body
from ffrf_advisor.io.calculix_deck import write_deck
from ffrf_advisor.significance import significance

from .gmsh_parts import HOLE, THICKNESS, l_bracket, l_profile

pytestmark = pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (ccx) is not installed")
NF = 6
POINT_MASS = 1e-4  # t: about 0.7 of the bracket's 1.35e-4 t, so a dropped mass cannot hide
REF, ROT = 900001, 900002  # the spider's REF and ROT NODE (not in any solid element)


def _solve(directory: Path, mesh, extra=(), storage=False) -> Path:
    directory.mkdir(parents=True, exist_ok=True)
    write_deck(mesh, STEEL, NF, directory / "part.inp", matrix_storage=storage, extra=tuple(extra))
    done = subprocess.run(["ccx", "part"], cwd=directory, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0 and "Job finished" in done.stdout, done.stdout[-2000:]
    return directory / "part.frd"


def _routes(root: Path, mesh, extra=()) -> dict[str, Path]:
    """The deck-only run, and a copy of it with the .mas/.dof/.sti of a MATRIXSTORAGE run of the same deck."""
    deck = _solve(root / "deck", mesh, extra)
    _solve(root / "matrices", mesh, extra, storage=True)
    shutil.copytree(root / "deck", root / "stored")
    for suffix in (".mas", ".dof", ".sti"):
        shutil.copy(root / "matrices" / f"part{suffix}", root / "stored" / f"part{suffix}")
    return {"deck": deck, "stored": root / "stored" / "part.frd"}


def _mas(directory: Path):
    """CalculiX's mass matrix (rows as in the .dof) and its labels (node, direction), parsed here on its own."""
    labels = [tuple(int(x) for x in w.split(".")) for w in (directory / "part.dof").read_text().split()]
    i, j, v = np.loadtxt(directory / "part.mas").T
    M = np.zeros((len(labels), len(labels)))
    M[i.astype(int) - 1, j.astype(int) - 1] = v
    M[j.astype(int) - 1, i.astype(int) - 1] = v
    return M, labels


def _rigid_mass(directory: Path, points: dict[int, np.ndarray], rot=()) -> tuple[float, np.ndarray]:
    """Total mass and inertia tensor about the centre of mass from the .mas by rigid motions of its rows:
    translations e_a on every translational row, rotations theta x x (and theta on a ROT NODE's rows)."""
    M, labels = _mas(directory)
    node, c = np.array(labels).T
    x = np.array([points[n] for n in node])
    turning = np.isin(node, list(rot))
    E = np.eye(3)
    T = np.array([np.where(turning, 0.0, E[a][c - 1]) for a in range(3)])  # translation a, row by row
    R = np.array([np.where(turning, E[a][c - 1], np.cross(E[a], x)[np.arange(len(c)), c - 1]) for a in range(3)])
    mass = float((T @ M @ T.T).trace() / 3)
    first = T @ M @ R.T  # (e_a . (e_b x m c)): the first moment m c
    centre = np.array([first[1, 2], first[2, 0], first[0, 1]]) / mass
    return mass, R @ M @ R.T - mass * (centre @ centre * np.eye(3) - np.outer(centre, centre))


def _dat(directory: Path) -> np.ndarray:
    """The .dat's frequencies (cycles/time column) of the flexible modes."""
    lines = (directory / "part.dat").read_text().splitlines()
    start = next(k for k, line in enumerate(lines) if "E I G E N V A L U E   O U T P U T" in line)
    rows = []
    for line in lines[start + 1:]:
        if rows and not line.split():
            break
        if line.split() and line.split()[0].isdigit():
            rows.append(float(line.split()[3]))
    return np.array(rows[6:])


def _points(mesh, extra: dict[int, tuple] | None = None) -> dict[int, np.ndarray]:
    out = {k + 1: p for k, p in enumerate(mesh.points)}
    out.update({n: np.array(p) for n, p in (extra or {}).items()})
    return out


# I0 against the .mas's rigid rotations: the stored route takes the .mas itself, the deck route assembles with
# CalculiX's rules from the deck's 13-digit nodes (round-off of the sums and the .mas's 14 printed digits)
I0_TOL = {"deck": 1e-9, "stored": 1e-9}


def _agrees(body, directory: Path, mass: float, inertia: np.ndarray, route: str) -> None:
    assert abs(body.mass / mass - 1) < 1e-6, (body.mass, mass)  # the brief's 1e-6 of CalculiX's .mas
    ours, theirs = np.linalg.eigvalsh(body.I0), np.linalg.eigvalsh(inertia)
    assert np.abs(ours / theirs - 1).max() < I0_TOL[route], (ours, theirs)  # nodal sums vs the .mas's rotations
    assert np.allclose(body.frequencies_hz, _dat(directory), rtol=1e-6)  # .dat: 7 printed digits
    failed = [(c.name, c.value, c.tolerance) for c in run_checks(body) if not c.passed]
    assert not failed, failed


# the default suite: quadratic tetrahedra (17 s with both ccx runs); the rest is slow
CASES = [pytest.param(k, marks=[] if k == "tetra10" else [pytest.mark.slow])
         for k in ("tetra", "tetra10", "wedge", "wedge15", "hexahedron", "hexahedron20")]


@pytest.fixture(scope="module")
def solved(tmp_path_factory):
    cache = {}

    def get(kind):
        if kind not in cache:
            mesh = l_bracket(kind)
            cache[kind] = mesh, _routes(tmp_path_factory.mktemp(kind), mesh)
        return cache[kind]
    return get


@pytest.mark.parametrize("kind", CASES)
def test_each_solid_element_reads_through_both_routes(solved, kind):
    """Connectivity mapped back from the .frd to the deck's (VTK) order exactly; mass and I0 of CalculiX's .mas;
    the .dat's frequencies; every check passes. The deck route assembles the mass itself."""
    mesh, routes = solved(kind)
    mass, inertia = _rigid_mass(routes["stored"].parent, _points(mesh))
    for route, frd in routes.items():
        body = read_body(frd, load_fe=True)
        assert np.array_equal(body.fe.mesh.cells[kind], mesh.cells[kind]), route  # the .frd permutation
        assert any(("matrix storage" in n) == (route == "stored") for n in body.provenance.notes if "mass" in n)
        _agrees(body, frd.parent, mass, inertia, route)


def _mass_card(node: int) -> list[str]:
    return ["*ELEMENT, TYPE=MASS, ELSET=PM", f"{800001}, {node}", "*MASS, ELSET=PM", f"{POINT_MASS!r}"]


@pytest.fixture(scope="module")
def point_mass(tmp_path_factory):
    mesh = l_bracket("tetra10")
    corner = int(np.argmin(np.linalg.norm(mesh.points - [60.0, 0.0, 0.0], axis=1))) + 1
    return mesh, _routes(tmp_path_factory.mktemp("pm"), mesh, _mass_card(corner))


@pytest.mark.slow  # 9 s a route: two ccx runs of the bracket
@pytest.mark.parametrize("route", ["deck", "stored"])
def test_a_point_mass_is_carried_and_a_dropped_one_fails(point_mass, route, tmp_path):
    mesh, routes = point_mass
    mass, inertia = _rigid_mass(routes["stored"].parent, _points(mesh))
    body = read_body(routes[route], load_fe=True)
    _agrees(body, routes[route].parent, mass, inertia, route)
    for suffix in (".frd", ".dat", ".inp", ".mas", ".dof", ".sti"):
        if routes[route].with_suffix(suffix).is_file():
            shutil.copy(routes[route].with_suffix(suffix), tmp_path / f"part{suffix}")
    deck = (tmp_path / "part.inp").read_text()
    (tmp_path / "part.inp").write_text(deck.replace(f"*MASS, ELSET=PM\n{POINT_MASS!r}\n", ""))
    with pytest.raises(BodyFileError, match=r"part\.dat: TOTAL EFFECTIVE MASS") if route == "deck" else _no_error():
        read_body(tmp_path / "part.frd")


class _no_error:
    """The stored route takes the mass from the .mas, which holds the point mass whatever the deck says."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def _spider(mesh) -> list[str]:
    """A *RIGID BODY on the hole's surface nodes with a mass on its REF NODE at the hole's centre."""
    r = np.hypot(mesh.points[:, 0] - HOLE[0], mesh.points[:, 1] - HOLE[1])
    ring = np.flatnonzero(np.abs(r - HOLE[2]) < 1e-6) + 1
    centre = f"{HOLE[0]!r}, {HOLE[1]!r}, {THICKNESS / 2!r}"
    return ["*NODE, NSET=SPIDERREF", f"{REF}, {centre}", f"{ROT}, {centre}", "*NSET, NSET=SPIDER",
            *[", ".join(str(n) for n in ring[k:k + 8]) for k in range(0, len(ring), 8)],
            f"*RIGID BODY, NSET=SPIDER, REF NODE={REF}, ROT NODE={ROT}",
            "*ELEMENT, TYPE=MASS, ELSET=PM", f"800001, {REF}", "*MASS, ELSET=PM", f"{POINT_MASS!r}"]


@pytest.fixture(scope="module")
def spider(tmp_path_factory):
    mesh = l_bracket("tetra10", 12.0)  # coarser than the others: the default suite's share
    return mesh, _routes(tmp_path_factory.mktemp("spider"), mesh, _spider(mesh))


@pytest.mark.parametrize("route", ["deck", pytest.param("stored", marks=pytest.mark.slow)])  # 9 s each
def test_a_spider_carrying_a_mass_is_read_exactly(spider, route, tmp_path):
    """The .dof holds the REF and ROT NODEs (CalculiX reduced the spider's mass onto them): the mass is assembled,
    the REF NODE's mass moves with the spider's rigid fit; mass and I0 equal the reduced .mas's rigid motions
    (a ROT NODE's rows are rotations), frequencies the .dat's; without the *MASS card the .dat total refuses."""
    mesh, routes = spider
    centre = (HOLE[0], HOLE[1], THICKNESS / 2)
    mass, inertia = _rigid_mass(routes["stored"].parent, _points(mesh, {REF: centre, ROT: centre}), rot={ROT})
    body = read_body(routes[route], load_fe=True)
    assert any("REF NODE" in n for n in body.provenance.notes)
    assert body.fe.mesh.n_nodes == mesh.n_nodes + 1
    _agrees(body, routes[route].parent, mass, inertia, "deck")  # both routes assemble: the .mas is reduced
    for suffix in (".frd", ".dat", ".inp"):
        shutil.copy(routes[route].with_suffix(suffix), tmp_path / f"part{suffix}")
    deck = (tmp_path / "part.inp").read_text()
    (tmp_path / "part.inp").write_text(deck.replace(f"*MASS, ELSET=PM\n{POINT_MASS!r}\n", ""))
    with pytest.raises(BodyFileError, match=r"part\.frd: DISP: expected modes of unit modal mass"):
        read_body(tmp_path / "part.frd")


@pytest.mark.slow  # two parts solved by ccx and analysed
def test_hexahedra_and_quadratic_tetrahedra_give_the_same_advice(solved):
    """One part, two meshes: the same level and term set at 0.01, 0.1 and 0.3 of the hexahedral body's lowest
    softening speed s_crit (theory 9)."""
    hexa = read_body(solved("hexahedron20")[1]["deck"], load_fe=True)
    tets = read_body(solved("tetra10")[1]["deck"], load_fe=True)
    s_crit = significance(hexa, q_max(hexa).q_max).s_crit.min()
    for fraction in (0.01, 0.1, 0.3):
        a, b = (analyze(body, Options(situation=Situation(w_op=fraction * s_crit))).advice for body in (hexa, tets))
        assert (a.level, a.terms) == (b.level, b.terms), fraction


# ---------------------------------------------------------------- shells and beams, expanded by CalculiX
SHELL_T = 2.0  # mm


def _flat_deck(directory: Path, points, name: str, cells, section: list[str], storage=False, output=""):
    """A free-free *FREQUENCY deck of shell or beam elements ``name`` (ids from 1, nodes from 1); runs ccx."""
    directory.mkdir(parents=True, exist_ok=True)
    out = ["*NODE, NSET=NALL"] + [f"{k + 1}, " + ", ".join(repr(float(v)) for v in p) for k, p in enumerate(points)]
    out += [f"*ELEMENT, TYPE={name}, ELSET=EALL"] + [", ".join(str(v) for v in (k + 1, *(c + 1)))
                                                    for k, c in enumerate(cells)]
    out += ["*MATERIAL, NAME=MAT", "*ELASTIC", f"{STEEL.E!r}, {STEEL.nu!r}", "*DENSITY", f"{STEEL.rho!r}",
            *section, "*STEP", "*FREQUENCY" + (", SOLVER=MATRIXSTORAGE" if storage else ""), f"{NF + 6}"]
    out += [] if storage else [f"*NODE FILE{output}", "U", "*END STEP"]
    (directory / "part.inp").write_text("\n".join(out + (["*END STEP"] if storage else [])) + "\n")
    done = subprocess.run(["ccx", "part"], cwd=directory, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0 and "Job finished" in done.stdout, done.stdout[-2000:]
    return directory / "part.frd"


def _flat_routes(root: Path, *deck) -> dict[str, Path]:
    frd = _flat_deck(root / "deck", *deck)
    _flat_deck(root / "matrices", *deck, storage=True)
    shutil.copytree(root / "deck", root / "stored")
    for suffix in (".mas", ".dof", ".sti"):
        shutil.copy(root / "matrices" / f"part{suffix}", root / "stored" / f"part{suffix}")
    return {"deck": frd, "stored": root / "stored" / "part.frd"}


SHELL = ("S8R", ["*SHELL SECTION, ELSET=EALL, MATERIAL=MAT", f"{SHELL_T!r}"])


@pytest.fixture(scope="module")
def shell(tmp_path_factory):
    points, cells = l_profile()
    return points, _flat_routes(tmp_path_factory.mktemp("shell"), points, SHELL[0], cells, SHELL[1])


@pytest.mark.parametrize("route", ["deck", "stored"])
def test_s8r_shells_read_as_calculix_expands_them(shell, route):
    """CalculiX's default output: the S8R plate as its expanded C3D20R elements. The stored route matches the .dof's
    rows (labelled with the shell node, once per expanded node) to the .frd's expanded nodes and takes the .mas;
    the deck route assembles them. Mass against the .mas's rigid translations, I_zz (the plate's largest principal
    moment, untouched by the thickness offsets along z) against its rigid rotation about z, frequencies, checks."""
    points, routes = shell
    mass, inertia = _rigid_mass(routes["stored"].parent, _points(type("P", (), {"points": points})))
    body = read_body(routes[route], load_fe=True)
    assert any("S8R read as CalculiX's expansion" in n for n in body.provenance.notes)
    assert any(("matrix storage" in n) == (route == "stored") for n in body.provenance.notes if "mass" in n)
    assert abs(body.mass / mass - 1) < 1e-6  # the brief's 1e-6 of CalculiX's .mas
    # the expanded nodes are the .frd's alone, 6 printed digits (E12.5): 2 x 5e-6 in x^2; and I0_TOL for the deck
    assert abs(np.linalg.eigvalsh(body.I0).max() / inertia[2, 2] - 1) < max(I0_TOL[route], 1e-5)
    assert np.allclose(body.frequencies_hz, _dat(routes[route].parent), rtol=1e-6)  # .dat: 7 digits
    failed = [(c.name, c.value, c.tolerance) for c in run_checks(body) if not c.passed]
    assert not failed, failed


def test_mid_surface_output_is_refused_by_the_element_name(tmp_path):
    points, cells = l_profile(16.0)
    frd = _flat_deck(tmp_path, points, SHELL[0], cells, SHELL[1], output=", OUTPUT=2D")
    with pytest.raises(BodyFileError, match=r"part\.frd: 3C: expected 3D results.*got S8R mid-surface"):
        read_body(frd)


def test_b32_beams_with_a_knot_read_with_their_mass(tmp_path):
    """An L-frame of B32 beams (a knot at the corner): the .dof holds the knot's extra nodes, so both routes assemble
    CalculiX's expanded elements; their mass is rho A L exactly (straight RECT sections). The .dat's x, y, z totals
    differ there (the knot's rotations counted as translations): noted, not checked."""
    corner = [(x, 10.0, 0.0) for x in np.linspace(60.0, 10.0, 11)] + [(10.0, y, 0.0) for y in np.linspace(15, 50, 8)]
    cells = np.array([[2 * k, 2 * k + 2, 2 * k + 1] for k in range(9)])  # B32: end, middle, end
    section = ["*BEAM SECTION, ELSET=EALL, MATERIAL=MAT, SECTION=RECT", "20., 10.", "0., 0., 1."]
    routes = _flat_routes(tmp_path, np.array(corner), "B32", cells[:, [0, 2, 1]], section)
    for route, frd in routes.items():
        body = read_body(frd, load_fe=True)
        assert body.mass == pytest.approx(STEEL.rho * 90.0 * 20.0 * 10.0, rel=1e-12)  # round-off of the sums
        assert any("not checked against the .dat" in n for n in body.provenance.notes)
        assert np.allclose(body.frequencies_hz, _dat(frd.parent), rtol=1e-6)
        assert all(c.passed for c in run_checks(body)), [(c.name, c.value) for c in run_checks(body)]


@pytest.mark.parametrize("name, solid, why", [("S4", "C3D8I", "gives its incompatible modes mass"),
                                              ("S4R", "C3D8R", "integrates its mass at one point")])
def test_four_node_shells_are_refused_without_the_mas_by_their_name(tmp_path, name, solid, why):
    """CalculiX expands S4 into C3D8I and S4R into C3D8R, whose mass the tool does not integrate as CalculiX does:
    refused naming the shell and what CalculiX made of it."""
    points, cells = l_profile(16.0)
    used, corners = np.unique(cells[:, :4], return_inverse=True)
    frd = _flat_deck(tmp_path, points[used], name, corners.reshape(-1, 4), SHELL[1])
    with pytest.raises(BodyFileError, match=rf"part\.frd: 3C: .*got {name} \(expanded into {solid}: CalculiX {why}\)"):
        read_body(frd)


@pytest.mark.slow  # a ccx run per type
@pytest.mark.parametrize("kind", ["tetra10", "wedge15"])
def test_binary_frd_elements_map_to_the_deck_order(tmp_path, kind):
    """*NODE OUTPUT / *ELEMENT OUTPUT write a binary .frd (float32 results): its element records mapped back to the
    deck's (VTK) order exactly, every check passing at the file's 7 digits."""
    mesh = l_bracket(kind, 12.0)
    write_deck(mesh, STEEL, NF, tmp_path / "b.inp", binary=True)
    subprocess.run(["ccx", "b"], cwd=tmp_path, capture_output=True, timeout=300)
    body = read_body(tmp_path / "b.frd")
    assert body.provenance.digits == 7 and np.array_equal(body.fe.mesh.cells[kind], mesh.cells[kind])
    assert all(c.passed for c in run_checks(body)), [(c.name, c.value) for c in run_checks(body)]


def test_a_point_mass_on_a_shell_node_is_refused_by_name(tmp_path):
    """CalculiX keeps a shell node that carries a MASS element and ties it to its expanded nodes, which do not move
    rigidly through the thickness (measured: z of the mid node 2e-3 off the faces'): which motion the mass takes is
    not in the .frd, so the card is refused naming the node, never dropped."""
    points, cells = l_profile(16.0)
    corner = int(np.argmin(np.linalg.norm(points - [60.0, 0.0, 0.0], axis=1))) + 1
    frd = _flat_deck(tmp_path, points, SHELL[0], cells, SHELL[1] + _mass_card(corner))
    with pytest.raises(BodyFileError, match=rf"part\.inp: \*MASS: .*got a mass on node {corner}, which no element"):
        read_body(frd)
