"""The exponential (generalized Lawson DOP853) integrator, sim.lawson (issue 52): exact on the modal oscillators at
steps far beyond the explicit limit, step for step its numpy reference, and the reference of `verify`."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ffrf_advisor.analysis import Options, analyze
from ffrf_advisor.guidelines import Situation
from ffrf_advisor.io import read_body
from ffrf_advisor.sim import lawson, lawson_reference
from ffrf_advisor.sim.integrate import EXPONENTIAL, Rhs, _output_times, compiled_args, integrate
from ffrf_advisor.sim.model import Model, build_model, initial_state
from ffrf_advisor.terms import FULL
from ffrf_advisor.verify import runner
from ffrf_advisor.verify.measures import worst
from ffrf_advisor.verify.reference import scene_errors
from ffrf_advisor.verify.scenes import make_scenes
from ffrf_advisor.zoo import FAMILIES, TEST_SEEDS_FROM, zoo_body

DIR = Path(__file__).resolve().parent.parent / "sample_bodies"
SAMPLES = ("beam", "carbody", "conrod", "genstruct1", "genstruct2", "plate")
# the scenes the slow comparisons run: modes started deflected, a prescribed spin ramp, a torque pulse (about each
# stable axis); mode-release and minor-axis add the CI minutes without another kind of motion
COMPARED = ("free-spin", "spin-up", "torque-pulse")
NO_LOADS = np.array([0.0, 0.0, 0.0, np.inf, 0.0, 0.0, 0.0, 0.0, 0.0])  # sim.loads.LoadProgram().packed()


def oscillators(hz: np.ndarray, zeta: float = 0.0) -> Model:
    """A rigid body at rest (I0 = 1) with modes of ``hz`` and no coupling: q'' = F - Omega^2 q - 2 zeta Omega q'."""
    nf, om = len(hz), 2 * np.pi * np.asarray(hz, float)
    return Model(("gyro0",), np.eye(3), np.zeros((3, 3, nf)), np.zeros((3, 3, nf, nf)), np.zeros((3, nf, nf)),
                 om ** 2, 2 * zeta * om, np.zeros((6, nf, nf)))


def _lawson(model, y0, t_end, rtol, fext):
    t = _output_times(t_end, t_end / 400)
    out = np.empty((len(t), len(y0)))
    address, compiled = compiled_args(model)
    rows, nfev, steps, code, _ = lawson.integrate_lawson(address, y0, t_end, rtol, np.full(len(y0), 1e-12), t, 10**9,
                                                         out, compiled, NO_LOADS, fext)
    assert code == 0 and rows == len(t)
    return t, out, nfev, steps


@pytest.mark.parametrize("zeta", [0.0, 0.001])
def test_oscillators_from_1_hz_to_10_khz_under_a_constant_force_are_exact_at_steps_far_past_the_explicit_limit(zeta):
    """Modes of 1 Hz .. 10 kHz, started deflected and moving, pushed by a constant modal force (the slowest
    forcing): every sample matches the closed-form response to round-off, while the mean step is more than 100x
    DOP853's stability limit on the 10 kHz mode (about 6 / Omega_max: its region reaches -6 on the real axis and
    less on the imaginary one)."""
    hz = np.geomspace(1.0, 1e4, 9)
    m = oscillators(hz, zeta)
    om, F = 2 * np.pi * hz, np.linspace(1.0, 2.0, 9) * (2 * np.pi * hz) ** 2 * 1e-3  # static deflections 1e-3..2e-3
    q0, v0 = np.full(9, 1e-3), -2e-3 * 2 * np.pi * hz
    y0 = np.concatenate([[1.0, 0, 0, 0, 0, 0, 0], q0, v0])
    t, out, nfev, steps = _lawson(m, y0, 1.0, 1e-10, F)
    a, w = zeta * om, om * np.sqrt(1 - zeta ** 2)  # closed form about the static deflection F / Omega^2
    c0, s0 = q0 - F / om ** 2, (v0 + a * (q0 - F / om ** 2)) / w
    tt = t[:, None]
    q = F / om ** 2 + np.exp(-a * tt) * (c0 * np.cos(w * tt) + s0 * np.sin(w * tt))
    qd = np.exp(-a * tt) * ((s0 * w - a * c0) * np.cos(w * tt) - (c0 * w + a * s0) * np.sin(w * tt))
    # round-off: the phase Omega t reaches 6.3e4 rad, whose double carries ~1e-11 rad, over a few dozen steps
    assert np.abs(out[:, 7:16] - q).max() <= 1e-10 * np.abs(q).max()
    assert np.abs(out[:, 16:] - qd).max() <= 1e-10 * np.abs(qd).max()
    assert 1.0 / steps > 100 * 6 / om.max() and nfev < 1000


def test_the_compiled_scheme_is_its_numpy_reference_step_for_step():
    """The beam spinning at 300 rad/s with every mode deflected (full set, 0.01 s, rtol 1e-9): the same evaluations
    and steps, samples to 1e-10 of their size (closed-form against scipy's expm propagators: round-off)."""
    m = build_model(read_body(DIR / "beam.ffrf.h5"), FULL)
    y0 = initial_state(m, (0.0, 0.0, 300.0), np.full(m.nf, 1e-4))
    t_end, rtol, atol = 0.01, 1e-9, np.full(len(y0), 1e-13)
    t = _output_times(t_end, t_end / 50)
    ref, nfev, steps = lawson_reference.integrate_lawson(m, Rhs(m), y0, t_end, rtol, atol, t)
    run = integrate(m, y0, t_end, EXPONENTIAL, rtol=rtol, atol=atol, output_step=t_end / 50)
    assert (run.nfev, run.steps) == (nfev, steps)
    assert np.all(np.abs(run.y - ref) <= 1e-10 * np.abs(ref).max(axis=0))


def test_propagators_are_the_matrix_exponential():
    """Closed form against scipy.linalg.expm, undamped, light, critical and heavy damping, zero stiffness."""
    m = Model(("gyro0",), np.eye(3), np.zeros((3, 3, 5)), np.zeros((3, 3, 5, 5)), np.zeros((3, 5, 5)),
              np.array([4e8, 1e4, 4.0, 1.0, 0.0]), np.array([0.0, 4.0, 4.0, 3.0, 0.5]), np.zeros((6, 5, 5)))
    E = np.empty((5, 4))
    lawson.propagators(m.eigenvalues, m.damping, 0.37, E)
    ref = lawson_reference.propagator(m, 0.37).reshape(5, 4)
    om = np.maximum(np.sqrt(m.eigenvalues), 1.0)[:, None]
    scaled = np.hstack([np.ones_like(om), om, 1 / om, np.ones_like(om)])  # q and q' / Omega on one scale
    # the 2e4 rad/s mode turns 7400 rad, whose phase carries 7400 eps = 1.6e-12; expm's scaling and squaring of
    # that rotation loses up to a few 1e-11
    assert np.abs((E - ref) * scaled).max() <= 1e-10


def _scenes(name: str, fraction: float):
    body = read_body(DIR / f"{name}.ffrf.h5")
    a = analyze(body, Options(situation=Situation(w_op=1.0)))
    s_crit = a.significance.s_crit
    speed = fraction * (float(np.min(s_crit)) if s_crit is not None and np.isfinite(s_crit).any()
                        else 2 * np.pi * float(body.frequencies_hz[0]))
    a = analyze(body, Options(situation=Situation(w_op=speed)))
    scenes = make_scenes(list(COMPARED), a)
    return runner.for_scenes(a, scenes), scenes


@pytest.mark.slow  # minutes: three kinds of scene of the six samples at three speeds, both references
@pytest.mark.parametrize("name", SAMPLES)
@pytest.mark.parametrize("fraction", [0.01, 0.1, 0.5])
def test_the_exponential_reference_matches_dop853s_on_the_samples(name, fraction):
    """The new reference (exponential, rtol 1e-10) against the former (DOP853, rtol 1e-10) in the COMPARED scenes of
    every sample at 0.01, 0.1 and 0.5 of its smallest s_crit: response errors within a tenth of verify's default
    tolerance (1e-3, the self-check's limit), so the verdicts cannot change, or both without a verdict
    (``_same_judgement``; bench_verify part 7 runs every scene: within 1.6e-7)."""
    _same_judgement(*_scenes(name, fraction))


def _same_judgement(a, scenes) -> None:
    """Each scene's exponential reference within 1e-3 (a tenth of the default tolerance) of DOP853's by the response
    errors; where not, neither self-converges (each differs from its own run at 1e-12 by more than 1e-3: chaotic
    motion), so both give no verdict there."""
    for sc in scenes:
        m = runner.reference_model(a, sc)
        new, old = (runner.run_scene(m, sc, integ, rtol=1e-10) for integ in (EXPONENTIAL, "dop853"))
        assert not new.failed, sc.label
        if worst(scene_errors(a, new, old), "response") > 1e-3:
            for run in (new, old):
                tight = runner.run_scene(m, sc, run.method, rtol=1e-12)
                assert worst(scene_errors(a, run, tight), "response") > 1e-3, (sc.label, run.method)


@pytest.mark.slow  # minutes: a body of every zoo family built, run through the COMPARED scenes twice
@pytest.mark.parametrize("family", FAMILIES)
def test_the_exponential_reference_matches_dop853s_on_a_body_of_every_zoo_family(family):
    """As on the samples, for the first test-set body of each zoo family at 0.1 of its smallest s_crit (the strip's
    free spins tumble: neither reference self-converges, 0.09-0.12 against their runs at 1e-12)."""
    from ffrf_advisor.significance import softening_speeds
    body = zoo_body(family, TEST_SEEDS_FROM)
    s_crit = softening_speeds(body)
    speed = 0.1 * (float(np.min(s_crit)) if np.isfinite(s_crit).any() else 2 * np.pi * float(body.frequencies_hz[0]))
    a = analyze(body, Options(situation=Situation(w_op=speed)))
    scenes = make_scenes(list(COMPARED), a)
    _same_judgement(runner.for_scenes(a, scenes), scenes)
