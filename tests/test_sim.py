"""The reduced-order simulator (issue 10): exact against nodal sums, conserving, compiled = numpy, RK4 limit, CLI."""
from __future__ import annotations

import csv
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from typer.testing import CliRunner

from ffrf_advisor.cli import app
from ffrf_advisor.schemas import schema
from ffrf_advisor.io import read_body
from ffrf_advisor.sim import equations as eq
from ffrf_advisor.sim.integrate import Loads, Rhs, integrate
from ffrf_advisor.sim.model import build_model, initial_state
from ffrf_advisor.sim.output import columns, summary
from ffrf_advisor.units import TMM
from ffrf_advisor.terms import FULL, GROUPS, IDS, LEVEL_SETS, is_lagrangian, lagrangian_superset

DIR = Path(__file__).resolve().parent.parent / "sample_bodies"


@pytest.fixture(scope="module")
def bodies():
    return {n: read_body(DIR / f"{n}.ffrf.h5", load_fe=True) for n in ("beam", "genstruct1")}


def _state(rng, body, scale=1.0):
    """A random state: modes of the size of their q_max, angular velocity of a few hundred rad/s."""
    nf = body.nf
    q = scale * 0.05 * rng.normal(size=nf) / (1 + np.arange(nf))
    qd = np.sqrt(body.eigenvalues) * scale * 0.05 * rng.normal(size=nf) / (1 + np.arange(nf))
    return q, qd, 200 * rng.normal(size=3)


# ---------------------------------------------------------------- nodal sums (N eq 82)
class Nodal:
    """Every term of theory section 5 as a nodal sum with the FE mass matrix (independent of the invariants)."""

    def __init__(self, body, q, qd, w):
        fe = body.fe
        self.X, self.Ms, self.Phi, self.w = fe.mesh.points, fe.Ms, fe.Phi, w
        self.u, self.v = fe.Phi @ q, fe.Phi @ qd
        self.lam, self.q = body.eigenvalues, q

    def dot(self, a, b):        # sum m a . b
        return float(np.sum(a * (self.Ms @ b)))

    def outer(self, a, b):      # sum m a b^T
        return a.T @ (self.Ms @ b)

    def cross(self, a, b):      # sum m a x b
        return np.sum(np.cross(a, self.Ms @ b), axis=0)

    def proj(self, f):          # sum m Phi^T f
        return np.einsum("ikp,ik->p", self.Phi, self.Ms @ f)

    def inertia(self, a, b=None):
        """sum m (a . b I - (a b^T + b a^T) / 2), the inertia form of two fields."""
        b = a if b is None else b
        return self.dot(a, b) * np.eye(3) - 0.5 * (self.outer(a, b) + self.outer(b, a))

    def spin2(self, a):         # w x (w x a) per node
        return np.cross(self.w, np.cross(self.w, a))

    def coupling(self, a):      # sum m a~ Phi (3 x nf)
        return np.stack([self.cross(a, self.Phi[:, :, r]) for r in range(self.Phi.shape[2])], axis=1)

    def term(self, name):
        """(mass contribution, rotational force, flexible force) of one term."""
        X, u, v, w = self.X, self.u, self.v, self.w
        zero3, zf = np.zeros((3, 3)), np.zeros(self.Phi.shape[2])
        if name == "gyro0":
            return self.inertia(X), -np.cross(w, self.inertia(X) @ w), zf
        if name == "inertia_lin":
            J = 2 * self.inertia(X, u)
            return J, -np.cross(w, J @ w), zf
        if name == "cor1":
            return zero3, -2 * self.inertia(X, v) @ w, zf
        if name == "inertia_quad":
            return self.inertia(u), -np.cross(w, self.inertia(u) @ w), zf
        if name == "cor_quad":
            return zero3, -2 * self.inertia(u, v) @ w, zf
        if name == "cor_coupling":
            return zero3, -np.cross(w, self.cross(u, v)), -2 * self.proj(np.cross(w, v))
        if name == "cf1":
            return zero3, np.zeros(3), -self.proj(self.spin2(X))
        if name == "cf2":
            return zero3, np.zeros(3), -self.proj(self.spin2(u))
        raise KeyError(name)

    def accelerations(self):
        """(w', q'') of the full model from N eq 82: mass matrix and quadratic velocity vector by nodal sums."""
        r, v, w = self.X + self.u, self.v, self.w
        acc = self.spin2(r) + 2 * np.cross(w, v)
        C = self.coupling(r)
        Mff = np.einsum("ikp,ikq->pq", self.Phi, (self.Ms @ self.Phi.reshape(len(r), -1)).reshape(self.Phi.shape))
        M = np.block([[self.inertia(r), C], [C.T, Mff]])
        rhs = np.concatenate([-self.cross(r, acc), -self.proj(acc) - self.lam * self.q])
        x = np.linalg.solve(M, rhs)
        return x[:3], x[3:]


def _contribution(body, name, q, qd, w):
    """(mass, rotational, flexible) contribution of a term from the invariants: set with it minus without."""
    base = build_model(body, ("gyro0",))
    with_term = build_model(body, ("gyro0", name))
    zf = np.zeros(body.nf)
    dm = eq.inertia(with_term, q) - (0 if name == "gyro0" else eq.inertia(base, q))
    fr = eq.rotational_force(with_term, q, qd, w, np.zeros(3)) - (0 if name == "gyro0" else
                                                                  eq.rotational_force(base, q, qd, w, np.zeros(3)))
    ff = eq.flexible_force(with_term, q, qd, w, zf) - eq.flexible_force(base, q, qd, w, zf)
    return dm, fr, ff


def _close(a, b, scale, rtol=1e-10):
    assert np.abs(np.asarray(a) - np.asarray(b)).max() <= rtol * scale


@pytest.mark.parametrize("name", ["beam", "genstruct1"])
@pytest.mark.parametrize("term", [t for t in IDS if t not in ("coupling", "geo_stiff")])
def test_each_term_equals_its_nodal_sum(bodies, rng, name, term):
    """Tolerance 1e-10: the invariants are the same nodal sums, regrouped (round-off 1e-13 at n = 1e4 nodes),
    plus the free-surface residuals of the shipped bodies (below 1e-12)."""
    body = bodies[name]
    for _ in range(3):
        q, qd, w = _state(rng, body)
        nodal = Nodal(body, q, qd, w).term(term)
        ours = _contribution(body, term, q, qd, w)
        scales = (np.abs(body.I0).max(), np.abs(Nodal(body, q, qd, w).term("gyro0")[1]).max() + 1e-30,
                  np.abs(Nodal(body, q, qd, w).term("cf1")[2]).max())
        for a, b, s in zip(ours, nodal, scales):
            _close(a, b, max(s, np.abs(b).max()))


@pytest.mark.parametrize("name", ["beam", "genstruct1"])
def test_coupling_matrix_and_full_right_hand_side_equal_nodal_sums(bodies, rng, name):
    body = bodies[name]
    full = build_model(body, FULL)
    for _ in range(3):
        q, qd, w = _state(rng, body)
        nodal = Nodal(body, q, qd, w)
        C = nodal.coupling(nodal.u)
        _close(eq.coupling_matrix(full, q), C, np.abs(C).max())
        wd, qdd = eq.accelerations(full, q, qd, w, np.zeros(3), np.zeros(body.nf))
        wd_n, qdd_n = nodal.accelerations()
        _close(wd, wd_n, np.abs(wd_n).max())
        _close(qdd, qdd_n, np.abs(qdd_n).max())


def test_the_nodal_reference_sees_a_dropped_term(bodies, rng):
    """A test of the test: without cor_coupling the full right-hand side differs from the nodal one."""
    body = bodies["genstruct1"]
    q, qd, w = _state(rng, body)
    partial = build_model(body, [t for t in FULL if t != "cor_coupling"])
    wd, _ = eq.accelerations(partial, q, qd, w, np.zeros(3), np.zeros(body.nf))
    wd_n, _ = Nodal(body, q, qd, w).accelerations()
    assert np.abs(wd - wd_n).max() > 1e-6 * np.abs(wd_n).max()


# ---------------------------------------------------------------- compiled = numpy
def test_compiled_and_numpy_right_hand_sides_agree(bodies, rng):
    """1e-13: the same operations in another order (summation order differs), on random term sets."""
    body = bodies["genstruct1"]
    nf = body.nf
    A = rng.normal(size=(6, nf, nf))
    G = A + A.transpose(0, 2, 1)
    sets = [FULL, ("gyro0",), (*FULL, "geo_stiff")] + [
        tuple(t for t in IDS if rng.random() < 0.5) for _ in range(20)]
    for terms in sets:
        model = build_model(body, terms, damping=rng.uniform(0, 0.05, nf), G=G)
        for prescribed in (None, (rng.normal(size=3) * 50, rng.normal(size=3) * 500)):
            q, qd, w = _state(rng, body)
            y = initial_state(model, w, q, qd)
            y[:4] = rng.normal(size=4)
            y[:4] /= np.linalg.norm(y[:4])
            tau, fext = rng.normal(size=3), rng.normal(size=nf)
            loads = Loads(torque=lambda t: tau, modal=lambda t: fext,
                          prescribed=None if prescribed is None else (lambda t: prescribed))
            ref = eq.rhs(model, 0.0, y, tau, fext, prescribed)
            got = Rhs(model, loads)(0.0, y)
            assert np.abs(got - ref).max() <= 1e-13 * np.abs(ref).max(), terms


def test_states_side_by_side_give_what_each_state_gives_alone(bodies, rng):
    """The linearisation evaluates all its difference columns as one batch: per state to round-off (1e-13)."""
    body = bodies["genstruct1"]
    nf = body.nf
    A = rng.normal(size=(6, nf, nf))
    for terms in (FULL, (*FULL, "geo_stiff"), tuple(t for t in IDS if rng.random() < 0.5)):
        model = build_model(body, terms, damping=rng.uniform(0, 0.05, nf), G=A + A.transpose(0, 2, 1))
        states = [_state(rng, body) for _ in range(4)]
        tau, fext = rng.normal(size=(4, 3)), rng.normal(size=(4, nf))
        q, qd, w = (np.array(v) for v in zip(*states))
        wd, qdd = eq.accelerations(model, q, qd, w, tau, fext)
        for k in range(4):
            wd1, qdd1 = eq.accelerations(model, q[k], qd[k], w[k], tau[k], fext[k])
            assert np.abs(wd[k] - wd1).max() <= 1e-13 * np.abs(wd1).max(), terms
            assert np.abs(qdd[k] - qdd1).max() <= 1e-13 * np.abs(qdd1).max(), terms


# ---------------------------------------------------------------- conservation
def _drifts(model, run):
    s = summary(model, run, "t-mm-N-s")
    assert not run.failed, run.reason
    return s["energy_drift"], s["H_drift"]


@pytest.fixture(scope="module")
def spinning(bodies):
    """genstruct1 spinning mostly about its soft axis 1, first modes deflected: W1, W2, W3 all at work."""
    body = bodies["genstruct1"]
    q0 = np.zeros(body.nf)
    q0[:4] = [0.3, -0.2, 0.1, 0.05]
    qd0 = np.zeros(body.nf)
    qd0[:2] = [20.0, -30.0]
    return body, (30.0, 4.0, -3.0), q0, qd0


def _lagrangian_sets():
    out = []
    for mask in range(8):
        groups = [g for i, g in enumerate(("W1", "W2", "W3")) if mask >> i & 1]
        out.append(tuple(["gyro0", *[t for g in groups for t in GROUPS[g]]]))
    return out


RK4_STEP = 2e-5  # h Omega_16 = 0.15 for genstruct1: RK4 energy error per period ~ (h Omega)^4 / 120


def test_lagrangian_sets_conserve_energy_and_momentum_and_others_drift(spinning):
    """Over 1 s (9 periods of mode 1, 5 turns): the Lagrangian sets keep energy and |H| to 1e-8 (RK4
    truncation at the step above; 2e-10 seen); level II and inertia terms without their Coriolis
    counterparts drift by 1e-5 or more (8e-2 and more seen)."""
    body, w0, q0, qd0 = spinning
    for terms in _lagrangian_sets():
        assert is_lagrangian(terms)
        model = build_model(body, terms)
        run = integrate(model, initial_state(model, w0, q0, qd0), 1.0, "rk4-lie", RK4_STEP)
        dE, dH = _drifts(model, run)
        assert dE < 1e-8 and dH < 1e-8, (terms, dE, dH)
    for terms in (LEVEL_SETS["II"], ("gyro0", "inertia_lin"), ("gyro0", "cf1", "inertia_lin", "inertia_quad", "cf2")):
        assert not is_lagrangian(terms)
        model = build_model(body, terms)
        run = integrate(model, initial_state(model, w0, q0, qd0), 1.0, "rk4-lie", RK4_STEP)
        dE, dH = _drifts(model, run)
        assert max(dE, dH) > 1e-5, (terms, dE, dH)


@pytest.mark.slow
def test_the_papers_printed_coriolis_form_loses_angular_momentum(spinning):
    """G16 prints the rotational Coriolis force as the complete one plus -w~ C q' (theory section 5):
    with it |H| drifts, with the verified form it is kept to the integrator's tolerance."""
    body, w0, q0, qd0 = spinning
    model = build_model(body, FULL)
    f = Rhs(model)

    def printed(t, y):
        _, w, q, qd = eq.split(y, model.nf)
        J, C = eq.inertia(model, q), eq.coupling_matrix(model, q)
        extra = -np.cross(w, C @ qd)
        wd = np.linalg.solve(J - C @ C.T, extra)
        return f(t, y) + np.concatenate([np.zeros(4), wd, np.zeros(model.nf), -C.T @ wd])

    y0 = initial_state(model, w0, q0, qd0)
    drift = {}
    for name, fun in (("verified", f), ("printed", printed)):
        sol = solve_ivp(fun, (0, 0.05), y0, method="DOP853", rtol=1e-11, atol=1e-13, dense_output=False)
        H = [eq.angular_momentum(model, y) for y in sol.y.T]
        drift[name] = np.ptp(H) / H[0]
    assert drift["verified"] < 1e-9 < 1e-6 < drift["printed"], drift


# ---------------------------------------------------------------- level I against independent solutions
def test_level_I_is_euler_rigid_body_and_harmonic_modes(bodies):
    body = bodies["beam"]
    model = build_model(body, LEVEL_SETS["I"])
    w0, q0, qd0 = np.array([10.0, 5.0, 300.0]), np.linspace(0.04, 0.0, body.nf), np.linspace(0.0, 30.0, body.nf)
    run = integrate(model, initial_state(model, w0, q0, qd0), 0.05, "rk4", 1e-5, output_step=1e-3)
    I0 = body.I0
    euler = solve_ivp(lambda t, w: np.linalg.solve(I0, -np.cross(w, I0 @ w)), (0, 0.05), w0, method="DOP853",
                      rtol=1e-13, atol=1e-12, t_eval=run.t)
    Om = np.sqrt(body.eigenvalues)
    q = q0 * np.cos(np.outer(run.t, Om)) + qd0 / Om * np.sin(np.outer(run.t, Om))
    # rotation: h |w| = 3e-3, RK4 error far below 1e-9; each mode: RK4's phase error (h Omega)^5 / 120 per step
    assert np.abs(run.y[:, 4:7] - euler.y.T).max() < 1e-9 * np.abs(w0).max()
    amplitude = np.hypot(q0, qd0 / Om)
    steps = np.round(run.t / 1e-5)[:, None]
    bound = amplitude * (2 * steps * (1e-5 * Om) ** 5 / 120 + 1e-12)
    assert np.all(np.abs(run.y[:, 7:7 + body.nf] - q) <= bound)


# ---------------------------------------------------------------- RK4 limit and quaternion drift
def test_rk4_stability_limit_is_2_sqrt_2_over_omega_max(bodies):
    """Zero spin, the highest mode excited: bisection of the largest step that does not grow it."""
    body = bodies["beam"]
    model = build_model(body, LEVEL_SETS["I"])
    y0 = initial_state(model, (0, 0, 0), np.eye(body.nf)[-1])
    Om = np.sqrt(body.eigenvalues.max())

    def stable(h):
        run = integrate(model, y0, 400 * h, "rk4", h, output_step=400 * h)
        return not run.failed and np.abs(run.y[-1, 7:]).max() <= 1.0

    lo, hi = 1.0 / Om, 4.0 / Om
    for _ in range(20):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    assert abs(lo * Om / (2 * np.sqrt(2)) - 1) < 0.02


def test_quaternion_norm_drift_of_both_rk4_variants_is_reported(bodies):
    body = bodies["beam"]
    model = build_model(body, FULL)
    y0 = initial_state(model, (10.0, 5.0, 300.0), (0.04, 0.02))
    for method in ("rk4", "rk4-lie"):
        s = summary(model, integrate(model, y0, 0.05, method, 1e-5), "t-mm-N-s")
        assert 0 <= s["quaternion_norm_drift"] < 1e-12 and s["integrator"] == method


def test_a_step_far_beyond_the_limit_fails_plainly(bodies):
    body = bodies["beam"]
    model = build_model(body, FULL)
    h = 10 * 2 * np.sqrt(2) / np.sqrt(body.eigenvalues.max())
    run = integrate(model, initial_state(model, (10, 5, 300), (0.04, 0.02)), 2000 * h, "rk4", h)
    assert run.failed and run.t_fail is not None and run.reason


# ---------------------------------------------------------------- terms catalogue
def test_catalogue_lagrangian_sets_and_supersets():
    assert LEVEL_SETS["IV"] == FULL and is_lagrangian(FULL) and is_lagrangian(("gyro0",))
    assert not is_lagrangian(LEVEL_SETS["II"]) and lagrangian_superset(LEVEL_SETS["II"]) == (
        "gyro0", "cf1", "inertia_lin", "cor1")
    assert lagrangian_superset(("gyro0", "coupling")) == ("gyro0", "coupling", "cor_coupling")
    assert lagrangian_superset(("gyro0", "geo_stiff")) is None


# ---------------------------------------------------------------- the command
def _cli(*args) -> SimpleNamespace:
    """The command run in this process, whose compiled kernels are loaded (a new process pays about a second to
    start): its exit code, stdout and stderr; an exception that escaped the command fails the test."""
    r = CliRunner().invoke(app, [str(a) for a in args])
    assert r.exception is None or isinstance(r.exception, SystemExit), r.exc_info
    return SimpleNamespace(returncode=r.exit_code, stdout=r.stdout, stderr=r.stderr)


def test_simulate_command_writes_a_csv_that_parses_back(tmp_path):
    out = tmp_path / "beam.csv"
    q0 = ",".join(["0.04", "0.02"] + ["0"] * 14)  # one number per mode of the beam's 16
    r = _cli("simulate", DIR / "beam.ffrf.h5", "--terms", "III", "--omega0", "10,5,300", "--q0", q0,
             "--t-end", "0.01", "--integrator", "rk4", "--step", "1e-5", "--output-step", "1e-3", "-o", out)
    assert r.returncode == 0, r.stderr
    with open(out) as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == columns(16, TMM) and rows[0][:2] == ["t [s]", "wx [rad/s]"] and rows[0][8] == "q1 [sqrt(t) mm]"
    data = np.array(rows[1:], float)
    assert data.shape == (11, len(columns(16, TMM)))
    assert np.allclose(data[:, 0], np.linspace(0, 0.01, 11), rtol=0, atol=1e-12)
    assert data[0, 1:4].tolist() == [10.0, 5.0, 300.0] and data[0, 8:10].tolist() == [0.04, 0.02]
    assert np.all(np.abs(np.linalg.norm(data[:, 4:8], axis=1) - 1) < 1e-12)
    again = _cli("simulate", DIR / "beam.ffrf.h5", "--t-end", "0.01", "-o", out)
    assert again.returncode == 2 and "refusing to overwrite" in again.stderr
    h5 = tmp_path / "beam.h5"  # the HDF5 trajectory says what it is a run of (issue 25)
    assert _cli("simulate", DIR / "beam.ffrf.h5", "--terms", "III", "--omega0", "10,5,300", "--t-end", "0.001",
                "-o", h5).returncode == 0
    import h5py
    from ffrf_advisor.io import sha256
    with h5py.File(h5) as f:
        assert (f.attrs["body"], f.attrs["body_sha256"], f.attrs["units"]) == ("beam", sha256(DIR / "beam.ffrf.h5"),
                                                                              "t-mm-N-s")
        assert f.attrs["integrator"] == "dop853" and f.attrs["terms"].split(",")[0] == "gyro0"
        assert f.attrs["initial_state"][1:4].tolist() == [10.0, 5.0, 300.0]
        assert f["trajectory"].attrs["columns"].split(",") == columns(16, TMM)


@pytest.mark.parametrize("args, message", [
    (["--integrator", "euler"], "--integrator"), (["--terms", "cor_full"], "--terms"),
    (["--integrator", "rk4"], "rk4: a fixed-step method; expected --step"), (["--omega0", "1,2,3,4"], "--omega0"),
    (["--q0", "x"], "--q0"),
    (["--t-end", "-1"], "--t-end"), (["-o", "out.txt"], "output")])
def test_simulate_bad_options_exit_2_in_one_line(tmp_path, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    t_end = [] if "--t-end" in args else ["--t-end", "0.001"]
    r = _cli("simulate", DIR / "beam.ffrf.h5", *t_end, *args)
    assert r.returncode == 2 and message in r.stderr and "Traceback" not in r.stderr + r.stdout
    assert len(r.stderr.strip().splitlines()) == 1


@pytest.mark.slow
def test_simulate_json_follows_its_schema_and_reports_divergence():
    import json

    import jsonschema
    spec = schema("simulate")
    ok = _cli("simulate", DIR / "beam.ffrf.h5", "--terms", "II", "--omega0", "0,0,100", "--q0", "qmax",
              "--t-end", "0.002", "--json")
    assert ok.returncode == 0, ok.stderr
    data = json.loads(ok.stdout)
    jsonschema.validate(data, spec)
    assert data["terms"] == ["gyro0", "cf1"] and data["lagrangian"] is False and data["integrator"] == "dop853"
    bad = _cli("simulate", DIR / "beam.ffrf.h5", "--integrator", "rk4", "--step", "1e-3", "--q0", ",".join(["1"] * 16),
               "--t-end", "1", "--json")  # h Omega_16 = 20, far beyond 2 sqrt 2
    assert bad.returncode == 3
    data = json.loads(bad.stdout)
    jsonschema.validate(data, spec)
    assert data["failed"] and 0 < data["t_fail"] < 1 and data["reason"]


def test_first_modes_equals_the_integrals_of_the_first_modes(bodies):
    from ffrf_advisor.invariants import shape_integrals
    body = bodies["beam"]
    few = body.first_modes(5)
    direct = shape_integrals(body.fe.mesh.points, body.fe.Ms, body.fe.Phi[:, :, :5])
    assert few.nf == 5 and few.fe.Phi.shape[2] == 5 and few.sigma_max.shape == (5,)
    assert np.abs(few.integrals.Sbar - direct.Sbar).max() < 1e-12
    assert np.abs(few.W3 - direct.W3()).max() < 1e-12


def test_implicit_midpoint_is_stable_far_beyond_the_explicit_limit(bodies):
    """Five times the RK4 limit: RK4 fails, the midpoint rule stays bounded; |p| = 1 is a quadratic
    invariant it keeps to its Newton tolerance, and the energy of the linear modes to O(h^2) phase only."""
    body = bodies["beam"]
    model = build_model(body, FULL)
    h = 5 * 2 * np.sqrt(2) / np.sqrt(body.eigenvalues.max())
    y0 = initial_state(model, (10.0, 5.0, 300.0), np.full(body.nf, 0.01))
    assert integrate(model, y0, 200 * h, "rk4", h).failed
    run = integrate(model, y0, 200 * h, "midpoint", h)
    s = summary(model, run, "t-mm-N-s")
    assert not run.failed and s["quaternion_norm_drift"] < 1e-10
    assert s["energy_drift"] < 1e-3 and s["H_drift"] < 1e-3


def test_torque_about_a_principal_axis_spins_the_body_up_linearly(bodies):
    """A constant body torque about axis 3 from rest: w3 = tau t / I0_33 (Newton-Euler); the centrifugal
    widening it causes changes I_33 by 1e-12 relative here, below the tolerance."""
    body = bodies["beam"]
    model = build_model(body, FULL)
    tau = np.array([0.0, 0.0, 50.0])
    run = integrate(model, initial_state(model), 0.01, "rk4", 1e-5, loads=Loads(torque=lambda t: tau))
    expected = tau[2] * run.t / body.I0[2, 2]
    assert np.abs(run.y[:, 6] - expected).max() <= 1e-10 * expected.max()
    assert np.abs(run.y[:, 4:6]).max() <= 1e-10 * expected.max()


def test_prescribed_steady_spin_settles_at_the_static_centrifugal_deflection(bodies):
    """With w prescribed constant and damping, q tends to (Omega^2 - s^2 Kc)^-1 f_cf1 (theory sections 7, 9)."""
    body = bodies["genstruct1"]
    model = build_model(body, ("gyro0", "cf1", "cf2"), damping=0.5)
    w = np.array([20.0, 0.0, 0.0])
    run = integrate(model, initial_state(model), 3.0, "dop853", rtol=1e-10, atol=1e-12,
                    loads=Loads(prescribed=lambda t: (w, np.zeros(3))))
    zero = np.zeros(body.nf)
    f0 = eq.flexible_force(model, zero, zero, w, zero)           # cf1 at q = 0
    K = np.diag(body.eigenvalues) - np.array([eq.flexible_force(model, e, zero, w, zero) - f0 + body.eigenvalues * e
                                              for e in np.eye(body.nf)]).T  # Omega^2 - s^2 Kc
    q_static = np.linalg.solve(K, f0)
    assert np.abs(run.y[-1, 7:7 + body.nf] - q_static).max() < 1e-6 * np.abs(q_static).max()


def test_energy_and_momentum_of_a_stack_of_states_equal_those_of_each(bodies):
    """output.summary and the drift curves evaluate every sample at once: the same numbers as state by state."""
    body = bodies["beam"]
    rng = np.random.default_rng(3)
    model = build_model(body, FULL)
    ys = np.array([initial_state(model, w, q, qd) for q, qd, w in (_state(rng, body) for _ in range(7))])
    assert np.allclose(eq.energy(model, ys), [eq.energy(model, y) for y in ys], rtol=1e-13, atol=0)
    assert np.allclose(eq.angular_momentum(model, ys), [eq.angular_momentum(model, y) for y in ys], rtol=1e-13,
                       atol=0)


@pytest.mark.parametrize("nf", [1, 10, 48, 49, 200])
def test_the_cost_model_never_makes_a_set_cheaper_by_adding_a_term(nf):
    """sim.cost counts the kernels' loops in both storages (the tall one up to TALL_MAX = 48 modes, the strips
    above): a term added to any set adds its own work, so no superset may be cheaper; and cost_ratio is that
    quotient."""
    from ffrf_advisor.sim.cost import cost_ratio, rhs_cost

    rng = np.random.default_rng(nf)
    for _ in range(200):
        terms = {"gyro0", *(t for t in IDS if rng.random() < 0.5)}
        extra = rng.choice([t for t in IDS if t not in terms]) if len(terms) < len(IDS) else "gyro0"
        assert rhs_cost(terms | {extra}, nf) > rhs_cost(terms, nf) or extra in terms
        assert cost_ratio(terms | {extra}, terms, nf) == rhs_cost(terms | {extra}, nf) / rhs_cost(terms, nf)


def test_the_spin_profile_of_an_array_of_times_is_that_of_each_time():
    """spin_profile takes arrays (the mode-set advice samples a rise at 2001 points at once): each entry equals the
    scalar evaluation, w rises from 0 to W with w' = 0 at both ends and is held at W after T; T = 0: W at once."""
    from ffrf_advisor.sim.loads import spin_profile
    t = np.linspace(0.0, 1.5, 31)
    w, a = spin_profile(3.0, 1.0)(t)
    scalar = np.array([spin_profile(3.0, 1.0)(x) for x in t])
    assert np.array_equal(np.column_stack([w, a]), scalar)
    assert w[0] == 0.0 and a[0] == 0.0 and np.all(w[t >= 1.0] == 3.0) and np.all(a[t >= 1.0] == 0.0)
    assert np.all(np.diff(w) >= 0) and np.all(a >= 0)
    w0, a0 = spin_profile(3.0, 0.0)(t)
    assert np.all(w0 == 3.0) and np.all(a0 == 0.0) and spin_profile(3.0, 0.0)(0.2) == (3.0, 0.0)
