"""Checks of theory section 4: each fires with the expected value on a deliberately broken body."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from ffrf_advisor.body import ModalFE
from ffrf_advisor.checks import check_values, density_text, density_warnings, run_checks, solid_density
from ffrf_advisor.fe.material import STEEL
from ffrf_advisor.fe.mesh import box_mesh
from ffrf_advisor.fe_body import modal_body
from ffrf_advisor.invariants import shape_integrals


def _failed(body):
    return {c.name for c in run_checks(body) if not c.passed}


def _with_modes(body, Phi):
    fe = body.fe
    return replace(body, integrals=shape_integrals(fe.mesh.points, fe.Ms, Phi),
                   fe=ModalFE(fe.mesh, fe.Ms, Phi, fe.K))


def test_generated_bodies_pass_every_check(block_body, lshape_body):
    assert _failed(block_body) == set()
    assert _failed(lshape_body) == set()


def test_com_offset_is_measured(block_body):
    c = np.array([3.0, -4.0, 0.0])
    moved = replace(block_body, integrals=block_body.integrals.shifted(c))
    assert abs(check_values(moved)["com_offset"] - 5.0 / 300.0) < 1e-12
    # about the new origin the product of inertia -m c_x c_y appears as well
    assert _failed(moved) == {"com_offset", "principal_axes"}


def test_principal_axis_misalignment_is_measured(block_body):
    theta = 0.01
    R = np.array([[np.cos(theta), -np.sin(theta), 0], [np.sin(theta), np.cos(theta), 0], [0, 0, 1]])
    turned = replace(block_body, integrals=block_body.integrals.rotated(R))
    I0 = block_body.I0
    expected = abs(I0[0, 0] - I0[1, 1]) * np.sin(theta) * np.cos(theta) / np.trace(I0)
    assert abs(check_values(turned)["principal_axes"] / expected - 1) < 1e-8
    assert "principal_axes" in _failed(turned)


def test_unnormalised_modes_fail(block_body):
    bad = _with_modes(block_body, block_body.fe.Phi * 1.01)
    assert abs(check_values(bad)["mass_normalisation"] - (1.01**2 - 1)) < 1e-12
    assert "mass_normalisation" in _failed(bad)


def test_rigid_content_in_modes_fails_free_surface(block_body):
    Phi = np.array(block_body.fe.Phi)
    t = 1e-3
    Phi[:, 0, 2] += t  # a rigid translation mixed into mode 3
    bad = _with_modes(block_body, Phi)
    expected = t * block_body.mass / np.sqrt(block_body.mass)
    assert abs(check_values(bad)["free_surface_translation"] / expected - 1) < 1e-6
    Phi = np.array(block_body.fe.Phi)
    Phi[:, :, 1] += 1e-3 * np.cross([0, 0, 1.0], block_body.fe.mesh.points)  # a rigid rotation
    assert "free_surface_rotation" in _failed(_with_modes(block_body, Phi))


def test_eigenvalue_order_and_sign(block_body):
    lam = np.array(block_body.eigenvalues)
    lam[[0, 1]] = lam[[1, 0]]
    assert check_values(replace(block_body, eigenvalues=lam))["eigenvalue_order"] == 1
    lam = np.array(block_body.eigenvalues)
    lam[0] = -1.0
    assert "eigenvalue_order" in _failed(replace(block_body, eigenvalues=lam))


# --- density and the bounding box (issue 49, part 2) ------------------------------------------------------------

STEEL_KG_M3 = 7.85e-9 * 1e3 / 1e-9  # 7.85e-9 t/mm^3 in kg/m^3
ROUND_OFF = 1e-9  # nodal sums of the consistent mass and the cells' volumes by exact quadrature


def _heavier(body, factor):
    """The body with its mass (all of Ms) multiplied: the same shape, a density in other units."""
    fe = body.fe
    return replace(body, integrals=shape_integrals(fe.mesh.points, fe.Ms * factor, fe.Phi / np.sqrt(factor)),
                   fe=ModalFE(fe.mesh, fe.Ms * factor, fe.Phi / np.sqrt(factor), fe.K))


def _mass_only(body, factor):
    """Only the mass number multiplied (a damaged single copy), the second moments kept."""
    return replace(body, integrals=replace(body.integrals, mass=body.integrals.mass * factor))


def test_the_solid_density_of_a_block_is_its_material_s(block_body):
    assert solid_density(block_body) == pytest.approx(STEEL_KG_M3, rel=ROUND_OFF)
    assert density_text(block_body) == "density 7850 kg/m^3 (solid cells)" and density_warnings(block_body) == ()


def test_a_density_in_kg_per_mm3_read_as_t_per_mm3_is_named(block_body):
    (warning,) = density_warnings(_heavier(block_body, 1e3))
    assert "outside engineering materials" in warning and "7.85e+06 kg/m^3" in warning
    assert "a density in kg/mm^3 read as t/mm^3?" in warning


def test_a_density_x2_stays_silent_but_shows_in_the_headline(block_body):
    """Twice steel is a heavy alloy, not an impossible body: no warning, but the number is in the headline."""
    assert density_warnings(_heavier(block_body, 2)) == ()
    assert density_text(_heavier(block_body, 2)) == "density 1.57e+04 kg/m^3 (solid cells)"


def test_a_mass_too_small_for_its_inertia_is_named(block_body):
    """A tenth of the mass with the same inertia: the equivalent box grows by sqrt(10) > sqrt(3), which no mass
    distribution inside the 300 x 70 x 40 mm bounding box allows; half of it (sqrt(2)) a hollow body could."""
    light = density_warnings(_mass_only(block_body, 0.1))
    assert any("too small for its inertia" in w and "bounding box 300 x 70 x 40 mm" in w for w in light), light
    assert density_warnings(_mass_only(block_body, 0.5)) == ()


def test_a_cached_compact_body_heavier_than_any_material_in_its_box_is_named():
    """A 50 x 45 x 40 mm steel block read from its cache (no cells; the largest dimension only, a 50 mm cube):
    five times its density (39,250 kg/m^3) is within the apparent density's range (below 1e5) but fills the cube
    at 39,250 x 0.72 = 28,260 kg/m^3, beyond osmium's. (Unequal edges: a cube's principal axes are arbitrary.)"""
    cube = modal_body(box_mesh([50.0, 45.0, 40.0], [2, 2, 2], "hexahedron"), STEEL, 6)
    cached = lambda body: replace(body, fe=None, nodal=body.fe.summary())  # noqa: E731
    assert density_warnings(cached(cube)) == ()
    (warning,) = density_warnings(cached(_heavier(cube, 5)))
    assert "does not fit the bounding box 50 x 50 x 50 mm: 2.826e+04 kg/m^3" in warning, warning


def test_a_cached_body_is_held_to_its_largest_dimension(tmp_path):
    from ffrf_advisor.io import read_body
    beam = read_body(Path(__file__).resolve().parent.parent / "sample_bodies" / "beam.ffrf.h5", load_fe="summary")
    assert beam.fe is None and density_warnings(beam) == ()
    assert density_text(beam).startswith("apparent density 7850 kg/m^3")  # the beam is a solid box
    assert any("too small for its inertia" in w for w in density_warnings(_mass_only(beam, 0.01)))


def test_the_headlines_of_info_and_analyze_show_mass_and_density():
    from typer.testing import CliRunner

    from ffrf_advisor.cli import app
    beam = str(Path(__file__).resolve().parent.parent / "sample_bodies" / "beam.ffrf.h5")
    runner = CliRunner()
    info = runner.invoke(app, ["info", beam], env={"COLUMNS": "200"})
    analyze = runner.invoke(app, ["analyze", beam, "--speed", "300rad/s"], env={"COLUMNS": "200"})
    assert info.exit_code == analyze.exit_code == 0
    assert "mass      6.280000e-03 t; apparent density 7850 kg/m^3 (equivalent box)" in info.stdout
    assert analyze.stdout.splitlines()[2] == "body: mass 0.00628 t, apparent density 7850 kg/m^3 (equivalent box)"


def test_a_readers_warning_reaches_the_advice():
    """A warning a reader left in the notes (a constrained run's rigid-mode count) is in analyze's and gate's
    warnings, not only in info's provenance (issue 49)."""
    from dataclasses import replace as _replace

    from ffrf_advisor.analysis import analyze
    from ffrf_advisor.io import read_body
    from pathlib import Path
    beam = read_body(Path(__file__).resolve().parents[1] / "sample_bodies" / "beam.ffrf.h5")
    note = "warning: 5 rigid modes instead of six (modes 1-5): the body is constrained"
    body = _replace(beam, provenance=beam.provenance.with_note(note))
    assert f"source: {note}" in analyze(body).advice.warnings
    assert not any(w.startswith("source:") for w in analyze(beam).advice.warnings)
