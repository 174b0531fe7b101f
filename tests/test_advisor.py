"""Advisor (theory sections 6-9): rules on synthetic bodies, invariances, FE bodies."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ffrf_advisor.amplitudes import AmplitudeOptions, q_max
from ffrf_advisor.analysis import Options, analyze
from ffrf_advisor.body import FlexibleBody
from ffrf_advisor.errors import FFRFError
from ffrf_advisor import guidelines
from ffrf_advisor.situation import THRESHOLDS, parse_speed
from ffrf_advisor.invariants import ShapeIntegrals
from ffrf_advisor.io import read_body
from ffrf_advisor.significance import centrifugal_terms, coriolis_terms, significance
from ffrf_advisor.units import SI, TMM, factor

from .test_cli import SAMPLE


def Situation(**kw) -> guidelines.Situation:
    """These tests check the rules of theory 8 (``--rules thresholds``); tests/test_predict.py the default advice."""
    return guidelines.Situation(rules="thresholds", **kw)

NF = 2
LAM = np.array([4e4, 1.6e5])  # Omega = 200, 400 rad/s


def synthetic(I0=100.0, Ibar=None, Sbar=None, sigma=None, lam=LAM) -> FlexibleBody:
    """A body defined by its invariants: I0 = I0 * 1, modes moving along x unless Sbar says otherwise."""
    if Sbar is None:
        Sbar = np.zeros((3, 3, NF, NF))
        Sbar[0, 0] = np.eye(NF)
    J = ShapeIntegrals(mass=1.0, first_moment=np.zeros(3), I=np.eye(3) * I0 / 2,
                       Ibar=np.zeros((3, 3, NF)) if Ibar is None else Ibar, Sbar=Sbar, mode_sum=np.zeros((3, NF)))
    return FlexibleBody("synthetic", J, lam, sigma_max=sigma)


def advise(body, q=(1.0, 0.5), **situation):
    return analyze(body, Options(AmplitudeOptions(q_max=q), Situation(**situation))).advice


def rule(advice, name):
    return next(r for r in advice.rules if r.name == name)


def test_quiet_body_is_level_I():
    adv = advise(synthetic(I0=1000.0), w_op=10.0, f_sys=1000.0)  # dI_Q = 1e-3
    assert adv.level == "I" and adv.terms == ("gyro0",)


@pytest.mark.parametrize("x, fires", [(0.01, True), (0.001, False)])  # threshold 0.005
def test_linear_inertia_rule(x, fires):
    Ibar = np.zeros((3, 3, NF))
    Ibar[0, 0, 0] = x * 1000.0 / 2  # W1 diagonal 2 Ibar_11 about axes 2, 3: dI_L = x (dI_Q = 1e-3)
    adv = advise(synthetic(I0=1000.0, Ibar=Ibar))
    assert rule(adv, "dI_L").value == pytest.approx(x, rel=1e-12)
    assert ("inertia_lin" in adv.terms) is fires and (adv.level == "III") is fires
    assert advise(synthetic(I0=1000.0, Ibar=Ibar), connection="stiff").level == "I"


@pytest.mark.parametrize("I0, fires", [(100.0, True), (1000.0, False)])  # dI_Q = 1 / I0 against 0.005
def test_quadratic_inertia_rule(I0, fires):
    adv = advise(synthetic(I0=I0))  # (Qf^T W2 Qf)_22 = q^2 Sbar_11 = 1
    assert rule(adv, "dI_Q").value == pytest.approx(1.0 / I0, rel=1e-12)
    assert ("inertia_quad" in adv.terms) is fires
    assert advise(synthetic(I0=I0), connection="soft").level == ("III" if fires else "I")


@pytest.mark.parametrize("c", [0.9, 0.5, 0.1])
def test_coupling_rule(c):
    Sbar = np.zeros((3, 3, NF, NF))
    Sbar[0, 0] = Sbar[1, 1] = np.eye(NF) / 2
    Sbar[0, 1] = [[0, c], [0, 0]]
    Sbar[1, 0] = Sbar[0, 1].T
    adv = advise(synthetic(I0=10.0, Sbar=Sbar), q=(1.0, 0.0))
    # C = q_1 W3[3, 1, :] = (0, c) about axis 3: dI_fT = c^2 / I0_33, dI_Tf = c^2 / I0_33
    assert rule(adv, "dI_fT").value == pytest.approx(c**2 / 10.0, rel=1e-12)
    assert rule(adv, "dI_Tf").value == pytest.approx(c**2 / 10.0, rel=1e-12)
    assert ("coupling" in adv.terms) is (c**2 / 10 > THRESHOLDS["dI_fT"])


def widening_body(sigma=None):
    """W1[0, 0] = 2 (Ibar_22 + Ibar_33) = 1000 dominates W2: centrifugal ratio about 2e-3."""
    Ibar = np.zeros((3, 3, NF))
    Ibar[1, 1, 0] = 500.0
    return synthetic(I0=1e6, Ibar=Ibar, sigma=sigma)


def test_widening_rule_by_user_and_by_centrifugal_stress():
    assert advise(widening_body(), widening=True).level == "II"
    assert rule(advise(widening_body()), "widening").fired is None  # no speed: not evaluated
    sigma = np.array([1.0, 1.0])
    for w, fires in ((20.0, True), (1.0, False)):  # 1e-2 and 2.5e-5 of sigma_allow against 5e-4
        adv = advise(widening_body(sigma), w_op=w)
        expected = (0.5 * 1000.0 * w**2 / LAM[0]) * sigma[0] / 500.0  # sum_p |q_c,p| sigma_p / sigma_allow
        assert rule(adv, "widening").value == pytest.approx(expected, rel=1e-12)
        assert ("cf1" in adv.terms) is fires


def test_a_free_body_gets_whole_energy_groups_and_a_stiffly_connected_one_the_rules_set():
    """cf1 alone (rule II) leaves a free spin without its W1 partners: the set is closed to the W1 group."""
    body = widening_body(np.array([1.0, 1.0]))
    free = advise(body, w_op=5.0, f_sys=1e4)  # widening 6.25e-4 > 5e-4, r_cf2 6.3e-4 < 5e-3
    assert free.terms == ("gyro0", "cf1", "inertia_lin", "cor1") and free.lagrangian and free.level == "II"
    assert rule(free, "lagrangian_closure").terms == ("inertia_lin", "cor1")
    stiff = advise(body, w_op=5.0, f_sys=1e4, connection="stiff")
    assert stiff.terms == ("gyro0", "cf1") and not stiff.lagrangian and not rule(stiff, "lagrangian_closure").fired


def test_cf2_follows_the_response_measure_with_or_without_widening():
    """r_cf2 (theory 7): about axes 2 and 3 Kc = I, so Omega_1(s) = sqrt(200^2 - s^2): at 150 rad/s the
    frequency falls by 1 - sqrt(1 - 0.75^2) = 34 %, and the static response q2 / q0 - 1 = 1/(1 - 0.5625) - 1;
    at 10 rad/s by 1.25e-3 and 2.5e-3, below 0.005."""
    body = widening_body()
    quiet = advise(body, w_op=10.0, widening=True, f_sys=1e4)
    assert "cf2" not in quiet.terms and rule(quiet, "cf2").value == pytest.approx(1 / (1 - 0.05**2) - 1)
    loud = advise(body, w_op=150.0, widening=True, f_sys=1e4)
    assert "cf2" in loud.terms and loud.level == "III"
    assert rule(loud, "cf2").value == pytest.approx(1 / (1 - 0.75**2) - 1, rel=1e-9)
    assert any("softening limit" in w for w in loud.warnings)  # 150 / 200 > 0.5
    assert not any("softening limit" in w for w in advise(body, w_op=10.0, f_sys=1e4).warnings)
    assert "cf2" in advise(body, w_op=150.0, widening=False).terms  # the frequency shift alone decides
    assert rule(advise(body, widening=True), "cf2").fired is None  # no speed: not evaluated
    # W1 = 0 (symmetric body): no static response to change, but the frequency shift decides
    symmetric = advise(synthetic(), w_op=150.0, widening=True, f_sys=1e4)
    assert "cf2" in symmetric.terms
    assert rule(symmetric, "cf2").value == pytest.approx(1 - np.sqrt(1 - 0.75**2), rel=1e-9)


def test_coriolis_rules_follow_speed_ratio_and_connection():
    body = synthetic(I0=1e6)
    assert rule(advise(body), "speed_ratio").fired is None
    fast = advise(body, w_op=2 * np.pi * 2.0, f_sys=10.0)  # ratio 0.2; 12.6 rad/s against Omega_1 = 200 rad/s
    assert rule(fast, "speed_ratio").value == pytest.approx(0.2) and "cor1" in fast.terms
    assert fast.level == "IV" and not {"cor_quad", "cor_coupling"} & set(fast.terms)
    assert "cor1" not in advise(body, w_op=2 * np.pi * 0.5, f_sys=10.0).terms
    assert "cor1" not in advise(body, w_op=2 * np.pi * 2.0, f_sys=10.0, connection="stiff").terms
    beam_like = advise(synthetic(I0=10.0), w_op=2 * np.pi * 2.0, f_sys=10.0)
    assert {"inertia_quad", "cor1", "cor_quad", "cor_coupling"} <= set(beam_like.terms)


def test_f_sys_default_warns():
    adv = advise(synthetic(), w_op=10.0)
    assert any("f_sys not given" in w for w in adv.warnings)


def test_speed_parsing():
    assert parse_speed("3000rpm") == pytest.approx(100 * np.pi)
    assert parse_speed("50Hz") == pytest.approx(100 * np.pi)
    assert parse_speed("314 rad/s") == 314.0 and parse_speed("12") == 12.0
    for bad in ("fast", "-3rpm", "3000 rpms", "nan"):
        with pytest.raises(FFRFError):
            parse_speed(bad)


def test_q_max_procedure_and_cap_conversion(block_body):
    amp = q_max(block_body)
    q1 = min(1.0, 500.0 / block_body.sigma_max[0])
    assert amp.q_max[0] == pytest.approx(q1, rel=1e-14)
    assert np.allclose(amp.q_max, q1 * block_body.eigenvalues[0] / block_body.eigenvalues, rtol=1e-14)
    si = q_max(block_body.converted(SI))
    assert si.q_cap == pytest.approx(factor(TMM, SI, "q"), rel=1e-15)
    assert np.allclose(si.q_max, amp.q_max * factor(TMM, SI, "q"), rtol=1e-12)
    capped = q_max(block_body, AmplitudeOptions(deflection_cap=1e-6))
    assert capped.governs[0] == "deflection"
    assert capped.deflection_ratio[0] == pytest.approx(1e-6, rel=1e-12)


def test_body_without_stress_warns():
    amp = q_max(synthetic())
    assert amp.governs[0] == "cap" and any("no modal stress" in w for w in amp.warnings)


def test_ratios_are_invariant_to_the_scale_of_w(block_body, rng):
    q = rng.normal(size=block_body.nf) * 0.1
    qd = rng.normal(size=block_body.nf)
    w = rng.normal(size=3)
    a = [np.linalg.norm(t) for t in coriolis_terms(block_body, q, qd, w)]
    b = [np.linalg.norm(t) for t in coriolis_terms(block_body, q, qd, 7.5 * w)]
    assert a[0] / a[1] == pytest.approx(b[0] / b[1], rel=1e-12)
    c = [np.linalg.norm(t) for t in centrifugal_terms(block_body, q, w)]
    d = [np.linalg.norm(t) for t in centrifugal_terms(block_body, q, 7.5 * w)]
    assert c[0] / c[1] == pytest.approx(d[0] / d[1], rel=1e-12)


def test_dimensionless_outputs_are_unit_invariant(block_body):
    opts = Options(situation=Situation(w_op=500.0, f_sys=300.0))
    a, b = analyze(block_body, opts), analyze(block_body.converted(SI), opts)
    assert a.advice.level == b.advice.level and a.advice.terms == b.advice.terms
    for name in ("dI_L", "dI_Q", "dI_fT", "dI_Tf"):
        x, y = getattr(a.significance, name), getattr(b.significance, name)
        assert np.abs(x - y).max() <= 1e-12 * np.abs(x).max()
    assert a.significance.coriolis.value == pytest.approx(b.significance.coriolis.value, rel=1e-12)
    assert a.significance.centrifugal.value == pytest.approx(b.significance.centrifugal.value, rel=1e-12)
    for ra, rb in zip(a.advice.rules, b.advice.rules):
        assert ra.fired == rb.fired
        if ra.value is not None:
            assert ra.value == pytest.approx(rb.value, rel=1e-12)


def test_slender_beam_is_III_with_quadratic_inertia_about_its_long_axis():
    beam = read_body(SAMPLE, load_fe=True)  # 40 x 20 x 1000 mm: length/width 25
    result = analyze(beam, Options(situation=Situation()))
    sig = result.significance
    assert result.advice.level == "III" and "inertia_quad" in result.advice.terms
    assert np.unravel_index(np.argmax(sig.dI_Q), sig.dI_Q.shape)[0] == 2
    assert sig.dI_Q[2].max() > 10 * max(sig.dI_L.max(), sig.dI_Q[:2].max())


def test_softening_speeds_of_the_beam_are_its_bending_frequencies():
    """Theory section 9: about the long axis and the stiff transverse axis s_crit = first bending."""
    beam = read_body(SAMPLE)
    s = significance(beam, q_max(beam).q_max).s_crit
    omega = 2 * np.pi * beam.frequencies_hz
    assert s[0] == pytest.approx(omega[0], rel=1e-3) and s[2] == pytest.approx(omega[0], rel=5e-3)
    assert s[1] == pytest.approx(omega[1], rel=1e-3)


def test_compact_block_needs_only_the_widening_at_moderate_speed(block_body):
    """At 1000 rpm the block's centrifugal stress is above 5e-4 of sigma_allow, nothing else matters: level II,
    the W1 group (cf1 closed to a Lagrangian set)."""
    result = analyze(block_body, Options(situation=Situation(w_op=parse_speed("1000rpm"))))
    assert result.advice.level == "II" and result.advice.terms == ("gyro0", "cf1", "inertia_lin", "cor1")


# ---------------------------------------------------------------- issue 12: sign-independent, same modes
def _flipped(body, signs):
    """The body with mode p multiplied by signs[p]: integrals transform exactly (Ibar by s, Sbar by s s^T)."""
    from dataclasses import replace as dc_replace
    ints = body.integrals
    s = np.asarray(signs, float)
    return dc_replace(body, integrals=dc_replace(ints, Ibar=ints.Ibar * s, mode_sum=ints.mode_sum * s,
                                                 Sbar=ints.Sbar * np.outer(s, s)),
                      geometric=None if body.geometric is None else body.geometric * np.outer(s, s))


def _decisions(a):
    sig = a.significance
    return ([sig.max_first(n) for n in ("dI_L", "dI_Q", "dI_fT", "dI_Tf")],
            [sig.coriolis.value, sig.centrifugal.value, *(sig.s_crit)], a.advice.level, a.advice.terms,
            [r.value for r in a.advice.rules])


@pytest.mark.parametrize("name", ["beam", "genstruct1", "carbody"])
def test_flipping_the_signs_of_any_modes_changes_no_decision(name):
    from ffrf_advisor.io import read_body
    body = read_body(Path(__file__).resolve().parent.parent / "sample_bodies" / f"{name}.ffrf.h5")
    rng = np.random.default_rng(12)
    options = Options(situation=Situation(w_op=100.0))
    ref = _decisions(analyze(body, options))
    for _ in range(4):
        signs = rng.choice([-1.0, 1.0], size=body.nf)
        got = _decisions(analyze(_flipped(body, signs), options))
        for a, b in zip(ref[0] + [ref[1]], got[0] + [got[1]]):
            np.testing.assert_allclose(np.asarray(b, float), np.asarray(a, float), rtol=1e-9, atol=1e-300)
        assert got[2:4] == ref[2:4]
        np.testing.assert_allclose(np.array(got[4], dtype=float), np.array(ref[4], dtype=float), rtol=1e-9)


def test_cutting_modes_changes_a_ratio_only_through_the_modes_removed():
    """Both sides of every ratio use the first n_ratio modes: a body cut from 16 to 10 modes gives the same
    ratios as the full body with n_ratio = 10, and cutting below n_ratio changes them."""
    from ffrf_advisor.io import read_body
    body = read_body(Path(__file__).resolve().parent.parent / "sample_bodies" / "beam.ffrf.h5")
    full = analyze(body, Options(n_ratio=10)).significance
    cut = analyze(body.first_modes(10), Options(n_ratio=10)).significance
    for name in ("coriolis", "centrifugal", "coriolis_paper", "centrifugal_paper"):
        assert getattr(cut, name).value == pytest.approx(getattr(full, name).value, rel=1e-12), name
    assert analyze(body.first_modes(8)).significance.centrifugal.value != pytest.approx(full.centrifugal.value)
    np.testing.assert_allclose(cut.max_first("dI_Q"), full.max_first("dI_Q"), rtol=1e-12)


@pytest.mark.parametrize("name", ["beam", "plate", "conrod", "genstruct1", "genstruct2", "carbody"])
def test_levels_and_term_sets_never_shrink_as_the_speed_grows(name):
    from ffrf_advisor.significance import softening_speeds
    from ffrf_advisor.guidelines import LEVELS
    body = read_body(Path(__file__).resolve().parent.parent / "sample_bodies" / f"{name}.ffrf.h5")
    s_crit = softening_speeds(body).min()
    previous_level, previous_terms = 0, set()
    for s in np.linspace(0.0, 0.9 * s_crit, 12):
        adv = analyze(body, Options(situation=Situation(w_op=float(s)))).advice
        level, terms = LEVELS.index(adv.level), set(adv.terms)
        assert level >= previous_level and terms >= previous_terms, (s, adv.level, adv.terms)
        previous_level, previous_terms = level, terms


@pytest.mark.parametrize("rules", ["predicted", "paper"])
def test_a_speed_at_which_the_body_yields_is_named(rules):
    """Issue 25: above the speed where the exact static centrifugal stress (theory 11) about the worst principal
    axis reaches sigma_allow, a warning says the body yields; 1 % below it, none."""
    b = read_body(SAMPLE, load_fe=False)
    w_yield = np.sqrt(AmplitudeOptions.sigma_allow / b.static_centrifugal.sigma.max())  # rad/s (t-mm-N-s)

    def yielding(w):
        advice = analyze(b, Options(situation=guidelines.Situation(w_op=w, rules=rules))).advice
        return [x for x in advice.warnings if x.startswith("the body yields at this speed")]
    assert yielding(0.99 * w_yield) == [] and len(yielding(1.01 * w_yield)) == 1
    assert "is 102.01% of sigma_allow" in yielding(1.01 * w_yield)[0]  # (1.01)^2
    assert yielding(1.01 * w_yield)[0].endswith("sigma_allow = 500 N/mm^2")


def test_the_coriolis_parts_of_every_mode_pair_are_coriolis_terms_of_that_pair():
    """significance._coriolis_parts (all pairs at once from the invariants' blocks) against coriolis_terms of
    each pair's state (the definition of theory section 5), on a sample whose invariants are all non-zero: equal
    to round-off (1e-13 of the largest)."""
    from ffrf_advisor.significance import _coriolis_parts
    body = read_body(Path(__file__).resolve().parent.parent / "sample_bodies" / "genstruct1.ffrf.h5")
    rng = np.random.default_rng(3)
    q_max, w, n = rng.uniform(0.5, 2.0, body.nf) * 1e-3, rng.normal(size=3), 7
    B, D = _coriolis_parts(body, q_max, n, w)
    om = np.sqrt(body.eigenvalues)
    for p in range(n):
        for r in range(n):
            q, qd = np.eye(body.nf)[p] * q_max[p], np.eye(body.nf)[r] * om[r] * q_max[r]
            dep, lin = coriolis_terms(body, q, qd, w)
            assert np.abs(B[:, p, r] - dep).max() <= 1e-13 * np.abs(B).max()
            assert np.abs(D[:, r] - lin).max() <= 1e-13 * np.abs(D).max()
