"""MBDyn modal FEM files (.fem): round trip, the written invariants against nodal sums, a hand-written file,
a coupled modal mass and stiffness, damaged files."""
from __future__ import annotations

import json
import tracemalloc

import numpy as np
import pytest

from ffrf_advisor.adams import to_adams
from ffrf_advisor.cli import app
from ffrf_advisor.errors import BodyFileError, FFRFError
from ffrf_advisor.invariants import shape_integrals
from ffrf_advisor.io import read_body, write_body
from ffrf_advisor.io.mbdyn_records import file_rows

from .test_adequacy import DIR as SAMPLES, beam, runner  # noqa: F401 - the beam with its FE data, a module fixture
from .test_rotary import dumbbell


@pytest.fixture(scope="module")
def small(beam, tmp_path_factory):
    """The beam's first 3 modes and their .fem text."""
    body = beam.first_modes(3)
    path = tmp_path_factory.mktemp("fem") / "small.fem"
    write_body(body, path)
    return body, path.read_text()


def _groups(text: str) -> dict[int, tuple[int, int]]:
    """Record group -> [first, last) line of its data (a plain reading of the format, not the project's)."""
    lines = text.splitlines()
    heads = [(int(s.split()[3].rstrip(",")), i) for i, s in enumerate(lines) if s.startswith("** RECORD GROUP ")]
    ends = [i for _, i in heads[1:]] + [len(lines)]
    return {g: (i + 1, e) for (g, i), e in zip(heads, ends)}


def _numbers(text: str, g: int) -> np.ndarray:
    a, b = _groups(text)[g]
    return np.array(" ".join(s for s in text.splitlines()[a:b] if not s.startswith("**")).split(), dtype=float)


def _with_group(text: str, g: int, rows) -> str:
    """``text`` with record group g's data replaced by ``rows`` (lines; None drops the group, header too)."""
    lines = text.splitlines()
    a, b = _groups(text)[g]
    new = lines[:a - 1] + ([] if rows is None else [lines[a - 1], *rows]) + lines[b:]
    return "\n".join(new) + "\n"


def _rows(values) -> list[str]:
    return [" ".join(map(repr, np.atleast_1d(r).tolist())) for r in values]


def _close(a, b, rtol):
    return np.abs(np.asarray(a) - b).max() <= rtol * np.abs(b).max()


# ---------------------------------------------------------------- round trip
@pytest.mark.parametrize("name, modes", [("beam", 16), ("plate", 6)])
def test_a_sample_written_and_read_back_is_the_same_body(tmp_path, name, modes):
    body = read_body(SAMPLES / f"{name}.ffrf.h5", load_fe=True).first_modes(modes)
    write_body(body, tmp_path / f"{name}.fem")
    back = read_body(tmp_path / f"{name}.fem")
    for matrix in ("I0", "W1", "W2", "W3"):
        # the text holds every double exactly; I and Ibar come back from I7 and Inv8 by a few roundings
        assert _close(getattr(back, matrix), getattr(body, matrix), 1e-12), matrix
    assert np.array_equal(back.eigenvalues, body.eigenvalues)
    assert np.array_equal(back.frequencies_hz, body.frequencies_hz)
    assert back.mass == body.mass  # written as its shortest exact text, read as the same double
    # the CoM is ~1e-15 mm (a principal CoM frame): compared with the body's size, rounding of m * CoM / m
    assert np.abs(back.com - body.com).max() <= 1e-15 * body.largest_dimension()
    # free-surface residuals are round-off; Cauchy-Schwarz bounds them by sqrt(m) and sqrt(I0_kk)
    assert np.abs(back.integrals.mode_sum - body.integrals.mode_sum).max() <= 1e-12 * np.sqrt(body.mass)
    residual = back.integrals.mean_axis_residual() - body.integrals.mean_axis_residual()
    assert np.abs(residual).max() <= 1e-12 * np.sqrt(np.trace(body.I0))
    summary = body.fe.summary()
    assert np.array_equal(back.nodal.max_deflection, summary.max_deflection)
    assert back.nodal.largest_dimension == summary.largest_dimension and back.nodal.n_nodes == summary.n_nodes
    assert back.units == body.units and back.provenance.mass_matrix == body.provenance.mass_matrix


def test_convert_to_fem_and_info_through_the_cli(tmp_path):
    out = tmp_path / "out.fem"
    done = runner.invoke(app, ["convert", str(SAMPLES / "beam.ffrf.h5"), str(out)])
    assert done.exit_code == 0, done.output
    info = runner.invoke(app, ["info", str(out), "--json"])
    assert info.exit_code == 0, info.output
    doc = json.loads(info.output)["body"]
    beam = read_body(SAMPLES / "beam.ffrf.h5", load_fe=True)  # as convert reads it
    assert doc["nf"] == beam.nf and doc["mass"] == beam.mass  # the mass, exactly as the sample has it
    assert runner.invoke(app, ["info", str(out)]).exit_code == 0


def test_the_written_file_keeps_the_line_rules_of_mbdyns_reader(small):
    """ReadModal reads lines (getline, 8191 characters) only for the group headers, the one comment line after
    group 1's header and the one line before each mode of group 8; everything else as free-format numbers."""
    body, text = small
    lines = text.splitlines()
    assert max(map(len, lines)) < 8191
    one = lines.index("** RECORD GROUP 1, HEADER")
    assert lines[one + 1].startswith("**") and lines[one + 2].split()[0] == "REV0"
    a, b = _groups(text)[8]
    n = body.fe.mesh.n_nodes
    for p in range(body.nf):
        block = lines[a + p * (n + 1):a + (p + 1) * (n + 1)]
        assert block[0].startswith("**") and all(len(s.split()) == 6 for s in block[1:]), p
    assert lines[-1] == "** END OF FILE"


def test_rotary_inertia_and_mode_rotations_survive(tmp_path):
    body = dumbbell()
    write_body(body, tmp_path / "d.fem")
    back = read_body(tmp_path / "d.fem")
    J, K = back.integrals, body.integrals
    # exact text; the rotary parts are differences (Inv4 less the translational sum, the unit modal mass less
    # Inv9's trace): a few roundings of numbers of order 1
    assert _close(back.I0, body.I0, 1e-13)
    assert np.abs(J.modal_mass() - K.modal_mass()).max() <= 1e-13
    assert _close(J.mean_axis_residual(), K.mean_axis_residual(), 1e-13)
    for matrix in ("W1", "W2"):
        assert _close(getattr(back, matrix), getattr(body, matrix), 1e-13), matrix
    assert np.abs(back.W3).max() <= 1e-13 and not body.W3.any()  # zero: W3 is translational, mode 1 has none


# ---------------------------------------------------------------- the written invariants, independently
def _skew(v):
    """(..., 3) -> (..., 3, 3) with skew(a) b = a x b."""
    z = np.zeros(v.shape[:-1])
    return np.stack([np.stack([z, -v[..., 2], v[..., 1]], -1), np.stack([v[..., 2], z, -v[..., 0]], -1),
                     np.stack([-v[..., 1], v[..., 0], z], -1)], -2)


def test_groups_14_16_18_are_the_nodal_sums_of_the_consistent_mass(tmp_path):
    """Inv3 = sum m Phi_j, Inv8_j = -sum m u~ Phi_j~ (MBDyn's sign), Inv9_jk = sum m Phi_j~ Phi_k~ (modal.cc),
    summed here over pairs of nodes with the sample's consistent mass matrix (m_p -> Ms_pq). The conrod: its
    W1 does not vanish by symmetry (the beam's and the plate's largely do, theory 7)."""
    body = read_body(SAMPLES / "conrod.ffrf.h5", load_fe=True).first_modes(3)
    write_body(body, tmp_path / "conrod.fem")
    text = (tmp_path / "conrod.fem").read_text()
    Ms, X, Phi = body.fe.Ms, body.fe.mesh.points, body.fe.Phi
    n, nf = len(X), body.nf
    inv3 = _numbers(text, 14).reshape(3, nf)
    inv8 = _numbers(text, 16).reshape(3, nf, 3)  # row, mode, column
    inv9 = _numbers(text, 18).reshape(3, nf, nf, 3)
    Sx = _skew(X)
    for j in range(nf):
        SP = (Ms @ _skew(Phi[:, :, j]).reshape(n, 9)).reshape(n, 3, 3)
        ref8 = -np.einsum("pab,pbc->ac", Sx, SP)
        # two summation orders of one nodal sum: round-off ~1e-15 of the Cauchy-Schwarz bounds (G23, G24),
        # sqrt(trace I0) for Inv8 and 2 for Inv9
        assert np.abs(inv8[:, j, :] - ref8).max() <= 1e-12 * np.sqrt(np.trace(body.I0))
        assert np.abs(ref8).max() > 1e-3 * np.sqrt(np.trace(body.I0))  # a real test: Inv8 is not round-off
        for k in range(nf):
            ref9 = np.einsum("pab,pbc->ac", _skew(Phi[:, :, k]), SP).T  # sum Ms Phi_k~ Phi_j~ = (Phi_j~ Phi_k~)^T
            assert np.abs(inv9[:, j, k, :] - ref9).max() <= 2e-12
    ref3 = np.ones(n) @ (Ms @ Phi.reshape(n, 3 * nf))
    # free-surface modes: Inv3 is round-off; Cauchy-Schwarz bounds it by sqrt(mass)
    assert np.abs(inv3 - ref3.reshape(3, nf)).max() <= 1e-12 * np.sqrt(body.mass)


# ---------------------------------------------------------------- a hand-written file
M, A, J, K = 2.0, 2.0, 0.25, 400.0  # nodal mass, half length, nodal rotary inertia, modal stiffness
HAND = f"""** two masses {M} at x = -{A}, +{A} with rotary inertia {J}; one axial mode, modal mass {2 * M}
** RECORD GROUP 1, HEADER
**   REVISION,  NODE,  NORMAL, ATTACHMENT, CONSTRAINT, REJECTED MODES.
REV0 2 1 0 0 0
** RECORD GROUP 2, FINITE ELEMENT NODE LIST
101 102
** RECORD GROUP 5, NODAL X COORDINATES
-{A}
{A}
** RECORD GROUP 6, NODAL Y COORDINATES
0 0
** RECORD GROUP 7, NODAL Z COORDINATES
0 0
** RECORD GROUP 8, MODE SHAPES
**    NORMAL MODE SHAPE #  1
-1 0 0 0 0 0
1 0 0 0 0 0
** RECORD GROUP 9, MODAL MASS MATRIX
{2 * M}
** RECORD GROUP 10, MODAL STIFFNESS MATRIX
{K}
** RECORD GROUP 11, DIAGONAL OF LUMPED MASS MATRIX
{M} {M} {M} {J} {J} {J}
{M} {M} {M} {J} {J} {J}
** RECORD GROUP 12, GLOBAL INERTIA
{2 * M}
0 0 0
{2 * J} 0 0
0 {2 * M * A**2 + 2 * J} 0
0 0 {2 * M * A**2 + 2 * J}
** END OF FILE
"""


VARIANTS = {"as written": HAND, "without group 12": _with_group(HAND, 12, None),
            "a rejected mode first": _with_group(HAND.replace("REV0 2 1 0 0 0", "REV0 2 2 0 0 1"), 8,
                                                 ["** REJECTED", "9 9 9 9 9 9", "9 9 9 9 9 9",
                                                  *HAND.split("MODE SHAPES\n")[1].split("** RECORD")[0].split("\n")])}


@pytest.mark.parametrize("variant", VARIANTS)
def test_a_hand_written_file_reads_to_the_body_computed_by_hand(tmp_path, variant):
    path = tmp_path / "hand.fem"
    path.write_text(VARIANTS[variant])
    body = read_body(path, load_fe=True)
    s = 1 / np.sqrt(2 * M)  # the mode scaled to unit modal mass
    ibar = 2 * M * A * s  # sum m x Phi_x: (-a)(-s) + (a)(s), times m
    expected = {"I0": np.diag([2 * J, 2 * M * A**2 + 2 * J, 2 * M * A**2 + 2 * J]),
                "W1": np.diag([0, 2 * ibar, 2 * ibar]),  # 2(Ib22 + Ib33), 2(Ib11 + Ib33), 2(Ib11 + Ib22)
                "W2": np.diag([0.0, 1.0, 1.0]),  # S22 + S33, S11 + S33, S11 + S22 with S11 = 2 m s^2 = 1
                "W3": np.zeros((3, 1))}
    for name, ref in expected.items():
        # numbers of a few binary digits: the sums are exact up to a rounding or two
        assert np.abs(getattr(body, name) - ref).max() <= 1e-14 * np.abs(expected["I0"]).max(), name
    assert body.mass == 2 * M and np.array_equal(body.com, np.zeros(3))
    assert body.eigenvalues.tolist() == [K / (2 * M)]
    assert np.array_equal(body.fe.Phi[:, 0, 0], [-s, s]) and body.provenance.mass_matrix == "lumped"
    assert np.array_equal(body.integrals.rotary.J, 2 * J * np.eye(3))
    assert "t-mm-N-s assumed" in body.provenance.notes[0]


def test_a_file_in_another_frame_is_moved_to_the_principal_com_frame_and_says_so(tmp_path):
    """The modal node's frame 10 to the side: the CoM goes to the origin, the nodes with it."""
    shifted = HAND.replace(f"-{A}\n{A}\n", f"{10 - A}\n{10 + A}\n").replace("\n0 0 0\n", "\n10 0 0\n")
    (tmp_path / "far.fem").write_text(shifted)
    for load_fe in (True, False):
        body = read_body(tmp_path / "far.fem", load_fe=load_fe)
        # 10 +- 2 and their mean are exact in binary: the CoM lands on the origin up to a rounding
        assert np.abs(body.com).max() <= 1e-15 * A and body.mass == 2 * M
        # moved back by parallel axes from 10 mm away: roundings of I0 ~ m 10^2 = 400
        assert np.abs(body.I0 - np.diag([2 * J, 2 * M * A**2 + 2 * J, 2 * M * A**2 + 2 * J])).max() <= 1e-12
        assert any("transformed from the file's frame" in note for note in body.provenance.notes)
        assert body.nodal_summary().largest_dimension == 2 * A


def test_a_coupled_modal_mass_and_stiffness_is_solved_and_the_invariants_follow(small, tmp_path):
    """Modes Psi = Phi A with modal mass A^T A and stiffness A^T Lambda A: the reader's generalised
    eigenproblem gives back the eigenvalues and, up to each mode's sign, the invariants."""
    body, text = small
    nf, fe = body.nf, body.fe
    Amix = np.array([[1.0, 0.4, 0.0], [0.2, 1.0, -0.3], [0.1, 0.0, 0.8]])
    Psi = fe.Phi @ Amix
    inv = to_adams(shape_integrals(fe.mesh.points, fe.Ms, Psi), "mbdyn")
    shapes = [row for p in range(nf) for row in ["**", *_rows(np.c_[Psi[:, :, p], np.zeros_like(Psi[:, :, p])])]]
    text = _with_group(text, 8, shapes)
    text = _with_group(text, 9, _rows(Amix.T @ Amix))
    text = _with_group(text, 10, _rows(Amix.T @ np.diag(body.eigenvalues) @ Amix))
    for g, key in ((14, "I3"), (15, "I4"), (16, "I8"), (17, "I5"), (18, "I9")):
        text = _with_group(text, g, _rows(file_rows(g, inv[key])))
    (tmp_path / "mixed.fem").write_text(text)
    back = read_body(tmp_path / "mixed.fem")
    # a 3 x 3 pair with cond(A)^2 ~ 4 and the original modes' own normalisation (~1e-15): round-off
    assert _close(back.eigenvalues, body.eigenvalues, 1e-12)
    # each entry is a product of mode signs: magnitudes, to 1e-12 of the Cauchy-Schwarz bounds (G23, G24:
    # sqrt(trace I0) for W1, 2 for W2 and W3), round-off of mixing and unmixing
    for matrix, bound in (("W1", np.sqrt(np.trace(body.I0))), ("W2", 2.0), ("W3", 2.0)):
        difference = np.abs(getattr(back, matrix)) - np.abs(getattr(body, matrix))
        assert np.abs(difference).max() <= 1e-12 * bound, matrix
    assert any("K v = lambda M v" in note for note in back.provenance.notes)


# ---------------------------------------------------------------- refusals and damage
def test_an_invariants_only_body_is_refused_in_one_line(beam, tmp_path):
    source = tmp_path / "beam.ffinv.json"
    write_body(beam, source)
    with pytest.raises(FFRFError, match="invariants only"):
        write_body(read_body(source), tmp_path / "x.fem")
    done = runner.invoke(app, ["convert", str(source), str(tmp_path / "y.fem")])
    assert done.exit_code == 2 and len(done.output.strip().splitlines()) == 1 and "y.fem" in done.output
    assert not (tmp_path / "y.fem").exists()


def _damaged(text: str) -> dict[str, str]:
    lines = text.splitlines()
    head = next(i for i, s in enumerate(lines) if s.startswith("REV0"))
    n, nf = (int(x) for x in lines[head].split()[1:3])
    mode = _groups(text)[8][0] + 5
    cases = {f"truncated at {q:.0%}": text[:int(q * len(text))] for q in (0.05, 0.3, 0.6, 0.95)}
    cases["truncated within a number"] = "\n".join(lines[:mode] + [lines[mode][:9]]) + "\n"
    for what, counts in (("one node more", (n + 1, nf)), ("one mode more", (n, nf + 1))):
        cases[f"header: {what}"] = "\n".join(lines[:head] + [f"REV0 {counts[0]} {counts[1]} 0 0 0"]
                                             + lines[head + 1:])
    cases["a non-number"] = "\n".join(lines[:mode] + ["1.0 x2 0 0 0 0"] + lines[mode + 1:])
    cases["group 5 missing"] = _with_group(text, 5, None)
    cases["group 12 missing"] = _with_group(text, 12, None)
    cases["group 1 missing"] = _with_group(text, 1, None)
    return cases


def test_damaged_files_give_one_line_and_exit_2(small, tmp_path):
    _, text = small
    for case, damaged in _damaged(text).items():
        path = tmp_path / "damaged.fem"
        path.write_text(damaged)
        done = runner.invoke(app, ["info", str(path)])
        assert done.exit_code == 2, (case, done.output)
        assert len(done.output.strip().splitlines()) == 1 and "Traceback" not in done.output, case
        assert "damaged.fem: " in done.output and ("record group" in done.output or "line " in done.output), case


def test_a_header_declaring_10_to_12_nodes_is_refused_before_allocating(small, tmp_path):
    _, text = small
    lines = text.splitlines()
    head = next(i for i, s in enumerate(lines) if s.startswith("REV0"))
    path = tmp_path / "huge.fem"
    path.write_text("\n".join(lines[:head] + [f"REV0 {10**12} 3 0 0 0"] + lines[head + 1:]) + "\n")
    tracemalloc.start()
    try:
        with pytest.raises(BodyFileError) as e:
            read_body(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert e.value.field == "record group 1 (header)" and "memory limit" in str(e.value)
    assert peak < 20 * path.stat().st_size  # the text and its lines, nothing of the declared size
    done = runner.invoke(app, ["info", str(path)])
    assert done.exit_code == 2 and len(done.output.strip().splitlines()) == 1


@pytest.mark.parametrize("token", ["true", "True", "'1.0'", "{1.0}", "nan", "inf"])
def test_a_word_where_a_number_belongs_is_refused_by_name(small, tmp_path, token):
    """Issue 49, part 4: a boolean, a quoted or nested number where the total mass belongs (group 12, the global
    inertia) is refused naming the group and the value, never read as 1 (the .fem reader's NUMBER pattern
    already held: a regression test)."""
    _, text = small
    a, _ = _groups(text)[12]
    lines = text.splitlines()
    values = lines[a].split()
    lines[a] = " ".join([token, *values[1:]])
    path = tmp_path / "typed.fem"
    path.write_text("\n".join(lines) + "\n")
    result = runner.invoke(app, ["info", str(path)])
    out = result.output.strip().splitlines()
    assert result.exit_code == 2 and len(out) == 1 and "record group 12 (global inertia)" in out[0] and token in out[0], out
