"""The shipped sample body is what its recipe makes."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ffrf_advisor.io import read_body
from ffrf_advisor.samples import beam

SAMPLES = Path(__file__).resolve().parent.parent / "sample_bodies"


def test_shipped_beam_matches_its_recipe():
    shipped = read_body(SAMPLES / "beam.ffrf.h5")
    made = beam()
    assert (SAMPLES / "beam.ffrf.h5").stat().st_size < 2e6
    assert np.abs(shipped.eigenvalues / made.eigenvalues - 1).max() < 1e-10
    for name in ("I", "Ibar", "Sbar"):
        a, b = getattr(shipped.integrals, name), getattr(made.integrals, name)
        assert np.abs(a - b).max() <= 1e-10 * np.abs(b).max(), name
