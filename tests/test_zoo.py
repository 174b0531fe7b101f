"""The body zoo (ffrf_advisor.zoo): families, reproducibility from the seed, symmetric pairs, the sample command."""
from __future__ import annotations

import functools

import numpy as np
import pytest
from scipy.spatial import cKDTree
from typer.testing import CliRunner

from ffrf_advisor.checks import run_checks
from ffrf_advisor.cli import app
from ffrf_advisor.errors import FFRFError
from ffrf_advisor.fe.assembly import mass_matrix
from ffrf_advisor.io import read_body
from ffrf_advisor.samples import sample
from ffrf_advisor.zoo import CELLS, FAMILIES, MAX_NODES, N_MODES, parse_zoo_name, zoo_body, zoo_draw, zoo_split

runner = CliRunner()
built = functools.cache(zoo_body)  # a body once per session where a test only reads it
BAD_NAMES = ("zoo:xyz:1", "zoo:ring:-1", "zoo:ring:1.5", "zoo:ring", "zoo:Ring:1", "zoo:ring:1:2")


def _relative_gap(f: np.ndarray) -> float:
    return float(abs(f[1] - f[0]) / f[0])


def _all_pass(body) -> bool:
    return all(c.passed for c in run_checks(body))


def test_families_names_and_split():
    assert len(FAMILIES) >= 12
    assert {"shaft", "rotor", "blade", "l_bracket", "t_bracket", "ring", "disc", "channel", "tube", "block",
            "strip", "plate", "frame", "masses"} <= set(FAMILIES)
    assert parse_zoo_name("zoo:ring:1003") == ("ring", 1003)
    assert [zoo_split(s) for s in (0, 999, 1000, 123456)] == ["calibration", "calibration", "test", "test"]
    for name in BAD_NAMES:
        with pytest.raises(FFRFError, match="expected zoo:FAMILY:SEED with FAMILY one of shaft, rotor"):
            parse_zoo_name(name)


def test_meshes_stay_small_closed_and_quadratic():
    for family in FAMILIES:
        for seed in (0, 1, 2, 1000, 1001, 1002):
            mesh = zoo_draw(family, seed).mesh
            assert mesh.n_nodes <= MAX_NODES and set(mesh.cells) <= set(CELLS), (family, seed)
            pairs = cKDTree(mesh.points).query_pairs(1e-6 * mesh.largest_dimension())
            assert not pairs, (family, seed)  # seams welded: no two nodes on one spot


def test_heavy_blocks_weigh_their_factor_times_the_density():
    draw = zoo_draw("masses", 1000)
    p, rho = draw.params, draw.material.rho
    a, blocks = p["a"], len(p["blocks"].split())
    base = p["n1"] * p["n2"] * a * a * p["T"]
    block = a * a * p["block_h"]
    total = (mass_matrix(draw.mesh, rho) + draw.added_mass()).sum()
    assert total == pytest.approx(rho * (base + blocks * p["heavy_factor"] * block), rel=1e-10)


@pytest.mark.parametrize("family, seed, other", [("ring", 1001, 12), ("block", 13, 1019)])
def test_a_body_is_a_pure_function_of_family_and_seed(family, seed, other):
    first, again, different = zoo_body(family, seed), zoo_body(family, seed), zoo_body(family, other)
    assert first.name == f"zoo:{family}:{seed}" and first.nf == N_MODES
    assert np.abs(again.eigenvalues / first.eigenvalues - 1).max() < 1e-10
    assert np.array_equal(again.fe.mesh.points, first.fe.mesh.points)
    assert again.provenance == first.provenance
    assert np.abs(different.eigenvalues / first.eigenvalues - 1).max() > 1e-3
    assert different.provenance.notes[1] != first.provenance.notes[1]  # the drawn values
    assert _all_pass(first) and _all_pass(different)


def test_ring_about_its_symmetry_axis_has_an_equal_in_plane_n2_pair():
    ring = built("ring", 1001)
    I0 = ring.I0
    assert abs(I0[0, 0] / I0[1, 1] - 1) < 1e-9 and I0[2, 2] > 1.9 * I0[0, 0]  # axis 3: the symmetry axis
    fe = ring.fe
    axial = np.einsum("ip,ij,jp->p", fe.Phi[:, 2], fe.Ms.toarray(), fe.Phi[:, 2])  # modal mass moving along 3
    p, q = np.flatnonzero(axial < 0.05)[:2]
    assert _relative_gap(ring.frequencies_hz[[p, q]]) < 1e-3
    # the pair's gyroscopic coupling about axis 3 (theory 3: W3 block S12 - S21) is Bryan's 2n / (n^2 + 1) for n = 2
    coupling = ring.W3[2 * ring.nf + p, q]
    assert abs(abs(coupling) - 0.8) < 0.03


def test_shaft_bends_in_an_equal_pair():
    shaft = built("shaft", 1007)
    fe = shaft.fe
    axial = np.einsum("ip,ij,jp->p", fe.Phi[:, 2, :2], fe.Ms.toarray(), fe.Phi[:, 2, :2])
    assert np.all(axial < 0.05)  # both move across the axis: bending
    assert _relative_gap(shaft.frequencies_hz[:2]) < 1e-3
    assert abs(shaft.I0[0, 0] / shaft.I0[1, 1] - 1) < 1e-9


def test_sample_command_writes_a_zoo_body_that_reads_back(tmp_path):
    out = tmp_path / "block.ffrf.h5"
    result = runner.invoke(app, ["sample", "zoo:block:13", "-o", str(out)])
    assert result.exit_code == 0, result.output
    body = read_body(out, load_fe=True)
    assert body.name == "zoo:block:13" and body.nf == N_MODES and body.fe.K is None
    assert np.abs(body.eigenvalues / built("block", 13).eigenvalues - 1).max() < 1e-12
    assert body.static_centrifugal is not None and body.geometric is not None
    assert "zoo: family=block, seed=13, split=calibration" in body.provenance.notes


def _bad_name_message(name: str) -> str:
    return (f"zoo name {name!r}: expected zoo:FAMILY:SEED with FAMILY one of {', '.join(FAMILIES)} "
            "and SEED a whole number >= 0")


@pytest.mark.parametrize("name", BAD_NAMES)
def test_bad_zoo_names_exit_2_with_one_line(tmp_path, name):
    with pytest.raises(FFRFError) as error:
        sample(name)
    assert str(error.value) == _bad_name_message(name)
    result = runner.invoke(app, ["sample", name, "-o", str(tmp_path / "x.ffrf.h5")])
    assert result.exit_code == 2
    assert len(result.output.strip().splitlines()) == 1
    assert result.output.startswith("error: zoo name") and "and SEED a whole number >= 0" in result.output


def test_cli_prints_zoo_names_verbatim(tmp_path):
    result = runner.invoke(app, ["sample", "zoo:ring:1.5", "-o", str(tmp_path / "x.ffrf.h5")])
    assert _bad_name_message("zoo:ring:1.5") in result.output


def test_refine_is_refused_for_zoo_names(tmp_path):
    result = runner.invoke(app, ["sample", "zoo:ring:1", "--refine", "2", "-o", str(tmp_path / "x.ffrf.h5")])
    assert result.exit_code == 2 and "--refine 2: a zoo body's mesh density is drawn from its seed" in result.output


@pytest.mark.slow
@pytest.mark.parametrize("family", FAMILIES)
def test_every_family_builds_free_free_and_passes_the_checks(family):
    for seed in (0, 1000):
        body = zoo_body(family, seed)
        failed = [c.name for c in run_checks(body) if not c.passed]
        assert not failed, (family, seed, failed)
        # six rigid modes dropped (fe.modal checks them): the first flexible one is a real vibration
        assert 5.0 < body.frequencies_hz[0] < 5e4, (family, seed)
        assert body.fe.mesh.n_nodes <= MAX_NODES and body.fe.stress_nodal is not None
        assert body.static_centrifugal is not None and body.geometric is not None
        assert f"zoo: family={family}, seed={seed}" in body.provenance.notes[0]
