"""CalculiX results against the built-in FE generator on the same mesh (needs `ccx`; .ci/run installs it)."""
from __future__ import annotations

import os
import shutil
import subprocess
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from ffrf_advisor.errors import BodyFileError
from ffrf_advisor.fe.assembly import mass_matrix, stiffness_matrix
from ffrf_advisor.fe_body import modal_body
from ffrf_advisor.fe.material import STEEL
from ffrf_advisor.fe.mesh import box_mesh
from ffrf_advisor.invariants import shape_integrals
from ffrf_advisor.io import read_body
from ffrf_advisor.io.calculix import write_deck

pytestmark = pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (ccx) is not installed")
NF = 6
MESH = box_mesh([200.0, 40.0, 20.0], [5, 2, 1], "hexahedron20")


def _run(directory: Path, job: str, mesh=MESH, **deck) -> Path:
    write_deck(mesh, STEEL, NF, directory / f"{job}.inp", **deck)
    done = subprocess.run(["ccx", job], cwd=directory, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0 and "Job finished" in done.stdout, done.stdout[-2000:]
    return directory / f"{job}.frd"


@pytest.fixture(scope="module")
def reference():
    return modal_body(MESH, STEEL, NF)


@pytest.fixture(scope="module")
def jobs(tmp_path_factory):
    d = tmp_path_factory.mktemp("ccx")
    ascii_frd = _run(d, "ascii")
    binary_frd = _run(d, "binary", binary=True)
    shutil.copy(binary_frd, d / "stored.frd")
    shutil.copy(d / "binary.dat", d / "stored.dat")
    _run(d, "stored_matrices", matrix_storage=True)
    for suffix in (".mas", ".sti", ".dof"):
        os.replace(d / f"stored_matrices{suffix}", d / f"stored{suffix}")
    return {"ascii": ascii_frd, "binary": binary_frd, "stored": d / "stored.frd"}


def _signs_aligned(body, reference):
    """Mode signs are arbitrary: flip the read modes to match the reference, recompute the integrals."""
    s = np.sign(np.einsum("iap,iap->p", body.fe.Phi, reference.fe.Phi))
    Phi = body.fe.Phi * s
    return replace(body, integrals=shape_integrals(body.fe.mesh.points, body.fe.Ms, Phi))


@pytest.mark.parametrize("job", ["ascii", "binary", "stored"])
def test_calculix_agrees_with_the_built_in_generator(jobs, reference, job):
    body = read_body(jobs[job])
    assert body.nf == NF
    assert np.array_equal(body.fe.mesh.cells["hexahedron20"], MESH.cells["hexahedron20"])  # frd order mapped back
    assert np.abs(body.fe.mesh.points - reference.fe.mesh.points).max() < 1e-9
    assert np.abs(body.eigenvalues / reference.eigenvalues - 1).max() < 1e-5  # .dat: 7 digits
    aligned = _signs_aligned(body, reference)
    for name, tol in (("I0", 1e-12), ("W1", 1e-4), ("W2", 1e-5), ("W3", 1e-5)):  # .frd modes: 6 digits
        ref = getattr(reference, name)
        assert np.abs(getattr(aligned, name) - ref).max() <= tol * np.abs(ref).max(), name
    assert np.abs(body.sigma_max / reference.sigma_max - 1).max() < 1e-3
    assert any("6 rigid dropped" in n for n in body.provenance.notes)


def test_stored_mass_and_stiffness_equal_the_assembled_ones(jobs):
    stored = read_body(jobs["stored"], load_fe=True)
    assert any("mass and stiffness: CalculiX matrix storage" in n for n in stored.provenance.notes)
    Ms = mass_matrix(MESH, STEEL.rho)
    assert abs(stored.fe.Ms - Ms).max() < 1e-9 * abs(Ms).max()
    K = stiffness_matrix(MESH, STEEL)  # the stored body is in the same (principal, CoM) frame: no rotation
    assert abs(stored.fe.K - K).max() < 1e-9 * abs(K).max()


def test_eigenvalues_fall_back_to_the_frd_frequencies(jobs, reference, tmp_path):
    shutil.copy(jobs["ascii"], tmp_path / "alone.frd")
    shutil.copy(jobs["ascii"].with_suffix(".inp"), tmp_path / "alone.inp")
    body = read_body(tmp_path / "alone.frd")
    assert any("from .frd" in n for n in body.provenance.notes)
    assert np.abs(body.eigenvalues / reference.eigenvalues - 1).max() < 2e-5  # 6 digits of f, squared


def test_a_constrained_body_is_reported(tmp_path):
    frd = _run(tmp_path, "held")
    deck = (tmp_path / "held.inp").read_text().replace("*STEP", "*BOUNDARY\n1, 1, 3\n*STEP")
    (tmp_path / "held.inp").write_text(deck)
    subprocess.run(["ccx", "held"], cwd=tmp_path, capture_output=True, timeout=300)
    body = read_body(frd)
    assert any("instead of six" in n and "constrained" in n for n in body.provenance.notes)


def test_without_deck_or_matrices_the_mass_is_missing(jobs, tmp_path):
    shutil.copy(jobs["ascii"], tmp_path / "bare.frd")
    with pytest.raises(BodyFileError, match="DENSITY"):
        read_body(tmp_path / "bare.frd")


@pytest.mark.parametrize("job, digits", [("ascii", 6), ("binary", 7)])
def test_calculix_files_pass_their_checks_at_their_own_precision(jobs, job, digits):
    """A 6-digit ASCII .frd cannot show mass normalisation better than about 1e-5 (issue 12): the reader
    records the precision and the checks widen their tolerances to it, and say so."""
    from ffrf_advisor.checks import run_checks
    body = read_body(jobs[job])
    assert body.provenance.digits == digits
    checks = run_checks(body)
    assert all(c.passed for c in checks), [(c.name, c.value, c.tolerance) for c in checks if not c.passed]
    normalisation = next(c for c in checks if c.name == "mass_normalisation")
    assert normalisation.tolerance == pytest.approx(10.0 ** (1 - digits)) and str(digits) in normalisation.precision


def test_a_truncated_or_nan_ascii_result_block_is_refused(jobs, tmp_path):
    """A result block that lost records (or holds NaN) was read with zeros; now it names the block."""
    text = jobs["ascii"].read_text()
    lines = text.splitlines(keepends=True)
    first = next(i for i, line in enumerate(lines) if line.startswith(" -4  DISP"))
    record = next(i for i in range(first, len(lines)) if lines[i].startswith(" -1"))
    cut = tmp_path / "cut.frd"
    cut.write_text("".join(lines[:record] + lines[record + 1:]))
    with pytest.raises(BodyFileError, match="DISP.*truncated"):
        read_body(cut)
    nan = tmp_path / "nan.frd"
    line = lines[record]
    lines[record] = line[:13] + "         nan" + line[25:]
    nan.write_text("".join(lines))
    with pytest.raises(BodyFileError, match="finite values"):
        read_body(nan)


def test_the_deck_material_gives_the_static_response_and_geometric_stiffness(jobs, reference):
    """*ELASTIC and *DENSITY of the deck: the body carries its material, the static centrifugal response and
    G_kl like the built-in generator (modes from the .frd: 6 digits, so 1e-4 on what they carry)."""
    body = read_body(jobs["ascii"], load_fe=True)
    assert body.fe.material.E == STEEL.E and body.fe.material.nu == STEEL.nu and body.fe.material.rho == STEEL.rho
    ref = reference  # the generator computes both too
    assert np.allclose(body.static_centrifugal.sigma, ref.static_centrifugal.sigma, rtol=1e-9)
    assert np.allclose(body.static_centrifugal.compliance, ref.static_centrifugal.compliance, rtol=1e-9)
    s = np.sign(np.einsum("iap,iap->p", body.fe.Phi, reference.fe.Phi))
    G = body.geometric * s[:, None] * s[None, :]
    assert np.abs(G - ref.geometric).max() <= 1e-4 * np.abs(ref.geometric).max()
    assert any("material from the deck" in n for n in body.provenance.notes)


def test_prestressed_spinning_frequencies_agree_with_calculix_perturbation_step(tmp_path):
    """Spin 8000 rad/s about the y axis through the centre: CalculiX's *STATIC step with *DLOAD CENTRIF and a
    *FREQUENCY, PERTURBATION step after it, on the 3-2-1 supports our static solution uses (CalculiX needs
    supports; they carry no reaction). Ours on all DOFs with the same supports: K + s^2 (K_G(sigma_c) -
    kron(Ms, I - a a^T)). Measured: the five positive eigenvalues agree to 0.5 % (CalculiX evaluates the
    prestress at its integration points, we at ours from the same displacement field), and both find the
    lowest one negative (the spin-softened mode)."""
    from ffrf_advisor.centrifugal import centrifugal_loads, static_deflections, support_dofs
    from ffrf_advisor.fe.assembly import full_mass, mass_matrix, stiffness_matrix
    from ffrf_advisor.fe.geometric import geometric_scalar
    from ffrf_advisor.io.calculix import _dat_eigenvalues  # noqa: F401
    import scipy.linalg as sla
    X = MESH.points
    c = X.mean(axis=0)
    s, a = 8000.0, np.array([0.0, 1.0, 0.0])
    supports = support_dofs(X - c)
    write_deck(MESH, STEEL, NF, tmp_path / "base.inp")
    lines = (tmp_path / "base.inp").read_text().splitlines()
    deck = lines[:lines.index("*STEP")] + ["*BOUNDARY"] + [f"{d // 3 + 1}, {d % 3 + 1}, {d % 3 + 1}" for d in supports]
    deck += ["*STEP", "*STATIC", "*DLOAD",
             f"EALL, CENTRIF, {s * s:.17g}, {c[0]:.17g}, {c[1]:.17g}, {c[2]:.17g}, 0., 1., 0.", "*END STEP",
             "*STEP, PERTURBATION", "*FREQUENCY", "6", "*END STEP"]
    (tmp_path / "spin.inp").write_text("\n".join(deck) + "\n")
    done = subprocess.run(["ccx", "spin"], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert "Job finished" in done.stdout, done.stdout[-2000:]
    theirs = _dat_eigenvalues(tmp_path / "spin.dat")[:6]
    K, Ms = stiffness_matrix(MESH, STEEL), mass_matrix(MESH, STEEL.rho)
    U = static_deflections(X - c, Ms, K, centrifugal_loads(X - c, Ms))
    Ks = geometric_scalar(MESH, STEEL, U[:, 1].reshape(-1, 3)).toarray()
    A = K.toarray() + s**2 * (np.kron(Ks, np.eye(3)) - np.kron(Ms.toarray(), np.eye(3) - np.outer(a, a)))
    free = np.ones(len(A), bool)
    free[supports] = False
    ours = sla.eigh(A[np.ix_(free, free)], full_mass(Ms).toarray()[np.ix_(free, free)], eigvals_only=True,
                    subset_by_index=[0, 5])
    assert theirs[0] < 0 and ours[0] < 0
    assert np.allclose(np.sqrt(ours[1:]), np.sqrt(theirs[1:]), rtol=5e-3)


def _cuts(data: bytes) -> list[int]:
    """Byte offsets to cut a .frd at: the start of every line that is no record (block headers, component and
    end lines, the mode headers, the end marker), every 40th line, and the middle of the last line of
    every block (a number cut in two)."""
    starts, at = [], 0
    for line in data.splitlines(keepends=True):
        starts.append(at)
        at += len(line)
    lines = data.splitlines(keepends=True)
    cuts = {s for k, (s, line) in enumerate(zip(starts, lines)) if not line.startswith((b" -1", b" -2")) or k % 40 == 0}
    cuts |= {starts[k - 1] + len(lines[k - 1]) // 2 for k, line in enumerate(lines) if line.startswith(b" -3")}
    return sorted(c for c in cuts if 0 < c < len(data))


@pytest.mark.slow  # half a minute: a few hundred cut files of both kinds
@pytest.mark.parametrize("job", ["ascii", "binary"])
def test_a_frd_cut_anywhere_is_refused(jobs, tmp_path, job):
    """Item 2 of issue 23: a .frd cut after the first mode's block was read as a 1-mode body, a cut number
    (-1.8676 for -1.86763E+02) was taken as it stood. Every cut is now an error naming the .frd (its end
    markers) or the .dat (whose eigenvalue count no longer matches)."""
    data = jobs[job].read_bytes()
    for suffix in (".dat", ".inp"):
        shutil.copy(jobs[job].with_suffix(suffix), tmp_path / f"cut{suffix}")
    cut = tmp_path / "cut.frd"
    for at in _cuts(data) if job == "ascii" else range(1000, len(data), max(1, len(data) // 150)):
        cut.write_bytes(data[:at])
        with pytest.raises(BodyFileError, match=r"cut\.(frd|dat)"):
            read_body(cut)
    cut.write_bytes(data)
    assert read_body(cut).nf == NF


def test_a_curved_ring_reads_with_the_mass_calculix_used(tmp_path):
    """Item 16 of issue 23: a ring of curved 20-node hexahedra read from an ASCII .frd failed its checks with
    the assembled mass (normalisation 1.6e-5) and passed with CalculiX's .mas. The cause is the .frd's 6-digit
    node coordinates, not the quadrature: assembled from the deck's full-precision nodes with CalculiX's own
    3x3x3 rule, the mass equals the .mas to its 14 printed digits (exact integration of the curved elements
    would differ from it by 7e-4 on this mesh), and the checks pass."""
    from ffrf_advisor.checks import run_checks
    from ffrf_advisor.fe.mesh import cylindrical

    box = box_mesh([10.0, 2 * np.pi, 20.0], [1, 12, 1], "hexahedron20", centred=False)
    ring = box.transformed(np.eye(3), np.array([95.0, 0.0, -10.0])).mapped(cylindrical).welded(1e-7)
    frd = _run(tmp_path, "ring", ring)
    assembled = read_body(frd, load_fe=True)
    assert any("deck's *NODE" in n for n in assembled.provenance.notes)
    assert all(c.passed for c in run_checks(assembled)), [(c.name, c.value) for c in run_checks(assembled)]
    (tmp_path / "stored").mkdir()
    write_deck(ring, STEEL, NF, tmp_path / "stored" / "ring.inp", matrix_storage=True)
    subprocess.run(["ccx", "ring"], cwd=tmp_path / "stored", capture_output=True, timeout=300)
    for suffix in (".mas", ".dof"):
        os.replace(tmp_path / "stored" / f"ring{suffix}", tmp_path / f"ring{suffix}")
    stored = read_body(frd, load_fe=True)
    assert any(".mas" in n for n in stored.provenance.notes)
    Ms, Mc = assembled.fe.Ms.toarray(), stored.fe.Ms.toarray()
    assert np.abs(Ms - Mc).max() <= 1e-12 * np.abs(Mc).max()  # assembled with CalculiX's own 3x3x3 rule


@pytest.mark.parametrize("density", ["0", "-7.85e-9", "nan"])
def test_a_deck_density_that_is_not_positive_is_one_line(jobs, tmp_path, density):
    """Item 9 of issue 23: *DENSITY 0 or negative gave 7-11 lines of RuntimeWarning, then a LinAlgError."""
    shutil.copy(jobs["ascii"], tmp_path / "d.frd")
    deck = jobs["ascii"].with_suffix(".inp").read_text().splitlines()
    at = next(i for i, line in enumerate(deck) if line.upper().startswith("*DENSITY"))
    deck[at + 1] = density
    (tmp_path / "d.inp").write_text("\n".join(deck) + "\n")
    with pytest.raises(BodyFileError, match=r"d\.inp: \*DENSITY: expected a finite positive density"):
        read_body(tmp_path / "d.frd")


def _with_cards(jobs, tmp_path, cards: list[str]) -> Path:
    """The ASCII run's .frd, .dat and deck with ``cards`` added before the step (the .frd is not solved again)."""
    for suffix in (".frd", ".dat"):
        shutil.copy(jobs["ascii"].with_suffix(suffix), tmp_path / f"c{suffix}")
    deck = jobs["ascii"].with_suffix(".inp").read_text().replace("*STEP", "\n".join(cards) + "\n*STEP")
    (tmp_path / "c.inp").write_text(deck)
    return tmp_path / "c.frd"


@pytest.mark.parametrize("cards, message", [
    (["*ELEMENT, TYPE=MASS, ELSET=PM", "9001, 1", "*ROTARY INERTIA, ELSET=PM", "1., 1., 1., 0., 0., 0."],
     r"c\.inp: \*ROTARY INERTIA: expected cards CalculiX 2\.20 reads.*got \*ROTARY INERTIA, ELSET=PM"),
    (["*NODE", "9001, 0., 0., 0.", "9002, 0., 0., 0.", "*NSET, NSET=S", "1, 2, 3",
      "*RIGID BODY, NSET=S, REF NODE=9001, ROT NODE=9002", "*ELEMENT, TYPE=MASS, ELSET=PM", "9001, 9002",
      "*MASS, ELSET=PM", "0.001"], r"c\.inp: \*MASS: expected masses on nodes that move.*ROT NODE"),
    (["*NODE", "9001, 0., 0., 0.", "*ELEMENT, TYPE=MASS, ELSET=PM", "9001, 9001", "*MASS, ELSET=PM", "0.001"],
     r"c\.inp: \*MASS: expected .*got a mass on node 9001, which no element of the \.frd holds"),
])
def test_cards_the_tool_cannot_carry_are_refused_by_name(jobs, tmp_path, cards, message):
    """Never dropped: rotary inertia (CalculiX 2.20 ignores it), a mass on a ROT NODE (rotations, not a position's
    displacement), a mass on a node that nothing the .frd holds moves."""
    with pytest.raises(BodyFileError, match=message):
        read_body(_with_cards(jobs, tmp_path, cards))


def test_a_point_mass_on_a_node_of_the_frd_is_added_and_the_dat_total_refuses_the_difference(jobs, tmp_path):
    """The ASCII run was solved without the mass: with a *MASS card added to its deck the body's mass is the .dat's
    plus the point (the card read), and the .dat's effective-mass total names the difference."""
    frd = _with_cards(jobs, tmp_path, ["*ELEMENT, TYPE=MASS, ELSET=PM", "9001, 1", "*MASS, ELSET=PM", "1e-6"])
    with pytest.raises(BodyFileError, match=r"c\.dat: TOTAL EFFECTIVE MASS: expected the total mass of the body"):
        read_body(frd)


@pytest.mark.parametrize("name, why", [("C3D8R", "integrates its mass at one point"),
                                       ("C3D8I", "gives its incompatible modes mass")])
def test_hexahedra_whose_mass_calculix_makes_otherwise_are_refused_without_the_mas(tmp_path, name, why):
    """C3D8R's one-point mass and C3D8I's incompatible modes give modes of another mass than the 8-node one the
    tool assembles (measured: modal masses 35 % and 10 % off): without .mas they are refused by name."""
    mesh = box_mesh([200.0, 40.0, 20.0], [5, 2, 1], "hexahedron")
    write_deck(mesh, STEEL, NF, tmp_path / "r.inp")
    (tmp_path / "r.inp").write_text((tmp_path / "r.inp").read_text().replace("TYPE=C3D8,", f"TYPE={name},"))
    subprocess.run(["ccx", "r"], cwd=tmp_path, capture_output=True, timeout=300)
    expected = rf"r\.frd: 3C: expected .*SOLVER=MATRIXSTORAGE.*got {name} \(CalculiX {why}"
    with pytest.raises(BodyFileError, match=expected):
        read_body(tmp_path / "r.frd")


def _damaged(jobs, tmp_path, suffix: str, edit, job: str = "ascii") -> Path:
    """A copy d.frd, d.dat, d.inp of a run with ``edit`` applied to the text of the file with ``suffix``."""
    for s in (".frd", ".dat", ".inp"):
        shutil.copy(jobs[job].with_suffix(s), tmp_path / f"d{s}")
    target = tmp_path / f"d{suffix}"
    target.write_bytes(edit(target.read_bytes()))
    return tmp_path / "d.frd"


def _gate(frd: Path, level: str = "I"):
    from typer.testing import CliRunner
    from ffrf_advisor.cli import app
    return CliRunner().invoke(app, ["gate", str(frd), "--speed", "30rad/s", "--max-level", level])


def _analyze(frd: Path):
    from typer.testing import CliRunner
    from ffrf_advisor.cli import app
    return CliRunner().invoke(app, ["analyze", str(frd), "--speed", "30rad/s"])


def _one_line(result, *names: str) -> None:
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.output, result.output
    assert all(name in lines[0] for name in names), lines[0]


def _dat_row(data: bytes, mode: int) -> tuple[int, bytes]:
    """Offset and text of mode ``mode``'s row of the .dat's eigenvalue table."""
    at = data.index(b"E I G E N V A L U E")
    start = data.index(f"\n{mode:7d}  ".encode(), at) + 1
    return start, data[start:data.index(b"\n", start)]


def test_a_damaged_dat_exponent_is_refused_not_read_as_rigid_modes(jobs, tmp_path):
    """Issue 49: one exponent digit of one .dat eigenvalue (E+09 -> E+81) made every smaller one 'rigid': level I,
    the gate passed. The row's frequency columns (and the .frd's frequency) disagree with it: exit 2 naming it."""
    clean = _gate(_damaged(jobs, tmp_path, ".dat", lambda b: b))
    assert clean.exit_code == 1, clean.output  # the clean body is above level I at 30 rad/s

    def exponent(data: bytes) -> bytes:
        start, row = _dat_row(data, 8)
        words = row.split()
        return data[:start] + row.replace(words[1], words[1][:-2] + b"81", 1) + data[start + len(row):]
    damaged = _damaged(jobs, tmp_path, ".dat", exponent)
    assert _gate(damaged).exit_code == 2
    _one_line(_analyze(damaged), "d.dat", "EIGENVALUE OUTPUT", "mode 8")


@pytest.mark.parametrize("factor, refused", [(1.001, True), (1 + 1e-9, False)])
def test_frd_frequencies_are_checked_against_the_dat_eigenvalues(jobs, tmp_path, factor, refused):
    """Both files carry each mode's frequency: the .frd's (every block header of mode 9) x1.001 is beyond both
    files' print precision (6 and 7 digits) and refused naming both; x(1 + 1e-9) is below it and reads."""
    def scaled(data: bytes) -> bytes:
        lines = data.split(b"\n")
        for k, line in enumerate(lines):
            if line.startswith(b"  100C") and line[58:63] == b"    9":
                lines[k] = line[:12] + f"{float(line[12:24]) * factor:12.6f}".encode() + line[24:]
        return b"\n".join(lines)
    result = _analyze(_damaged(jobs, tmp_path, ".frd", scaled))
    if refused:
        _one_line(result, "d.dat", "d.frd", "mode 9")
    else:
        assert result.exit_code == 0, result.output


KEY = b"1PMODE                         2"


@pytest.mark.parametrize("job", ["ascii", "binary"])
@pytest.mark.parametrize("old, new", [(KEY, b"6" + KEY[1:]), (KEY, KEY[:-1] + b"3"), (b"    2MODAL", b"    3MODAL")])
def test_a_damaged_frd_mode_key_is_refused(jobs, tmp_path, job, old, new):
    """Issue 49: one byte of a '1PMODE' line ('6PMODE') skipped its block and filed the modes under wrong numbers
    (--rules paper went II -> I). The key line and the block header's mode number must agree: exit 2."""
    _one_line(_analyze(_damaged(jobs, tmp_path, ".frd", lambda b: b.replace(old, new, 1), job)), "d.frd", "1PMODE")


def test_a_rigid_shape_with_a_flexible_frequency_is_refused(jobs, tmp_path):
    """Rigid modes are told by their shape, not by the eigenvalue's size: without the .dat, mode 3 (a rigid motion)
    given a 2 kHz frequency in every header of the .frd is refused; before, it was read as a flexible mode."""
    def rigid_at_2khz(data: bytes) -> bytes:
        lines = data.split(b"\n")
        for k, line in enumerate(lines):
            if line.startswith(b"  100C") and line[58:63] == b"    3":
                lines[k] = line[:12] + b" 2000.000000" + line[24:]
        return b"\n".join(lines)
    frd = _damaged(jobs, tmp_path, ".frd", rigid_at_2khz)
    (tmp_path / "d.dat").unlink()
    _one_line(_analyze(frd), "d.frd", "mode 3")


def test_a_flexible_mode_at_zero_frequency_is_refused(jobs, tmp_path):
    """Without the .dat, modes 7 and 8 at zero frequency (every header of the .frd) are no rigid motions: they were
    dropped as 'rigid' silently (level and term set changed); now an error naming them (a mechanism or a damaged
    frequency)."""
    def zero(data: bytes) -> bytes:
        lines = data.split(b"\n")
        for k, line in enumerate(lines):
            if line.startswith(b"  100C") and line[58:63] in (b"    7", b"    8"):
                lines[k] = line[:12] + b" 0.00000E+00" + line[24:]
        return b"\n".join(lines)
    frd = _damaged(jobs, tmp_path, ".frd", zero)
    (tmp_path / "d.dat").unlink()
    _one_line(_analyze(frd), "d.frd", "rigid-body shape at zero frequency (not a mechanism)", "mode 7")


def test_the_rigid_modes_are_named(jobs):
    notes = read_body(jobs["binary"]).provenance.notes
    assert any(n.startswith("rigid modes (shapes spanned by rigid motions) dropped: 1, 2, 3, 4, 5, 6 (") for n in notes)


@pytest.mark.parametrize("old, new, names", [
    (b"*ELASTIC\n", b"*ULASTIC\n", ("d.inp", "*ELASTIC", "none")),  # one bit: read without a material before
    (b"\n210000.0, 0.3\n", b"\n210000.0, 3\n", ("d.inp", "*ELASTIC", "nu")),
    (b"\n210000.0, 0.3\n", b"\n420000.0, 0.3\n", ("d.frd", "eigenvalues", "Rayleigh")),
])
def test_a_damaged_elastic_card_is_refused(jobs, tmp_path, old, new, names):
    """Found by the differential fuzzer: '*ELASTIC' -> '*ULASTIC' dropped the deck's material, and with it the static
    centrifugal response, and the term set changed with no word. A frequency step needs a stiffness card (CalculiX
    refuses an unknown one); an E that is not the run's disagrees with the eigenvalues (Rayleigh quotients)."""
    assert old in jobs["ascii"].with_suffix(".inp").read_bytes()
    _one_line(_analyze(_damaged(jobs, tmp_path, ".inp", lambda b: b.replace(old, new, 1))), *names)


def test_a_free_run_must_have_six_rigid_modes(jobs, tmp_path):
    """The deck has no *BOUNDARY, so the body is free and six shapes must be rigid motions: mode 2's shape made a
    flexible mode's (the .frd's DISP block of mode 7 copied over it, its zero frequency kept) is refused, naming
    the mode whose flexible shape has a zero frequency (io.rigid_modes: before the count, which it would break)."""
    def copied(data: bytes) -> bytes:
        text = data.decode("latin-1")
        blocks = text.split("    1PMODE")
        disp = [k for k, b in enumerate(blocks) if " -4  DISP" in b]
        body = lambda b: b[b.index(" -4  DISP"):b.index(" -3", b.index(" -4  DISP"))]  # noqa: E731
        two, seven = disp[1], disp[6]
        blocks[two] = blocks[two].replace(body(blocks[two]), body(blocks[seven]))
        return "    1PMODE".join(blocks).encode("latin-1")
    frd = _damaged(jobs, tmp_path, ".frd", copied)
    (tmp_path / "d.dat").unlink()
    _one_line(_analyze(frd), "d.frd", "rigid-body shape at zero frequency", "mode 2")


@pytest.mark.parametrize("job", ["ascii", "binary"])
@pytest.mark.parametrize("block", [b"-4  STRESS", b"-4  DISP"])
def test_a_damaged_result_block_name_is_refused(jobs, tmp_path, job, block):
    """Found by the differential fuzzer: one bit of 'STRESS' in mode 7's block ('STRDSS') left the body without
    modal stresses (q_max from --q-cap, another term set, a warning about deflection that named no damage); every
    mode must have every block the others have."""
    def renamed(data: bytes) -> bytes:
        at = data.index(block, data.index(b"1PMODE                         7"))
        return data[:at] + block[:-1] + bytes([block[-1] ^ 1]) + data[at + len(block):]
    _one_line(_analyze(_damaged(jobs, tmp_path, ".frd", renamed, job)), "d.frd", "for mode 7")
