"""q_max and the small-deformation warning (theory section 6): a mode deflecting more than SMALL_DEFORMATION of the
body's size at q_max is named, with what bounded q_max and the options that lower it."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from ffrf_advisor.amplitudes import SMALL_DEFORMATION, AmplitudeOptions, q_max
from ffrf_advisor.cli import app
from ffrf_advisor.io import read_body

BEAM = Path(__file__).resolve().parent.parent / "sample_bodies" / "beam.ffrf.h5"


@pytest.fixture(scope="module")
def beam():
    return read_body(BEAM, load_fe=True)  # the nodal modes: the deflection ratio needs them


def _large(amp) -> list[str]:
    return [w for w in amp.warnings if w.startswith("large deformation")]


def test_the_shipped_beam_at_defaults_stays_within_small_deformations(beam):
    amp = q_max(beam)
    assert amp.deflection_ratio is not None and 0 < amp.deflection_ratio.max() < SMALL_DEFORMATION
    assert _large(amp) == []


@pytest.mark.parametrize("opts, governs, names", [
    (AmplitudeOptions(q_cap=20.0, sigma_allow=1e5), "cap", "q_cap of 20 t-mm units"),
    (AmplitudeOptions(q_cap=1e3, sigma_allow=5e4), "stress", "bounded by the stress (sigma_allow 50000 N/mm^2"),
    (AmplitudeOptions(q_cap=1e3, sigma_allow=1e6, deflection_cap=0.2), "deflection", "deflection cap 0.2"),
])
def test_a_large_q_max_warns_naming_the_mode_the_ratio_and_what_bounded_it(beam, opts, governs, names):
    amp = q_max(beam, opts)
    assert amp.governs[0] == governs
    p = int(np.argmax(amp.deflection_ratio))
    [warning] = _large(amp)
    assert f"mode {p + 1} deflects {amp.deflection_ratio[p]:.3g}" in warning and names in warning
    assert "--deflection-cap" in warning


@pytest.mark.parametrize("share, fires", [(0.98, False), (1.02, True)])
def test_the_warning_starts_just_above_the_small_deformation_limit(beam, share, fires):
    """q_max given per mode so that mode 1 deflects share x SMALL_DEFORMATION and the others barely move."""
    unit = q_max(beam, AmplitudeOptions(q_max=(1.0,) * beam.nf)).deflection_ratio  # ratio per unit q
    q = np.full(beam.nf, 1e-6)
    q[0] = share * SMALL_DEFORMATION / unit[0]
    amp = q_max(beam, AmplitudeOptions(q_max=tuple(q)))
    assert bool(_large(amp)) is fires
    if fires:
        assert "mode 1 " in _large(amp)[0] and "given per mode (--q-max)" in _large(amp)[0]


def test_analyze_shows_the_warning_and_is_quiet_at_defaults():
    runner = CliRunner()
    loud = json.loads(runner.invoke(app, ["analyze", str(BEAM), "--q-cap", "20", "--sigma-allow", "1e5",
                                          "--json"]).stdout)
    assert any(w.startswith("large deformation") and "q_cap of 20" in w for w in loud["warnings"])
    quiet = json.loads(runner.invoke(app, ["analyze", str(BEAM), "--json"]).stdout)
    assert not any(w.startswith("large deformation") for w in quiet["warnings"])
