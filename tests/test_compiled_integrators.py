"""The compiled integrators (issue 24, item 1) against their references: scipy's DOP853 step for step, the
Python implicit midpoint rule to round-off, the load shapes against their Python functions, and the midpoint
rule's phase error against its exact value."""
from __future__ import annotations

import ast
import inspect
from pathlib import Path

import numba as nb
import numpy as np
import pytest
from typer.testing import CliRunner

from ffrf_advisor.cli import app
from ffrf_advisor.io import read_body
from ffrf_advisor.sim import integrate as integ
from ffrf_advisor.sim import kernels
from ffrf_advisor.sim.integrate import integrate
from ffrf_advisor.sim.loads import LoadProgram, Loads
from ffrf_advisor.sim.model import build_model, initial_state
from ffrf_advisor.terms import FULL

BEAM = Path(__file__).resolve().parent.parent / "sample_bodies" / "beam.ffrf.h5"
LOADS = {"none": Loads(),
         "torque pulse": Loads.of(LoadProgram(tau0=np.array([2e3, 0.0, 1e4]), pulse=0.004)),
         "spin ramp": Loads.of(LoadProgram(spin=np.array([0.0, 50.0, 300.0]), ramp=0.01)),
         "steady spin": Loads.of(LoadProgram(spin=np.array([0.0, 0.0, 300.0])))}


def _relative(run, ref, nf: int) -> float:
    """Largest difference of two runs' states, each part (quaternion, w, q, q') over its size in the reference."""
    parts = [slice(0, 4), slice(4, 7), slice(7, 7 + nf), slice(7 + nf, 7 + 2 * nf)]
    return max(np.abs(run.y[:, p] - ref.y[:, p]).max() / max(np.abs(ref.y[:, p]).max(), 1e-300) for p in parts)


@pytest.fixture(scope="module")
def beam():
    body = read_body(BEAM)
    return body, build_model(body, FULL)


@pytest.mark.parametrize("loads", LOADS, ids=list(LOADS))
def test_compiled_dop853_takes_scipys_steps_and_agrees_to_round_off(beam, loads):
    """The same step control gives the same accepted steps, but for a step whose error estimate lands on the
    acceptance threshold within the round-off of the stage sums (summed in another order; one in 1,600 seen):
    0.2 % of the steps; the states differ by that round-off, amplified over about 1,600 steps: 1e-8 of each
    part's size (measured 3e-11 to 1e-9)."""
    body, model = beam
    y0 = initial_state(model, (5.0, 0.0, 30.0), np.full(body.nf, 1e-3))
    runs = [integrate(model, y0, 0.03, method, rtol=1e-10, atol=1e-16, output_step=0.03 / 300, loads=LOADS[loads])
            for method in ("dop853", "scipy-dop853")]
    compiled, scipy = runs
    assert abs(compiled.steps - scipy.steps) <= 0.002 * scipy.steps and not compiled.failed and not scipy.failed
    assert np.array_equal(compiled.t, scipy.t)
    assert _relative(compiled, scipy, body.nf) < 1e-8


def test_the_compiled_load_shapes_equal_their_python_functions():
    programs = [LoadProgram(tau0=np.array([1.0, -2.0, 3.0]), pulse=0.3),
                LoadProgram(tau0=np.array([0.5, 0.0, 0.0])),
                LoadProgram(spin=np.array([1.0, 2.0, -3.0]), ramp=0.7), LoadProgram(spin=np.array([0.0, 4.0, 0.0]))]
    tau, w, wd = np.empty(3), np.empty(3), np.empty(3)
    for program in programs:
        for t in np.linspace(0.0, 1.0, 41):
            kernels.loads_at(t, program.packed(), tau, w, wd)
            assert np.allclose(tau, program.torque(t), rtol=1e-14, atol=0)
            if program.spin is not None:
                assert np.allclose(np.concatenate([w, wd]), np.concatenate(program.prescribed(t)), rtol=1e-14, atol=0)


@pytest.mark.parametrize("loads", LOADS, ids=list(LOADS))
def test_compiled_midpoint_equals_the_python_rule(beam, loads):
    """The same Newton iteration on the same finite-difference Jacobians, kept by the same rule: equal to
    round-off, with the same number of evaluations."""
    body, model = beam
    y0 = initial_state(model, (5.0, 0.0, 30.0), np.full(body.nf, 0.01))
    h = 2e-5
    compiled = integrate(model, y0, 100 * h, "midpoint", h, output_step=10 * h, loads=LOADS[loads])
    python = integ._fixed_python(model, y0, h, 100, 10, "midpoint", LOADS[loads], None)
    assert compiled.nfev == python.nfev and compiled.steps == python.steps == 100
    assert _relative(compiled, python, body.nf) < 1e-12


def test_a_kept_jacobian_gives_the_steps_of_a_fresh_one_for_fewer_evaluations(beam, monkeypatch):
    """The simplified Newton iteration converges to the same fixed point whichever Jacobian drives it: steps
    of 4 and 0.5 times the RK4 limit at 300 rad/s agree with a Jacobian taken at every step (the Python rule with
    THETA_REFRESH below every ratio) to 1e-11 of each part's size (the Newton tolerance 1e-12 over 100-900
    steps), in at most a third of the evaluations."""
    from ffrf_advisor.sim import midpoint
    body, model = beam
    y0 = initial_state(model, (5.0, 0.0, 300.0), np.full(body.nf, 0.01))
    limit = integ.rk4_limit(body.eigenvalues)
    kept = {f: integrate(model, y0, 0.06, "midpoint", f * limit, output_step=f * limit) for f in (4.0, 0.5)}
    monkeypatch.setattr(midpoint, "THETA_REFRESH", -1.0)
    for f, run in kept.items():
        fresh = integ._fixed_python(model, y0, f * limit, run.steps, 1, "midpoint", Loads(), None)
        assert not run.failed and not fresh.failed
        assert fresh.nfev >= run.steps * (len(y0) + 2)  # f0, a column per state entry, at least one iteration
        assert _relative(run, fresh, body.nf) < 1e-11
        assert run.nfev < fresh.nfev / 3


def test_the_midpoint_rules_phase_error_is_its_exact_value(beam):
    """A free undamped mode under the midpoint rule turns by 2 atan(h Omega / 2) per step: after N steps the
    phase is exactly N times that (the rule is a Cayley transform of the mode's rotation)."""
    body, _ = beam
    model = build_model(body, ("gyro0",))
    p = body.nf - 1
    om = float(np.sqrt(body.eigenvalues[p]))
    h = 1.5 / om  # far beyond RK4's limit 2 sqrt 2 / Omega only for this mode's neighbours: a visible error
    q0 = np.zeros(body.nf)
    q0[p] = 1e-3
    n = 40
    run = integrate(model, initial_state(model, (0, 0, 0), q0), n * h, "midpoint", h, output_step=h)
    phase = np.unwrap(np.arctan2(-run.y[:, 7 + body.nf + p] / om, run.y[:, 7 + p]))
    assert np.abs(phase - np.arange(n + 1) * 2 * np.arctan(h * om / 2)).max() < 1e-9


def test_an_over_budget_compiled_run_fails_and_says_so(beam, monkeypatch):
    body, model = beam
    monkeypatch.setattr(integ, "BASE_EVALUATIONS", 1000)
    monkeypatch.setattr(integ, "EVALUATIONS_PER_PERIOD", 0)
    run = integrate(model, initial_state(model, (0, 0, 30.0), np.full(body.nf, 1e-3)), 0.03, "dop853",
                    rtol=1e-10, atol=1e-16)
    assert run.failed and "work budget of 1000 right-hand sides" in run.reason and len(run.t) >= 1



def _literal(arg: ast.expr, constants: set[str]) -> bool:
    """An argument numba types as a literal: an int or bool constant (or its negative), or a module-level one
    (a float is typed float64: DOP853's start at t = 0.0 compiled once, numba's compile log showed)."""
    if isinstance(arg, ast.UnaryOp):
        arg = arg.operand
    return (isinstance(arg, ast.Constant) and isinstance(arg.value, (bool, int))
            or isinstance(arg, ast.Name) and arg.id in constants)


def _compiled_modules():
    """(module, its syntax tree) of the three modules of compiled code."""
    from ffrf_advisor.sim import dop853, midpoint
    return [(module, ast.parse(inspect.getsource(module))) for module in (kernels, dop853, midpoint)]


def test_no_compiled_call_passes_a_literal_argument():
    """numba compiles a callee once more, specialised, for each literal argument a compiled caller passes it (a
    literal prescribed=False had compiled the whole right-hand side twice, about 10 s of a fresh install's first
    simulation): no call of a kernel that is not inlined passes a constant or a module-level int or bool. The
    modules' Python-level code calls no kernel (a call from Python is typed by value, never as a literal)."""
    from numba.core.registry import CPUDispatcher

    found = []
    for module, tree in _compiled_modules():
        names = vars(module)
        called = {n for n, f in names.items() if isinstance(f, CPUDispatcher)
                  and f.targetoptions.get("inline", "never") == "never"}
        constants = {n for n, v in names.items() if isinstance(v, (bool, int))}
        assert "rhs_into" in called or module is not kernels
        found += [f"{module.__name__}:{node.lineno} {node.func.id}" for node in ast.walk(tree)
                  if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in called
                  and any(_literal(a, constants) for a in node.args)]
    assert not found, found


def test_no_compiled_function_calls_the_right_hand_side_by_name():
    """The compiled integrators call rhs_into through its address (kernels.call_rhs): called by name, numba links
    it into every compiled caller and compiles it once more in each layer (3.5-4 s a layer, docs/simulate.md)."""
    found = []
    for module, tree in _compiled_modules():
        for function in ast.walk(tree):
            if isinstance(function, ast.FunctionDef) and function.decorator_list:
                found += [f"{module.__name__}:{node.lineno}" for node in ast.walk(function)
                          if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "rhs_into"]
    assert not found, found


@pytest.mark.parametrize("terms", [("gyro0",), FULL], ids=["I", "IV"])
@pytest.mark.parametrize("source", ["beam.ffrf.h5", "plate.ffrf.h5", "beam.ffinv.json", "beam modes 1, 3-5"])
def test_every_model_is_packed_as_the_type_the_address_was_compiled_for(source, terms, tmp_path):
    """call_rhs passes the packed model to rhs_into compiled for kernels.MODEL: models from an FE body, an
    invariants file (read-only arrays as read) and a mode subset (views) are all packed as that type."""
    if source.endswith(".ffinv.json"):
        path = tmp_path / source
        assert CliRunner().invoke(app, ["convert", str(BEAM), str(path)]).exit_code == 0
        body = read_body(path)
    elif source.startswith("beam modes"):
        body = read_body(BEAM).with_modes(np.array([0, 2, 3, 4]))
    else:
        body = read_body(BEAM.parent / source)
    assert nb.typeof(integ._compiled_model(build_model(body, terms))) == kernels.MODEL


def test_the_right_hand_side_by_address_equals_it_by_name_and_refuses_other_types(beam):
    """kernels.call_rhs gives rhs_into's result bit for bit; an argument of another type than the address was
    compiled for (here a strided state) is a typing error naming call_rhs, not a call with a wrong layout."""
    @nb.njit
    def by_address(address, y, out, model, z3, zf):
        kernels.call_rhs(address, y, out, model, z3, zf, kernels.FREE[0], z3, z3)

    body, model = beam
    y = initial_state(model, (1.0, 2.0, 300.0), np.full(model.nf, 1e-3))
    compiled, z3, zf = integ._compiled_model(model), np.zeros(3), np.zeros(model.nf)
    direct, through = np.empty_like(y), np.empty_like(y)
    kernels.rhs_into(y, direct, compiled, z3, zf, False, z3, z3)
    by_address(kernels.rhs_address(), y, through, compiled, z3, zf)
    assert np.array_equal(direct, through)
    with pytest.raises(nb.core.errors.TypingError, match="call_rhs"):
        by_address(kernels.rhs_address(), np.repeat(y, 2)[::2], through, compiled, z3, zf)


def test_on_compile_tells_once_while_numba_compiles_and_not_when_code_comes_from_the_cache(tmp_path, monkeypatch):
    """kernels.on_compile calls back once, at the first compilation within it, never outside it, and not for a
    function loaded from numba's cache (a later run: the note of the first run after installing is not shown)."""
    (tmp_path / "cached_twice.py").write_text("import numba\n\n@numba.njit(cache=True)\ndef f(x):\n    return 2 * x\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    import cached_twice
    told = []
    with kernels.on_compile(lambda: told.append("compiling")):
        assert cached_twice.f(2) == 4  # compiled and written to the cache
        assert nb.njit(lambda x: x + 1)(1) == 2  # compiled again: told already
    assert nb.njit(lambda x: x + 3)(1) == 4 and told == ["compiling"]
    with kernels.on_compile(lambda: told.append("again")):
        again = nb.njit(cache=True)(cached_twice.f.py_func)  # a new dispatcher: loaded from the cache
        assert again(3) == 6 and again.stats.cache_hits
    assert told == ["compiling"]


@pytest.mark.slow
def test_the_first_simulation_after_installing_says_it_compiles_on_a_terminal(tmp_path):
    """simulate (RK4, the least to compile) on a terminal (rich's TTY_COMPATIBLE) with an empty numba cache notes
    that it compiles; the next run loads the code and notes nothing."""
    import os
    import subprocess
    import sys
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "TTY_COMPATIBLE": "1", "COLUMNS": "200"}
    run = [sys.executable, "-m", "ffrf_advisor", "simulate", str(BEAM), "--t-end", "1e-4", "--omega0", "0,0,300",
           "--integrator", "rk4", "--step", "1e-5"]
    first, second = (subprocess.run(run, capture_output=True, text=True, env=env) for _ in range(2))
    assert first.returncode == second.returncode == 0
    assert "compiling the simulator (the first run after installing" in first.stderr
    assert "compiling" not in second.stderr


def test_compiling_ahead_gives_the_signatures_the_runs_use(beam):
    """integrate.compile_ahead compiles each integrator for the argument types its runs pass: after it, a run of
    each adds no second signature (else the tests' workers would compile ahead in vain, conftest.py)."""
    from ffrf_advisor.sim import dop853, lawson, midpoint, rk4
    integ.compile_ahead(integ.COMPILED)
    _, model = beam
    y0 = initial_state(model, (0.0, 0.0, 30.0), np.full(model.nf, 1e-4))
    for method in ("rk4", "rk4-lie", "dop853", "midpoint", integ.EXPONENTIAL):
        integrate(model, y0, 1e-4, method, step=1e-5 if method in integ.FIXED else None, progress=lambda _: None)
    dispatchers = (rk4.rk4_loop, dop853.integrate_dop853, midpoint.midpoint_loop, lawson.integrate_lawson)
    assert [len(d.signatures) for d in dispatchers] == [1, 1, 1, 1]


@pytest.mark.slow
def test_a_fresh_install_compiles_the_right_hand_side_in_a_second_process(tmp_path):
    """compile_beside on an empty numba cache: a helper process compiles the right-hand side while this one
    compiles the integrator, which then loads it from the cache (a hit, no miss: not compiled twice); with
    the cache filled, no helper starts and everything loads (a first verify --quick 20 -> 15 s, a full one
    39 -> 31 s on the beam, 2026-11-26)."""
    import os
    import subprocess
    import sys
    script = """
import subprocess
from ffrf_advisor.sim import dop853, integrate, kernels
spawned, real = [], subprocess.Popen
subprocess.Popen = lambda *args, **kwargs: spawned.append(1) or real(*args, **kwargs)
integrate.compile_beside(("dop853",))
count = lambda stats: (sum(stats.cache_hits.values()), sum(stats.cache_misses.values()))
print(len(spawned), *count(kernels.rhs_into.stats), *count(dop853.integrate_dop853.stats))
"""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    runs = [subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=300)
            for _ in range(2)]
    assert all(r.returncode == 0 for r in runs), runs[0].stderr + runs[1].stderr
    fresh, cached = (tuple(map(int, r.stdout.split())) for r in runs)
    assert fresh == (1, 1, 0, 0, 1)  # a helper; the right-hand side loaded, the integrator compiled here
    assert cached == (0, 1, 0, 1, 0)  # no helper; both loaded
