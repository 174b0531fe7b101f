"""Rigid modes told by their shape, with a zero rule scaled by the run's own flexible modes (io.rigid_modes)."""
from __future__ import annotations

import numpy as np
import pytest

from ffrf_advisor.errors import BodyFileError
from ffrf_advisor.fe.modal import rigid_modes
from ffrf_advisor.io.rigid_modes import rigid_modes_of


def _run(flexible_hz, rigid_lambda=1e-5):
    """Six rigid shapes of 50 nodes and one smooth non-rigid shape per flexible frequency."""
    rng = np.random.default_rng(1)
    points = rng.uniform(-1, 1, (50, 3))
    R = rigid_modes(points).reshape(50, 3, 6)
    flex = np.stack([np.sin((k + 2) * points @ [1.0, 0.3, 0.2])[:, None] * [1.0, 0.5, 0.2]
                     for k in range(len(flexible_hz))], axis=-1)
    lam = np.concatenate([np.full(6, rigid_lambda), (2 * np.pi * np.asarray(flexible_hz)) ** 2])
    return points, np.concatenate([R, flex], axis=2), lam


def test_a_run_over_four_decades_of_frequency_keeps_its_lowest_modes():
    """5 Hz to 50 kHz: 1e-6 of the largest eigenvalue would call the 5 Hz mode zero (a mechanism)."""
    points, T, lam = _run(np.geomspace(5.0, 5e4, 12))
    rigid, notes = rigid_modes_of("f", points, T, lam, 6, "free")
    assert rigid.tolist() == [True] * 6 + [False] * 12 and not any("warning" in n for n in notes)


@pytest.mark.parametrize("k, factor, expects", [(8, 1e-14, "a rigid-body shape at zero frequency"),
                                                 (2, 1e12, "a zero frequency for a rigid-body shape")])
def test_a_damaged_eigenvalue_is_refused_naming_its_mode(k, factor, expects):
    points, T, lam = _run(np.geomspace(5.0, 5e4, 12))
    lam[k] *= factor
    with pytest.raises(BodyFileError, match=f"{expects}.*mode {k + 1}:"):
        rigid_modes_of("f", points, T, lam, 6, "free")


def test_a_constrained_run_gets_a_warning_and_a_free_one_an_error():
    points, T, lam = _run([10.0, 20.0, 40.0])
    keep = [0, 1, 2, 6, 7, 8]  # three rigid shapes left
    _, notes = rigid_modes_of("f", points, T[:, :, keep], lam[keep], None, "supports")
    assert any(n.startswith("warning: 3 rigid modes instead of six") for n in notes)
    with pytest.raises(BodyFileError, match="expected 6 rigid modes"):
        rigid_modes_of("f", points, T[:, :, keep], lam[keep], 6, "free")
