"""Trajectory and response errors of theory section 10 on runs made by hand (analytic expectations)."""
from __future__ import annotations

import numpy as np
import pytest

from ffrf_advisor.sim.integrate import Run
from ffrf_advisor.verify.measures import errors, worst

T = np.linspace(0.0, 50.0, 4001)  # 50 periods of a unit-period mode, 80 samples per period


def _run(q: np.ndarray, w: float = 1.0) -> Run:
    """A run with a fixed orientation, spin w about axis 3 and one modal coordinate q(t)."""
    y = np.zeros((len(T), 9))
    y[:, 0] = 1.0
    y[:, 6] = w
    y[:, 7] = q
    return Run("hand", T, y, nfev=0, steps=0, wall_s=0.0)


def test_a_pure_phase_drift_fails_the_trajectory_but_not_the_response():
    """A 1e-3 frequency error over 50 periods: the phase has moved by 2 pi 50 1e-3 = 0.31 rad, so the
    pointwise q error is 2 sin(0.31 / 2) = 0.31; the mean and the rms about it change by at most about
    the frequency error (over whole periods, not at all)."""
    e = 1e-3
    ref, run = _run(np.sin(2 * np.pi * T)), _run(np.sin(2 * np.pi * (1 + e) * T))
    err = errors(run, ref, None)
    assert err["q"] == pytest.approx(2 * np.sin(np.pi * 50 * e), rel=1e-3)
    assert err["q_response"] < 2 * e and err["stress_peak"] < 1e-3
    assert worst(err, "trajectory") > 0.3 and worst(err, "response") < 2 * e


def test_a_missing_static_deflection_counts_in_first_order():
    """Oscillation about 0.05 (the centrifugal widening) against one about 0: the mean is off by 0.05 of
    the amplitude 1.05, and the peak stress too; an rms norm of the whole signal would see only 0.05^2."""
    ref, run = _run(0.05 + np.sin(2 * np.pi * T)), _run(np.sin(2 * np.pi * T))
    err = errors(run, ref, np.array([1.0]))
    assert err["q_response"] == pytest.approx(0.05 / 1.05, rel=1e-3)
    assert err["stress_peak"] == pytest.approx(0.05 / 1.05, rel=1e-3)


def test_a_changed_amplitude_and_spin_count():
    ref, run = _run(np.sin(2 * np.pi * T)), _run(1.02 * np.sin(2 * np.pi * T), w=1.01)
    err = errors(run, ref, None)
    assert err["q_response"] == pytest.approx(0.02, rel=1e-2)
    assert err["w_response"] == pytest.approx(0.01, rel=1e-6)


def test_floors_scale_the_errors_of_a_scene_that_barely_deforms():
    """A reference deflection of 1e-6 missed entirely is 1e-6 / (0.1 |q_max|) with q_max = 1e-2."""
    ref, run = _run(np.full(len(T), 1e-6)), _run(np.zeros(len(T)))
    err = errors(run, ref, None, q_max=np.array([1e-2]))
    assert err["q_response"] == pytest.approx(1e-3) and err["q"] == pytest.approx(1e-3)


def test_a_failed_run_has_infinite_errors():
    ref = _run(np.sin(2 * np.pi * T))
    bad = Run("hand", T, ref.y, 0, 0, 0.0, failed=True)
    assert all(np.isinf(v) for v in errors(bad, ref, None).values())
