"""Start-up: `--version`, `--help` and `COMMAND --help` import neither numpy nor scipy (issue 24, item 5), and
the commands that analyse a body with a cache import neither scipy nor pydantic (items 3 and 5).

Each case runs the CLI in a fresh interpreter and lists the heavy packages it imported by then;
benchmarks/bench_startup.py times the same runs.
"""
from __future__ import annotations

import gc
import json
import os
import subprocess
import sys
from contextlib import contextmanager
from pathlib import Path

import pytest
import typer

from ffrf_advisor import collector
from ffrf_advisor.cli import app

ROOT = Path(__file__).resolve().parent.parent
HEAVY = ("numpy", "scipy", "h5py", "numba", "matplotlib", "weasyprint", "pydantic", "multiprocessing",
         "ffrf_advisor.fe")
PROBE = f"""
import sys
from ffrf_advisor.cli import app
try:
    app(sys.argv[1:], prog_name="ffrf-advisor")
except SystemExit as e:
    print("exit", e.code)
loaded = {{m.split(".")[0] for m, mod in list(sys.modules.items()) if type(mod).__name__ != "_LazyModule"}}
loaded |= {{"ffrf_advisor.fe"}} & {{m.rpartition(".")[0] for m in sys.modules}}  # the FE modules: mesh, elements
print("imported", *sorted(loaded & set({HEAVY!r})))  # a lazy module (io.guard.lazy_module) counts once loaded
"""
COMMANDS = sorted(typer.main.get_command(app).commands)


def heavy_imports(*args: str) -> tuple[int, set[str]]:
    """(exit code, heavy packages imported) of ``ffrf-advisor ARGS`` in a fresh interpreter."""
    run = subprocess.run([sys.executable, "-c", PROBE, *args], capture_output=True, text=True, check=True)
    *_, exit_line, imported = run.stdout.splitlines()
    return int(exit_line.removeprefix("exit ")), set(imported.split()[1:])


def test_every_command_is_probed():
    assert {"analyze", "info", "gate", "verify", "simulate", "sample", "schema"} <= set(COMMANDS)


@pytest.mark.parametrize("args", [["--version"], ["--help"], *([c, "--help"] for c in COMMANDS)], ids=" ".join)
def test_version_and_help_import_no_numpy(args):
    code, heavy = heavy_imports(*args)
    assert code == 0 and heavy == set(), f"ffrf-advisor {' '.join(args)} imported {sorted(heavy)}"


def test_probe_sees_numpy():
    """The probe itself: a command that reads (formats lists the readers) imports numpy."""
    code, heavy = heavy_imports("formats")
    assert code == 0 and "numpy" in heavy


def test_version_alone_is_answered_before_the_cli_is_built():
    """`ffrf-advisor --version` prints the line of the CLI's own --version without importing typer."""
    from ffrf_advisor import version_line
    probe = ("import runpy, sys; sys.argv = ['ffrf-advisor', '--version']; "
             "runpy.run_module('ffrf_advisor', run_name='__main__'); print('typer' in sys.modules)")
    fast = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True).stdout
    typer_path = subprocess.run([sys.executable, "-c", PROBE, "--version"], capture_output=True, text=True,
                                check=True).stdout
    assert fast.splitlines() == [version_line(), "False"]
    assert typer_path.splitlines()[0] == version_line()


@pytest.fixture(scope="module")
def cached_beam(tmp_path_factory):
    """The beam written again by the tool: with its invariants and nodal summary cached."""
    from ffrf_advisor.io import read_body, write_body
    path = tmp_path_factory.mktemp("cached") / "beam.ffrf.h5"
    write_body(read_body(ROOT / "sample_bodies" / "beam.ffrf.h5", load_fe=True), path)
    return path


@pytest.mark.parametrize("args", [["info"], ["analyze", "--speed", "300rad/s"], ["settings", "--solver", "adams"],
                                  ["gate", "--speed", "300rad/s", "--max-level", "IV"]], ids=lambda a: a[0])
def test_a_cached_body_is_analysed_without_scipy_or_pydantic(cached_beam, args):
    """scipy.sparse and the FE modules are for FE data, pydantic was typer's coercion (cli_params): together
    0.15 s per command;
    multiprocessing is for more than one job (pool.local_pool: gate --jobs 1 ran without it). h5py and the
    HDF5 library (io.guard.lazy_module): analyze, info and gate leave them to the reading child and import
    their own modules while it parses; settings loads them meanwhile, for the reads and writes that may
    follow."""
    code, heavy = heavy_imports(args[0], str(cached_beam), *args[1:])
    assert code == 0 and "numpy" in heavy
    assert not heavy & {"scipy", "pydantic", "numba", "multiprocessing", "ffrf_advisor.fe"}, heavy
    assert ("h5py" in heavy) == (args[0] not in ("analyze", "info", "gate")), heavy


def test_help_builds_no_command_and_lists_what_the_built_commands_say():
    """LazyCommands: the command list of --help comes from the docstrings, as click shortens a built command's
    help; looking a command up builds that one only."""
    from typer._click import Context
    group = typer.main.get_command(app)
    ctx = Context(group, info_name="ffrf-advisor")
    text = group.get_help(ctx)
    assert not group.commands._built and all(f"  {name} " in text for name in COMMANDS)
    lines = {name: group.commands.short_help(name, 60) for name in COMMANDS}
    assert group.get_command(ctx, "info").name == "info" and set(group.commands._built) == {"info"}
    assert {name: group.get_command(ctx, name).get_short_help_str(60) for name in COMMANDS} == lines


@pytest.mark.parametrize("given", [None, "20"])
def test_the_command_line_shortens_openblas_spin_unless_the_user_set_it(given):
    """__main__.BLAS_SPIN: set in the environment before the command loads numpy (and OpenBLAS reads it), a
    value the user gave kept."""
    from ffrf_advisor.__main__ import BLAS_SPIN
    name, value = BLAS_SPIN
    probe = ("import os, runpy, sys; sys.argv = ['ffrf-advisor', 'formats']\n"
             "try:\n    runpy.run_module('ffrf_advisor', run_name='__main__')\nexcept SystemExit:\n    pass\n"
             f"print(os.environ.get({name!r}))")
    env = {k: v for k, v in os.environ.items() if k != name} | ({} if given is None else {name: given})
    run = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True, env=env)
    assert run.stdout.splitlines()[-1] == (value if given is None else given)


def test_gate_over_bodies_loads_the_file_libraries_while_the_second_body_is_read(cached_beam):
    """gate.AFTER_READ: the first body's reading child parses while the tool imports the analysis (one body:
    no h5py in the tool, above); from the second body on, while it loads h5py, which the later children then
    inherit loaded instead of each importing it anew (about 25 ms a body)."""
    args = ("gate", str(cached_beam), str(cached_beam), "--speed", "300rad/s", "--max-level", "IV")
    code, heavy = heavy_imports(*args)
    assert code == 0 and "h5py" in heavy


def test_the_options_are_built_and_checked_without_the_analysis():
    """situation: a command (gate) builds and checks its options before the first read without importing the
    analysis modules, which it imports while the reading child parses (gate.AFTER_READ)."""
    probe = ("import sys\nfrom ffrf_advisor.cli_options import AnalysisArgs\n"
             "o = AnalysisArgs(speed='300rad/s', threshold=['dI_L=0.01'], tolerance=0.02).options(print)\n"
             "print(o.situation.w_op, o.situation.tolerance)\n"
             "print(*sorted(m for m in sys.modules if m.startswith('ffrf_advisor.')))")
    run = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    values, loaded = run.stdout.splitlines()[-2:]
    assert values == "300.0 0.02"
    assert not set(loaded.split()) & {"ffrf_advisor.analysis", "ffrf_advisor.guidelines", "ffrf_advisor.predict",
                                      "ffrf_advisor.amplitudes", "ffrf_advisor.significance"}, loaded


FORK_PROBE = """
import gc, json, runpy, sys
from ffrf_advisor.io import guard
real, seen = guard._forked, []
guard._forked = lambda *a, **k: seen.append({"collecting": gc.isenabled(), "rich": "rich" in sys.modules,
                                             "meanwhile": list(guard._MEANWHILE)}) or real(*a, **k)
sys.argv = ["ffrf-advisor", *sys.argv[1:]]
try:
    runpy.run_module("ffrf_advisor", run_name="__main__")
except SystemExit:
    pass
print(json.dumps({"forks": seen, "collecting": gc.isenabled(), "frozen": gc.get_freeze_count() > 0}))
"""


def at_forks(*args: str) -> dict:
    """What ``ffrf-advisor ARGS`` had done when it forked each child (the collector's state, rich imported, the
    modules to import while the child reads) and the collector's state at the end."""
    run = subprocess.run([sys.executable, "-c", FORK_PROBE, *args], capture_output=True, text=True, check=True)
    return json.loads(run.stdout.splitlines()[-1])


def test_the_tool_starts_without_the_collector_and_collects_after_its_first_read(cached_beam):
    """__main__: the cyclic garbage collector is off while the tool starts (up to the first reading child) and
    on after it, with start-up's objects frozen out of its scans (ffrf_advisor.collector)."""
    seen = at_forks("info", str(cached_beam))
    assert [f["collecting"] for f in seen["forks"]] == [False] and seen["collecting"] and seen["frozen"]


def test_a_one_body_gate_imports_its_report_while_the_body_is_read(cached_beam):
    """cli.gate: one body shows no progress bar (no steps to show), so the console report and rich are imported
    while the body is read (gate.run_gate's after_read), not before; --json needs neither."""
    args = ("gate", str(cached_beam), "--speed", "300rad/s", "--max-level", "IV")
    (fork,) = at_forks(*args)["forks"]
    assert not fork["rich"] and "ffrf_advisor.report.console" in fork["meanwhile"]
    (fork,) = at_forks(*args, "--json")["forks"]
    assert not fork["rich"] and "ffrf_advisor.report.console" not in fork["meanwhile"]


@contextmanager
def collector_state(how: str):
    """Within: the collector as the tool's start-up holds it ("paused", ffrf_advisor.collector), on ("on": the
    package used as a library) or turned off by its user ("off"); then as it was, nothing left frozen."""
    before = gc.isenabled()
    if how == "paused":
        collector.pause()
    elif how == "off":
        gc.disable()
    try:
        yield
    finally:
        collector.resume()
        gc.unfreeze()
        (gc.enable if before else gc.disable)()


@pytest.mark.parametrize("how", ["paused", "on", "off"])
def test_a_guarded_read_collects_in_the_child_and_after_it_in_the_parent(cached_beam, how):
    """io.atomic.forked_child: a read forked where the tool's start-up holds the collector off freezes what
    exists before the fork, the child collects (leaving the frozen objects' pages alone), and the parent
    collects again after it; where it is on, or off by the choice of the program using the package, it stays
    so and nothing is frozen."""
    from ffrf_advisor.io import guard
    frozen = gc.get_freeze_count()
    with collector_state(how):
        on, in_child = guard.run(cached_beam, "lib", lambda: (gc.isenabled(), gc.get_freeze_count()))
        assert on == (how != "off") and (in_child > frozen) == (how == "paused")
        assert gc.isenabled() == (how != "off") and (gc.get_freeze_count() > frozen) == (how == "paused")


def test_a_pool_started_before_any_read_collects_in_its_workers_and_parent():
    """pool.local_pool: the workers of a command that has read nothing yet (gate --jobs) and the tool itself
    collect again (ffrf_advisor.collector)."""
    from ffrf_advisor.pool import local_pool
    with collector_state("paused"), local_pool(1) as pool:
        assert pool.submit(gc.isenabled).result() and gc.isenabled()
