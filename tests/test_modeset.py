"""Mode-set advice (theory 12, issue 26): load cases, static shares, residual vectors, the reduced body."""
from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
import scipy.linalg

from ffrf_advisor.adequacy import basis_errors
from ffrf_advisor.centrifugal import centrifugal_loads, static_deflections
from ffrf_advisor.analysis import Options, analyze
from ffrf_advisor.augment import with_residual_vectors
from ffrf_advisor.body import Provenance
from ffrf_advisor.checks import run_checks
from ffrf_advisor.cli import app
from ffrf_advisor.fe.assembly import full_mass, mass_matrix, stiffness_matrix
from ffrf_advisor.fe.material import STEEL
from ffrf_advisor.fe.mesh import box_mesh
from ffrf_advisor.fe.modal import mass_normalised, rigid_modes, without_rigid
from ffrf_advisor.fe.stress import modal_von_mises
from ffrf_advisor.fe_body import fe_body, with_centrifugal_response
from ffrf_advisor.guidelines import Situation
from ffrf_advisor.io import read_body
from ffrf_advisor.predict import MARGIN
from ffrf_advisor.zoo import zoo_body
from ffrf_advisor.modeset import (CASES, advise_modes, coefficients, euler_factors, inertia_loads,
                                  modal_loads_from_invariants, participation, reduced_body, response_factors,
                                  rising_load, scene_demands)

from .test_adequacy import DIR, beam, runner  # noqa: F401 - the beam with its FE data, a module fixture


@pytest.fixture(scope="module")
def advised(beam):
    a = analyze(beam, Options(situation=Situation(w_op=300.0)))
    loads = inertia_loads(beam)
    return a, loads, advise_modes(a, loads=loads)


def test_the_invariants_give_the_nodal_modal_loads(beam):
    """phi_k^T f_j by nodal sums on the mesh equals the polarised cf1 force of the invariants (both exact sums
    of the same mass matrix: round-off, 1e-12 of the largest)."""
    P = inertia_loads(beam).P
    assert np.abs(modal_loads_from_invariants(beam) - P).max() <= 1e-12 * np.abs(P).max()
    w = np.array([0.3, -1.1, 0.7])
    F = centrifugal_loads(beam.fe.mesh.points, beam.fe.Ms)
    assert np.allclose(F @ coefficients(w), centrifugal_loads(beam.fe.mesh.points, beam.fe.Ms) @ coefficients(w))


@pytest.fixture(scope="module")
def every_mode():
    """A small free box (hexahedron, 36 nodes) with all 102 flexible modes from a dense eigensolution."""
    mesh = box_mesh([40.0, 20.0, 200.0], [2, 1, 5], "hexahedron")
    Ms, K = mass_matrix(mesh, STEEL.rho), stiffness_matrix(mesh, STEEL)
    M = full_mass(Ms)
    lam, S = scipy.linalg.eigh(K.toarray(), M.toarray())
    S = without_rigid(S[:, 6:], rigid_modes(mesh.points), M)
    Phi = mass_normalised(S, M, mesh.points).reshape(mesh.n_nodes, 3, -1)
    return fe_body("box", mesh, Ms, Phi, lam[6:], Provenance(), K, None, STEEL)


def test_the_shares_of_all_modes_sum_to_one_and_the_error_is_the_projection_error(every_mode):
    """sum_k p_k(f) = 1 over all flexible modes (eigensolver round-off: 1e-9), and e_S(f) of a kept set equals
    |u - u_S|_K / |u|_K computed from the deflection and the modes."""
    b = every_mode
    loads = inertia_loads(b)
    p = participation(loads, b.eigenvalues)
    assert p.sum(axis=0) == pytest.approx(np.ones(6), abs=1e-9)
    kept = np.arange(10)
    n = b.fe.mesh.n_nodes
    Phi = b.fe.Phi.reshape(3 * n, -1)[:, kept]
    K = b.fe.K
    for j in range(6):
        u = loads.U[:, j]
        rest = u - Phi @ (loads.P[kept, j] / b.eigenvalues[kept])
        direct = np.sqrt(rest @ (K @ rest) / (u @ (K @ u)))
        assert np.sqrt(max(0.0, 1 - p[kept, j].sum())) == pytest.approx(direct, rel=1e-6, abs=1e-7)
    first_k = np.sqrt(np.clip(1 - np.cumsum(p, axis=0), 0, None))  # e of the first k modes, k = 1 .. all
    assert np.all(np.diff(first_k, axis=0) <= 1e-12) and np.all(first_k[-1] <= 1e-4)  # sqrt of 1e-9 round-off


def test_residual_vectors_remove_the_static_error_and_the_step_ratio_is_the_reduced_bodys(beam, advised):
    """The written body carries the advised cases' static deflections (energy error at round-off: the square
    root of 1e-12) and its top frequency is the one the Ritz values predicted (1e-5: the prediction takes
    phi^T M u = phi^T f / lambda, exact for eigenvectors; the file's modes have relative eigen-residuals up to
    4e-7)."""
    a, loads, adv = advised
    assert adv.residual_cases and set(adv.kept) < set(range(beam.nf))
    r = reduced_body(beam, adv, loads)
    assert r.nf == adv.size  # no residual vector the basis transform drops as dependent
    errors = basis_errors(r)
    for j in range(3):  # a case left out as dependent on the others (the slender beam's w1w1 and w2w2) is met
        assert errors[j] <= (1e-5 if j in adv.residual_cases else adv.tolerance)
    # its minor-axis error was first predicted within the margin of the tolerance: the other cases joined
    assert any("within a factor" in n for n in adv.notes) and max(p[1] for p in adv.predicted) <= adv.tolerance / MARGIN
    assert np.sqrt(beam.eigenvalues.max() / r.eigenvalues.max()) == pytest.approx(adv.step_ratio, rel=1e-5)
    assert "kept modes" in r.provenance.notes[-1] and "residual vectors" in r.provenance.notes[-1]
    kept = beam.eigenvalues[list(adv.kept)]  # unchanged by the residual vectors (the eigensolver's 1e-7)
    assert np.abs(r.eigenvalues[:, None] / kept[None, :] - 1).min(axis=0).max() <= 1e-6
    assert all(c.passed for c in run_checks(r))
    nodal = r.fe.integrals()  # the stored invariants are the nodal sums over the new basis (round-off)
    scale = {"Ibar": np.abs(nodal.Ibar).max(), "Sbar": np.abs(nodal.Sbar).max(),
             "mode_sum": np.sqrt(r.mass)}  # sum_i m_i phi_i: at most sqrt(mass) for unit modal mass, ~0 at the CoM
    for name, size in scale.items():
        assert np.abs(getattr(r.integrals, name) - getattr(nodal, name)).max() <= 1e-12 * size, name


def test_a_beam_spun_across_needs_the_axial_residual_vector_and_about_its_length_none(advised):
    """Spin about a transverse axis stretches the beam at tens of N/mm^2: the kept modes miss some of it, so
    its case gets a residual vector; about the long axis the kept modes miss the widening almost entirely,
    but it is 0.1 N/mm^2 at 300 rad/s, below a tenth of sigma_allow: it counts for little, no residual
    vector (theory 10's floor). Mode 1, the first bending mode, is in every scene's band."""
    a, loads, adv = advised
    long_axis = int(np.argmin(np.diag(a.body.I0)))
    by_case = {c.case: c for c in adv.cases}
    along = by_case[f"w{long_axis + 1}w{long_axis + 1}"]
    across = [c for name, c in by_case.items() if name[1] == name[3] and name[1] != str(long_axis + 1)]
    assert along.energy > 0.5 and along.weight < 0.01 and not along.residual
    assert across and all(c.residual and c.weight == 1.0 for c in across) and 0 in adv.kept


def test_modes_in_band_are_kept_and_a_high_f_max_keeps_every_mode(advised):
    a, loads, adv = advised
    for m in adv.modes:
        inside = any(m.f_hz <= adv.band * s.f_exc for s in adv.scenes)
        assert m.keep == (inside or m.participation > adv.tolerance or m.rule in ("spun", "partner"))
        assert m.decision == (f"keep ({m.rule})" if m.keep else "drop") and bool(m.rule) == m.keep
        assert (m.rule != "band" or inside) and (m.rule != "share" or m.participation > adv.tolerance)
    wide = advise_modes(a, f_max=1e6, loads=loads)
    assert wide.kept == tuple(range(a.body.nf)) and all(m.reason.startswith("keep: in band") for m in wide.modes)
    assert {m.decision for m in wide.modes} == {"keep (band)"}


def test_a_degenerate_pair_is_kept_whole():
    """A ring spun to 1000 rad/s: the spin keeps one mode of an n-pair (its error without it) whose partner of the
    same frequency carries none of the loads in the eigensolver's basis (a share of 1e-21): which of the two a
    load meets is that basis' choice, so the partner joins (``keep (partner)``, dropped before)."""
    a = analyze(zoo_body("ring", 1000), Options(situation=Situation(w_op=1000.0)))
    adv = advise_modes(a)
    f = a.body.frequencies_hz
    for k in adv.kept:
        assert all(j in adv.kept for j in np.flatnonzero(np.abs(f - f[k]) <= 1e-6 * f[k])), (k, adv.kept)
    partners = [m for m in adv.modes if m.rule == "partner"]
    assert partners and all(m.participation < 1e-15 and "same frequency as mode" in m.reason for m in partners)


def _turned_pairs(body, seed: int = 0):
    """``body`` (with FE data) rebuilt from its modes with each pair of one frequency turned by a random angle
    within its plane, as another eigensolver may return them: stresses, invariants and the static response anew."""
    f, Q = body.frequencies_hz, np.eye(body.nf)
    rng = np.random.default_rng(seed)
    for i in np.flatnonzero(np.diff(f) <= 1e-6 * f[:-1]):
        t = rng.uniform(0.2, 1.3)
        Q[np.ix_([i, i + 1], [i, i + 1])] = [[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]]
    fe = body.fe
    Phi = np.einsum("nkp,pq->nkq", fe.Phi, Q)
    return with_centrifugal_response(fe_body(body.name, fe.mesh, fe.Ms, Phi, body.eigenvalues, body.provenance, fe.K,
                                             modal_von_mises(fe.mesh, fe.material, Phi), fe.material))


@pytest.mark.slow  # 2-3 s: a zoo ring built, rebuilt and advised twice
def test_the_advice_does_not_depend_on_the_eigensolvers_basis_within_a_pair():
    """zoo:ring:1000 (six pairs of one frequency) and the same ring with each pair turned within its plane, at
    1000 rad/s: the same level, terms, kept modes and residual vectors, and the same predicted frequency errors
    (a spectrum has no basis). Before the partner rule the turned ring kept one mode of two pairs each. The
    static and rigid predictions bound per mode (sigma_max, q_max per mode) and move by some 10 % with the turn."""
    ring = zoo_body("ring", 1000)
    advice = []
    for body in (ring, _turned_pairs(ring)):
        a = analyze(body, Options(situation=Situation(w_op=1000.0)))
        m = advise_modes(a, loads=inertia_loads(body))
        # The residual vectors by what they carry, not by their case's index: the ring's principal axes 1 and 2
        # are equivalent, so w1w1 or w2w2 (equal errors) is a tie that round-off breaks (BLAS threads, the turn).
        carried = sorted(round(c.energy, 6) for c in m.cases if c.residual)
        advice.append((a.advice.level, a.advice.terms, m.kept, carried,
                       [c.errors["frequency"] for c in a.advice.candidates]))
    (*first, f_a), (*second, f_b) = advice
    assert first == second
    assert np.allclose(f_a, f_b, rtol=1e-6, atol=0)


def test_response_factors_equal_an_integrated_oscillator():
    """A mode's largest dynamic excess |x - g| under a spin rising over 1 s, against scipy's DOP853 at rtol
    1e-11 on a 20,000-point grid (1e-5: the load is linear between 2000 points, about 1e-6); a step (no rise)
    rings at the static amplitude."""
    from scipy.integrate import solve_ivp
    from ffrf_advisor.sim.loads import spin_profile
    f = np.array([1.0, 2.0, 5.0])
    total, excess = response_factors(f, 1.0)
    for fk, e, tot in zip(f, excess, total):
        om, g = 2 * np.pi * fk, lambda t: spin_profile(1.0, 1.0)(t)[0] ** 2  # noqa: E731
        sol = solve_ivp(lambda t, y: [y[1], om**2 * (g(t) - y[0])], [0, 1 + 5 / fk], [0, 0], method="DOP853",
                        rtol=1e-11, atol=1e-13, dense_output=True)
        t = np.linspace(0, 1 + 5 / fk, 20001)
        x = sol.sol(t)[0]
        assert e == pytest.approx(np.abs(x - [g(u) for u in t]).max(), rel=1e-5, abs=1e-9)
        assert np.abs(x).max() == pytest.approx(tot, rel=1e-4)  # sampled at 2000 points: (om dt)^2 / 8 < 4e-5
    assert response_factors([3.0], 0.0) == (pytest.approx([2.0]), pytest.approx([1.0]))


def test_the_euler_cases_load_no_free_mode(beam):
    """The Euler load -M (e_j x x) of a unit angular acceleration, summed over the nodes, projects on the
    beam's free modes to round-off of the centrifugal cases' projections (theory 12), as the invariants
    (mean-axis residual) say: nodal sums against euler_loads."""
    from ffrf_advisor.modeset import euler_loads
    fe = beam.fe
    X, n = fe.mesh.points, fe.mesh.n_nodes
    M = full_mass(fe.Ms)
    nodal = np.column_stack([fe.Phi.reshape(3 * n, beam.nf).T @ -(M @ np.cross(e, X).ravel()) for e in np.eye(3)])
    scale = np.abs(inertia_loads(beam).P).max()
    assert np.abs(nodal).max() <= 1e-12 * scale and np.abs(euler_loads(beam)).max() <= 1e-12 * scale
    assert np.allclose(nodal, euler_loads(beam), rtol=0, atol=1e-13 * scale)
    # the sign and the sum where the shapes are not free modes (random fields): the same nodal sums
    rng = np.random.default_rng(3)
    shapes = replace(fe, Phi=rng.standard_normal((n, 3, 2)), K=None, stress_nodal=None, rotary=None)
    fake = replace(beam, fe=shapes, integrals=shapes.integrals(), eigenvalues=np.ones(2), sigma_max=None,
                   static_centrifugal=None, geometric=None)
    nodal = np.column_stack([shapes.Phi.reshape(3 * n, 2).T @ -(M @ np.cross(e, X).ravel()) for e in np.eye(3)])
    assert np.allclose(euler_loads(fake), nodal, rtol=1e-12, atol=1e-12 * np.abs(nodal).max())


def test_euler_factors_equal_an_integrated_oscillator():
    """A mode's largest response to the load shape of a rising spin on its own deflection, h = a (w / W)^2
    normalised (a = w' / W), against scipy's DOP853 at rtol 1e-11 (1e-5: h linear between 2000 points); h ends
    at 0, so the response after the rise is a free oscillation."""
    from scipy.integrate import solve_ivp
    from ffrf_advisor.sim.loads import spin_profile
    f, T = np.array([0.3, 1.0, 2.0, 5.0]), 1.0
    D, A = euler_factors(f, T)
    h = lambda t: (lambda w, a: a * w**2)(*spin_profile(1.0, T)(t)) / A  # noqa: E731
    grid = np.linspace(0, T, 20001)
    assert max(h(t) for t in grid) == pytest.approx(1.0, rel=1e-6)  # A is the largest a w^2
    for fk, d in zip(f, D):
        om = 2 * np.pi * fk
        end = T + 5 / fk
        sol = solve_ivp(lambda t, y: [y[1], om**2 * (h(t) - y[0])], [0, end], [0, 0], method="DOP853", rtol=1e-11,
                        atol=1e-13, dense_output=True)
        assert d == pytest.approx(np.abs(sol.sol(np.linspace(0, end, 40001))[0]).max(), rel=1e-4)
    assert euler_factors(f, 0.0)[1] == 0.0


def test_the_rising_load_is_the_simulators_euler_and_coriolis_force(beam):
    """While a prescribed spin W e rises, the flexible equations' Euler (-C(q)^T w') and Coriolis
    (-2 C(q')^T w) forces on the deflection q_s (w / W)^2 (q' following it) equal rising_load times
    (w / W)^2 |w'| (sim.equations.rhs against the closed form; round-off)."""
    from ffrf_advisor.sim.equations import rhs
    from ffrf_advisor.sim.linearise import static_deflection
    from ffrf_advisor.sim.model import N_ROT, build_model
    from ffrf_advisor.terms import FULL
    m = build_model(beam, FULL)
    e, W = np.array([0.0, 0.6, 0.8]), 300.0
    qs = static_deflection(m, W * e)
    for u, a in ((0.3, 2e4), (0.8, 5e3)):  # w / W and w' [rad/s^2] at two instants of a rise
        y = np.zeros(N_ROT + 2 * m.nf)
        y[0], y[N_ROT:N_ROT + m.nf], y[N_ROT + m.nf:] = 1.0, qs * u**2, qs * 2 * u * a / W
        still = y.copy()
        still[N_ROT + m.nf:] = 0.0
        moving = rhs(m, 0.0, y, prescribed=(u * W * e, a * e))[N_ROT + m.nf:]
        held = rhs(m, 0.0, still, prescribed=(u * W * e, 0 * e))[N_ROT + m.nf:]
        expected = u**2 * a * rising_load(m, qs, e)
        assert np.allclose(moving - held, expected, rtol=0, atol=1e-10 * np.abs(expected).max())
        assert np.abs(expected).max() > 0


def test_the_minor_axis_wobble_loads_both_cross_cases(beam):
    """The minor-axis scene's 1 % wobble turns about its spin axis: both cross cases of that axis apply."""
    a = analyze(beam, Options(situation=Situation(w_op=300.0)))
    scene = next(s for s in scene_demands(a, ("minor-axis",), 0.01))
    k = int(np.argmax(np.abs(scene.directions[0])))
    cross = {CASES.index(f"w{min(k, j) + 1}w{max(k, j) + 1}") for j in range(3) if j != k}
    assert cross <= set(scene.cases)


def test_without_nodal_data_the_principal_cases_come_from_the_cache(beam):
    """An invariants-only read: projections from W1, compliances of 11, 22, 33 from the file's cache; the
    cross cases cannot be bounded."""
    cached = read_body(DIR / "beam.ffrf.h5", load_fe="summary")
    loads, exact = inertia_loads(cached), inertia_loads(beam)
    assert loads.U is None and loads.bounded.tolist() == [True] * 3 + [False] * 3
    assert loads.compliance[:3] == pytest.approx(exact.compliance[:3], rel=1e-12)


def test_modes_command_writes_the_advised_body_and_its_json(tmp_path):
    target = tmp_path / "reduced.ffrf.h5"
    result = runner.invoke(app, ["modes", str(DIR / "beam.ffrf.h5"), "--speed", "300rad/s", "-o", str(target),
                                 "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    body = read_body(target, load_fe=True)
    assert body.nf == data["size"] == len(data["kept"]) + len(data["residual_cases"])
    assert set(data["residual_cases"]) <= set(CASES)
    again = runner.invoke(app, ["modes", str(DIR / "beam.ffrf.h5"), "--speed", "300rad/s", "-o", str(target)])
    assert again.exit_code == 2 and "exists" in again.output
    bad = runner.invoke(app, ["modes", str(DIR / "beam.ffrf.h5"), "--scene", "wobble"])
    assert bad.exit_code == 2 and "--scene 'wobble'" in bad.output and "Traceback" not in bad.output
    lone = runner.invoke(app, ["modes", str(DIR / "beam.ffrf.h5"), "--figures", str(tmp_path)])
    assert lone.exit_code == 2 and "--figures: expected --verify" in lone.output


@pytest.mark.slow
def test_the_advised_set_carries_a_spin_up_as_the_reference_does(beam, advised):
    """Proof by simulation (theory 12): the prescribed spin-up about each stable axis, run with the advised
    term set on the reference (all modes and the residual vectors of all six cases), the advised body and the
    kept modes alone, compared in what both bases express: nodal deflections. The advised body's peak
    deflection stays within the tolerance (relative to at least the proof's floor); the kept modes alone err
    in energy norm by the predicted error before its weight (within a factor 1.5: the prediction is
    quasi-static; the reference at rtol 1e-10)."""
    from ffrf_advisor.modeset_proof import floors
    from ffrf_advisor.sim.model import build_model
    from ffrf_advisor.verify.runner import run_scene
    from ffrf_advisor.verify.scenes import make_scenes
    a, loads, adv = advised
    K = stiffness_matrix(beam.fe.mesh, beam.fe.material)
    reference = with_residual_vectors(beam, loads.U, "all six cases")
    bodies = {"reference": reference, "advised": reduced_body(beam, adv, loads),
              "bare": beam.with_modes(list(adv.kept))}
    for scene in make_scenes(("spin-up",), a):
        u = {}
        for name, body in bodies.items():
            zero = np.zeros(body.nf)
            run = run_scene(build_model(body, adv.terms), replace(scene, q0=zero, qd0=zero), rtol=1e-10)
            u[name] = np.einsum("iap,tp->tia", body.fe.Phi, run.y[:, 7:7 + body.nf]).reshape(len(run.t), -1)
        energy = lambda v: np.sqrt(np.einsum("ti,ti->t", v, (K @ v.T).T)).max()  # noqa: E731
        peak = {name: np.sqrt((v.reshape(len(v), -1, 3) ** 2).sum(axis=2)).max() for name, v in u.items()}
        i = [s.label for s in adv.scenes].index(scene.label)
        raw = adv.predicted[i][0] / adv.scenes[i].weights[0]
        assert abs(peak["advised"] - peak["reference"]) <= adv.tolerance * max(peak["reference"], floors(a)[0])
        bare = energy(u["bare"] - u["reference"]) / energy(u["reference"])
        assert raw / 1.5 <= bare <= 1.5 * raw, (scene.label, bare, raw)


def test_analyze_names_the_mode_set_that_modes_advises_from_the_cache_alone():
    """analyze reads only the invariants cache; its mode-set line and JSON keep the modes that `modes` keeps
    from the FE data for the same scenes (the shares agree to round-off, the principal compliances are cached)."""
    beam_file = str(DIR / "beam.ffrf.h5")
    analyzed = json.loads(runner.invoke(app, ["analyze", beam_file, "--speed", "300rad/s", "--json"]).stdout)
    full = json.loads(runner.invoke(app, ["modes", beam_file, "--speed", "300rad/s", "--scene", "spin-up",
                                          "--scene", "torque-pulse", "--json"]).stdout)
    assert analyzed["mode_set"]["kept"] == full["kept"] and analyzed["mode_set"]["modes_total"] == 16
    text = runner.invoke(app, ["analyze", beam_file, "--speed", "300rad/s"], env={"COLUMNS": "200"}).stdout
    assert f"mode set: {len(full['kept'])} of 16 modes" in text


@pytest.mark.slow
def test_modes_verify_proves_the_advised_set_and_draws_the_mode_sets(tmp_path):
    """`modes --verify`: the advised basis within the tolerance of the reference in every scene (its errors
    from the simulation, not the prediction), the kept modes without their residual vectors, the first k modes
    and all 16 modes outside it (the beam's transverse spin needs the widening vector), JSON by its schema, the
    chart written."""
    import jsonschema
    from ffrf_advisor.schemas import schema
    result = runner.invoke(app, ["modes", str(DIR / "beam.ffrf.h5"), "--speed", "300rad/s", "--scene", "spin-up",
                                 "--verify", "--figures", str(tmp_path), "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    jsonschema.validate(data, schema("modes"))
    proof = data["verification"]
    worst = {b["basis"]: b["worst_error"] for b in proof["bases"]}
    assert proof["verdict"] == "verified" and worst["advised"] <= data["tolerance"]
    assert worst["advised modes only"] > data["tolerance"] and worst["all modes"] > data["tolerance"] and all(
        v > data["tolerance"] for k, v in worst.items() if k.startswith("first"))
    assert (tmp_path / "mode_sets_work_precision.png").stat().st_size > 10_000


@pytest.mark.slow
@pytest.mark.parametrize("name", ["beam", "conrod"])
def test_the_proof_verifies_the_advised_body_and_finds_a_dropped_mode_unsafe(name):
    """On two samples the advised basis meets the tolerance against the all-mode reference in the spin-up
    and torque-pulse; without the kept mode that carries the most of an applied load case it does not (the
    beam's in-band bending modes carry none of these loads: a symmetric body spun about a principal axis)."""
    from ffrf_advisor.modeset_proof import RTOLS, prove
    body = read_body(DIR / f"{name}.ffrf.h5", load_fe=True)
    a = analyze(body, Options(situation=Situation(w_op=300.0)))
    loads = inertia_loads(body)
    scenes = ("spin-up", "torque-pulse")
    adv = advise_modes(a, scenes, loads=loads)
    tight = (RTOLS[-1],)  # the judging tolerance alone (the chart's others are not needed here)
    assert prove(a, adv, loads, scenes, rtols=tight).verdict == "verified"
    carrier = max(adv.kept, key=lambda k: adv.modes[k].participation)
    fewer = replace(adv, kept=tuple(k for k in adv.kept if k != carrier), residual_cases=())
    assert prove(a, fewer, loads, scenes, rtols=tight).verdict == "unsafe"


def test_an_invariants_file_gets_the_frequency_band_only_and_says_so(tmp_path):
    """Without nodal data or a cached static response the shares cannot be bounded: modes are kept by band
    alone, no residual vector, and the summary says the error is not bounded."""
    inv = tmp_path / "beam.ffinv.json"
    assert runner.invoke(app, ["convert", str(DIR / "beam.ffrf.h5"), str(inv)]).exit_code == 0
    data = json.loads(runner.invoke(app, ["modes", str(inv), "--speed", "300rad/s", "--json"]).stdout)
    assert "frequency band decides alone" in data["loads_source"] and not data["residual_cases"]
    assert all(m["reason"].startswith(("keep: in band", "drop: out of band, share unknown")) for m in data["modes"])
    assert "error not bounded" in data["summary"]
