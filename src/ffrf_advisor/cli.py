"""The ffrf-advisor command line: thin wiring of readers, analyses and reports.

Each command imports what it uses when it runs: `--version` and `--help` import neither numpy nor rich
(tests/test_startup.py, benchmarks/bench_startup.py); help texts take their lists from ``names``. No
``from __future__ import annotations``: typer reads every command's annotations at each run, and as strings
they cost about 8 ms more.
"""
import functools
import inspect
import sys
import time
import warnings
from collections.abc import MutableMapping
from contextlib import contextmanager, nullcontext
from pathlib import Path
from typing import Annotated, Optional, get_args, get_origin

import typer
from typer._click.exceptions import NoArgsIsHelpError, UsageError  # typer vendors click (pinned)
from typer._click.utils import make_default_short_help
from typer.core import TyperArgument, TyperGroup

from . import version_line
from .cli_params import plain_runtime_param
from .cli_options import AnalysisArgs, Density, Eigenvalues, UnitSystem, analysis_options, numbers, read_any
from .errors import FFRFError
from .names import INTEGRATORS, MAX_MEMORY_ENV, SAMPLES, SCENES, SCHEMA_COMMANDS, SOLVERS

_consoles: dict = {}  # this run's rich consoles: "out" (stdout), "err" (errors, warnings), "info" (progress, notes)
_run = {"quiet": False}  # this run's --quiet


def _console(kind: str):
    """This run's rich console, made at first use with the width the terminal (or COLUMNS) has now, not as at
    an earlier run in this process (tests, notebooks); "info" is stderr, silent under --quiet."""
    if kind not in _consoles:
        from rich.console import Console
        # emoji=False: names like zoo:ring:1003 stay text
        console = Console(stderr=kind != "out", emoji=False, highlight=False,
                          quiet=kind == "info" and _run["quiet"])
        console.width = console.width
        _consoles[kind] = console
    return _consoles[kind]


out, err, notes = (functools.partial(_console, kind) for kind in ("out", "err", "info"))


def _note(text: str) -> None:
    """A note on stderr (silent under --quiet), printed as it is."""
    notes().print(text, markup=False, highlight=False)


def _print_json(data) -> None:
    import json
    print(json.dumps(data, indent=1))


def _importing(*modules: str):
    """Within: ``modules`` (what a command uses after its read; ".name" for this package's) are imported while
    the reading child parses the body file (io.guard.importing_meanwhile)."""
    from importlib.util import resolve_name
    from .io.guard import importing_meanwhile
    return importing_meanwhile(*(resolve_name(m, __package__) for m in modules))


def run_analysis(body, options):
    """analysis.analyze, imported when a command analyses."""
    from .analysis import analyze
    return analyze(body, options)


class LazyCommands(MutableMapping):
    """The CLI's commands by name, each built by typer when first looked up: a run builds the command it
    invokes, and the command list of --help comes from the docstrings (typer introspects a command's parameters
    to build it: about 10 ms for all 16, before any option is parsed)."""

    def __init__(self, infos: dict):
        self._infos, self._built = infos, {}

    def __getitem__(self, name: str):
        if name not in self._built:
            self._built[name] = typer.main.get_command_from_info(
                self._infos[name], pretty_exceptions_short=app.pretty_exceptions_short,
                rich_markup_mode=app.rich_markup_mode)
        return self._built[name]

    def __setitem__(self, name: str, command) -> None:
        self._built[name] = command

    def __delitem__(self, name: str) -> None:
        self._infos.pop(name, None)
        self._built.pop(name, None)

    def __iter__(self):
        return iter({**self._infos, **self._built})

    def __len__(self) -> int:
        return len({**self._infos, **self._built})

    def short_help(self, name: str, limit: int) -> str:
        """The command's line in the command list, as click shortens its help, without building it."""
        if name in self._built:
            return self._built[name].get_short_help_str(limit)
        return make_default_short_help(inspect.getdoc(self._infos[name].callback) or "", limit)


class OneLineUsage(TyperGroup):
    """Usage errors (unknown option, missing argument, bad value) as one line on stderr with exit 2, like every
    other bad input; without arguments the help, on stderr, with exit 2. Commands are built on first use
    (LazyCommands)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.commands = LazyCommands(dict(COMMANDS))

    def list_commands(self, ctx) -> list[str]:
        return list(self.commands)

    def format_commands(self, ctx, formatter) -> None:
        names = self.list_commands(ctx)
        if names:
            limit = formatter.width - 6 - max(map(len, names))
            with formatter.section("Commands"):
                formatter.write_dl([(name, self.commands.short_help(name, limit)) for name in names])

    def main(self, *args, standalone_mode: bool = True, **kwargs):
        _plain_metavars(self)
        try:
            code = super().main(*args, standalone_mode=False, **kwargs)
        except NoArgsIsHelpError as e:
            print(e.format_message(), file=sys.stderr)
            code = EXIT_BAD_INPUT
        except UsageError as e:
            where = " ".join(["ffrf-advisor", *(e.ctx.command_path.split()[1:] if e.ctx is not None else [])])
            err().print(f"error: {' '.join(e.format_message().split())} (see `{where} --help`)", markup=False,
                        highlight=False, soft_wrap=True)
            code = EXIT_BAD_INPUT
        except typer.Abort:
            err().print("aborted", highlight=False)
            code = 1
        if standalone_mode:
            sys.exit(code if isinstance(code, int) else 0)
        return code

    def get_command(self, ctx, name):
        command = super().get_command(ctx, name)
        if command is not None:
            _plain_metavars(command)
            if ctx is not None:
                _plain_coercion(command.get_help_option(ctx))
        return command

    def get_help_option(self, ctx):
        option = super().get_help_option(ctx)
        _plain_coercion(option)
        return option


def _plain_coercion(param) -> None:
    """The parameter's values coerced by cli_params (no pydantic) where its type allows."""
    if param is not None and param._runtime_param is None:
        param._runtime_param = plain_runtime_param(param)


PLAIN_TYPES = {"str": "TEXT", "float": "NUMBER", "int": "INTEGER", "Path": "PATH"}


def _plain_metavars(command) -> None:
    """Help in the words of man pages: ``BODY``, ``--speed TEXT``, ``--jobs INTEGER`` (typer shows ``{body}``,
    ``<str>``, ``<int range>``); values coerced without pydantic (cli_params)."""
    for param in command.params:
        _plain_coercion(param)
        if param.metavar is not None or getattr(param, "is_flag", False):
            continue
        if isinstance(param, TyperArgument):
            param.metavar = param.name.upper()
            usage = param.metavar + ("..." if param.nargs != 1 else "")
            param._usage_display_name = lambda usage=usage: usage  # no braces around required arguments
            param.display_type_rich = lambda ctx: None  # the name says it: BODY, BODIES...
        else:
            kind = param.type_descriptor.annotation
            kind = (get_args(kind) or (kind,))[0] if get_origin(kind) is list else kind
            param.metavar = PLAIN_TYPES.get(getattr(kind, "__name__", ""), "VALUE")


app = typer.Typer(cls=OneLineUsage, no_args_is_help=True, context_settings={"help_option_names": ["-h", "--help"]},
                  rich_markup_mode=None,  # help texts keep [units]
                  help="Which FFRF inertia terms does a flexible body need? Advice with evidence.")

EXIT_BAD_INPUT = 2


def handles_errors(fn):
    """Report FFRFError (bad input) as one line on stderr with exit code 2, no traceback; any other error
    after reading (numerics a body provokes, a full disk) likewise, named by its type, so exit 1 keeps its
    one meaning (gate: a body exceeds its level). Adds --quiet/-q to the command: no progress and no notes
    on stderr (errors and warnings stay)."""
    signature = inspect.signature(fn)
    quiet = inspect.Parameter("quiet", inspect.Parameter.KEYWORD_ONLY, default=False, annotation=Quiet)

    @functools.wraps(fn)
    def wrapper(*args, quiet: bool = False, **kwargs):
        from .io.atomic import one_run
        _run["quiet"] = quiet
        _consoles.pop("info", None)
        try:
            with one_run(), warnings.catch_warnings():  # what the command reads, it never writes over
                warnings.simplefilter("ignore")  # numpy's overflow warnings of a diverging run: the summary says it
                return fn(*args, **kwargs)
        except FFRFError as e:
            message = str(e)
        except (typer.Exit, typer.Abort, KeyboardInterrupt, SystemExit):
            raise
        except Exception as e:  # noqa: BLE001 - the promise is one line and exit 2 for whatever a file provokes
            message = f"unexpected {type(e).__name__}: {' '.join(str(e).split())[:300]}"
        err().print(f"error: {message}", markup=False, highlight=False, soft_wrap=True)
        raise typer.Exit(EXIT_BAD_INPUT) from None
    wrapper.__signature__ = signature.replace(parameters=[*signature.parameters.values(), quiet])
    return wrapper


Quiet = Annotated[bool, typer.Option("--quiet", "-q", help="No progress and no notes on stderr (errors and "
                                                           "warnings stay).")]


def _version(value: bool):
    if value:
        print(version_line())
        raise typer.Exit()


def _limits(needed: bool):
    """io.limits when an option sets it or an earlier run in this process may have (it imports the readers and
    numpy, which --help does without); None when the defaults hold."""
    if needed or f"{__package__}.io.limits" in sys.modules:
        from .io import limits
        return limits
    return None


def _max_memory(value: Optional[str]):
    if (limits := _limits(value is not None)) is None:
        return
    try:
        limits.set_max_bytes(None if value is None else limits.parse_size(value, "--max-memory"))
    except FFRFError as e:
        err().print(f"error: {e}", markup=False, highlight=False, soft_wrap=True)
        raise typer.Exit(EXIT_BAD_INPUT) from None


@app.callback()
def main(version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                      help="Print the version and exit."),
         max_memory: Optional[str] = typer.Option(
             None, "--max-memory", callback=_max_memory,
             help=f"Most memory a body file may make the tool allocate: 8G, 500M (default ${MAX_MEMORY_ENV} or 8G)."),
         follow_outside: bool = typer.Option(
             False, "--follow-outside", help="Follow references (HDF5 external links, XDMF data) to files "
                                             "outside the body file's folder.")):
    """ffrf-advisor: guideline advisor for flexible bodies in the floating frame of reference."""
    _consoles.clear()
    if (limits := _limits(follow_outside)) is not None:
        limits.follow_outside(follow_outside)


def _json_option(command: str):
    return Annotated[bool, typer.Option("--json", help=f"Print JSON (its schema: `ffrf-advisor schema {command}`) "
                                                        "instead of tables.")]


AsJson = _json_option("analyze")
InfoJson, GateJson, CompareJson = (_json_option(c) for c in ("info", "gate", "compare"))
SettingsJson, SimulateJson, VerifyJson = (_json_option(c) for c in ("settings", "simulate", "verify"))
ModesJson, DiffJson = _json_option("modes"), _json_option("diff")


@app.command()
@handles_errors
def info(body: Path = typer.Argument(..., help="Body file (any format, see `formats`)."),
         eigenvalues: Eigenvalues = None, density: Density = None, units: UnitSystem = None,
         as_json: InfoJson = False):
    """Mass, CoM, I0, eigenfrequencies, modal stress and the checks of theory section 4."""
    with _importing(".checks", ".report.console", ".report.json_out"):
        b = read_any(body, eigenvalues, density, load_fe=False, units=units)
    from .checks import run_checks
    from .report.console import body_summary
    from .report.json_out import info_json
    checks = run_checks(b)
    if as_json:
        _print_json(info_json(b, checks, str(body)))
        return
    body_summary(out(), b, checks)


@app.command()
@handles_errors
@analysis_options
def analyze(body: Path = typer.Argument(..., help="Body file."), as_json: AsJson = False, *,
            args: AnalysisArgs):
    """Recommend the equation-of-motion level I-IV with the term set and the numbers that decided it."""
    with _importing(".modeset", ".verify.scenes", ".report.console", ".report.json_out", ".report.modes_out"):
        b = args.read(body, load_fe="summary")
    from .modeset import ANALYZE_SCENES, advise_modes
    from .report.console import analysis_summary
    from .report.json_out import analysis_json
    from .report.modes_out import mode_set_json
    result = run_analysis(b, args.options(_note))
    mode_set = advise_modes(result, ANALYZE_SCENES)
    if as_json:
        _print_json({**analysis_json(result, str(body)), "mode_set": mode_set_json(mode_set)})
    else:
        analysis_summary(out(), result, err(), f"{mode_set.summary()} (ffrf-advisor modes BODY: details)")


@app.command()
@handles_errors
@analysis_options
def gate(bodies: list[Path] = typer.Argument(..., help="Body files."),
         max_level: str = typer.Option(..., "--max-level", help="Highest level the model implements: I-IV."),
         junit: Optional[Path] = typer.Option(None, "--junit", help="Write JUnit XML here."),
         force: bool = typer.Option(False, "--force", help="Let --junit replace a file that is not a JUnit report."),
         jobs: int = typer.Option(1, "--jobs", "-j", min=1, help="Bodies analysed in parallel."),
         as_json: GateJson = False, *, args: AnalysisArgs):
    """CI gate: exit 0 when every body's level is within --max-level, 1 when one is not, 2 on bad input."""
    from .gate import check_junit_target, run_gate, write_junit
    from .io.atomic import atomic_path
    from .names import LEVELS
    from .report.progress import step_bar
    max_level = max_level.strip().upper()
    if max_level not in LEVELS:
        raise FFRFError(f"--max-level {max_level!r}: expected one of {', '.join(LEVELS)}")
    if junit is not None:
        check_junit_target(junit, bodies, force)
    options = args.options(_note)
    if options.situation.w_op is None:
        raise FFRFError("gate: --speed: expected the operating speed (0 for a body at rest), --speed-range or "
                        "speed in the config; without one only the rules that hold at rest would be evaluated")
    report = () if as_json else (f"{__package__}.report.console",)  # imported while the first body is read
    with step_bar(notes()) if len(bodies) > 1 else nullcontext() as progress:  # one body: no steps to show
        results = run_gate([str(b) for b in bodies], options, max_level, jobs, args.mesh_options(), progress, report)
    from .guidelines import operating_point
    from .report.console import gate_report
    from .report.json_out import SCHEMA_VERSION
    if junit is not None:
        with atomic_path(junit, overwrite=True) as tmp:
            write_junit(results, max_level, tmp)
    if as_json:
        _print_json({"schema_version": SCHEMA_VERSION, "max_level": max_level, "bodies": results})
    else:
        gate_report(out(), err(), results, max_level, operating_point(options.situation))
    if any(r["error"] for r in results):
        raise typer.Exit(EXIT_BAD_INPUT)
    if not all(r["within"] for r in results):
        raise typer.Exit(1)


@app.command()
@handles_errors
@analysis_options
def compare(bodies: list[Path] = typer.Argument(..., help="Body files."), as_json: CompareJson = False, *,
            args: AnalysisArgs):
    """Paper-style comparison of bodies: frequencies, stress, q_max, inertia, coupling and norm ratios."""
    from .report.compare import comparison, comparison_table
    from .report.console import shown
    options = args.options(_note)
    analyses = [run_analysis(args.read(b, load_fe="summary"), options) for b in bodies]
    data = comparison(analyses, [str(b) for b in bodies])
    if as_json:
        _print_json(data)
    else:
        out().print(comparison_table(data))
        for body in data["bodies"]:
            for w in body["warnings"]:
                err().print(f"{shown(body['name'])}: warning: {shown(w, 2000)}", highlight=False)


@app.command()
@handles_errors
@analysis_options
def report(bodies: list[Path] = typer.Argument(..., help="Body file(s); several give the comparison first."),
           output: Path = typer.Option(..., "--output", "-o", help="Report file: .html (self-contained) or .pdf."),
           verify: bool = typer.Option(False, "--verify", help="Verify each advice by simulation (the beam: "
                                                               "about 20 s) and include it."),
           verification: Optional[list[Path]] = typer.Option(
               None, "--verification", help="Include a verification already run: the JSON of `verify --json -o "
                                            "DIR` (its figures are read from DIR), one per body in order."),
           force: bool = typer.Option(False, "--force", help="Overwrite OUTPUT."), *, args: AnalysisArgs):
    """HTML or PDF report: verdict, evidence, the paper's figures and tables, pictures, Campbell, verification."""
    import tempfile
    from .report import document
    from .report.progress import busy, step_bar
    from .report.write import check_report_target, write
    check_report_target(output, bodies, force)
    if verification and len(verification) != len(bodies):
        raise FFRFError(f"--verification: expected one file per body ({len(bodies)}), got {len(verification)}")
    options = args.options(_note)
    with step_bar(notes()) as progress:
        analyses = [_analysed(args, b, options, progress, (i, len(bodies))) for i, b in enumerate(bodies)]
    with tempfile.TemporaryDirectory(prefix="ffrf-report-") as scratch:  # figures of --verify, until written
        studies = [_verification(a, b, Path(scratch) / str(i) if verify else None,
                                 verification[i] if verification else None)
                   for i, (a, b) in enumerate(zip(analyses, bodies))]
        doc = (document.single(analyses[0], str(bodies[0]), studies[0]) if len(bodies) == 1
               else document.collection(analyses, [str(b) for b in bodies], studies))
        with busy(notes(), f"writing {output}"):
            write(doc, output, force)
    notes().print(f"wrote {output} ({output.stat().st_size / 1024:.0f} KiB)", markup=False, highlight=False)


def _analysed(args: AnalysisArgs, body: Path, options, progress, step: tuple[int, int]):
    """run_analysis of one body of a report, then ``progress`` (step_bar) told which of how many is done."""
    analysis = run_analysis(args.read(body), options)
    if progress is not None:
        progress(f"analysed {body}", step[0] + 1, step[1])
    return analysis


def _verification(analysis, body: Path, folder: Optional[Path], given: Optional[Path]) -> Optional[dict]:
    """A verification for the report: read from a file, run now (figures into ``folder``), or none."""
    if given is not None:
        from .io import sha256
        from .report.verify_input import check_matches, read_verification
        study = read_verification(given)
        check_matches(study, analysis, sha256(body), given)
        return study
    if folder is None:
        return None
    from .report.verify_json import study_json
    from .verify.scenes import SceneOptions
    folder.mkdir()
    notes().print(f"verifying {body} by simulation ...", markup=False, highlight=False)
    study, figures = _study(folder, analysis, list(SCENES), analysis.options.situation.tolerance,
                            scene_options=SceneOptions())
    return study_json(study, str(body), figures)


@contextmanager
def _compile_note():
    """A note on a terminal's stderr, as the progress bars appear there, when the simulator's code is compiled
    rather than loaded from its cache (the first run after installing)."""
    if not notes().is_terminal or notes().quiet:
        yield
        return
    from .sim.kernels import on_compile
    with on_compile(lambda: _note("compiling the simulator (the first run after installing: about half a minute; "
                                  "later runs load it from the cache)")):
        yield


def _study(folder: Optional[Path], *args, **kwargs):
    """verify.study.run_study(*args, **kwargs) with a progress bar, and its figures written into ``folder``
    when given (report.verify_figures): (study, paths of the figures)."""
    from .report.progress import step_bar
    from .verify.study import drift_curves, run_study
    with _compile_note(), step_bar(notes()) as progress:
        st = run_study(*args, progress=progress, **kwargs)
        if folder is None:
            return st, ()
        from .report.verify_figures import write_figures
        drift = None if st.stability is None else drift_curves(st.analysis, st.verification.scenes[0])
        return st, write_figures(st, drift, folder, progress)


def _writable(target: Path, name: str | None = None):
    """The format of ``target`` (by ``name`` or suffix), refused when it can only be read."""
    from .io import format_of
    fmt = format_of(target, name)
    if fmt.write is None:
        raise FFRFError(f"{target}: format {fmt.name} can be read but not written")
    return fmt


@app.command()
@handles_errors
def sample(name: str = typer.Argument(..., help=f"One of: {', '.join(SAMPLES)}."),
           output: Path = typer.Option(..., "--output", "-o", help="Body file to write (.ffrf.h5)."),
           refine: int = typer.Option(1, "--refine", help="Element size divided by this (mesh convergence)."),
           force: bool = typer.Option(False, "--force", help="Overwrite OUTPUT.")):
    """Build a sample body from its recipe (docs/samples.md): FE mesh, free-free modes, stress."""
    from .io import write_body
    from .io.atomic import check_target
    from .report.console import shown
    from .samples import sample as make_sample
    check_target(output, force)  # a bad target or suffix fails before the minutes of FE work
    _writable(output)
    start = time.perf_counter()
    body = make_sample(name, refine, report=lambda step: notes().print(
        f"{name}: {step} ({time.perf_counter() - start:.0f} s so far)", highlight=False))
    write_body(body, output, overwrite=force)
    out().print(f"wrote {shown(output)}: {shown(body.name)}, {body.nf} modes, f1 = {body.frequencies_hz[0]:.4g} Hz, "
                f"{body.fe.mesh.n_nodes} nodes")


ModeSet = Annotated[str, typer.Option("--modes", help="all, or advised: the mode set `modes BODY` advises for its "
                                                      "default scenes with the config file's analysis options "
                                                      "(theory 12; kept modes and residual vectors).")]


def _mode_set(body, modes: str, options, source: str):
    """``body`` itself (--modes all) or reduced to its advised mode set (--modes advised, modeset.advised_body)."""
    if modes not in ("all", "advised"):
        raise FFRFError(f"--modes {modes!r}: expected all or advised")
    if modes == "all":
        return body
    from .modeset import advised_body
    return advised_body(run_analysis(body, options), source)


@app.command()
@handles_errors
def convert(source: Path = typer.Argument(..., help="Body file to read."),
            target: Path = typer.Argument(..., help="Body file to write."),
            from_format: Optional[str] = typer.Option(None, "--from", help="Input format name (default: by suffix)."),
            to_format: Optional[str] = typer.Option(None, "--to", help="Output format name (default: by suffix)."),
            force: bool = typer.Option(False, "--force", help="Overwrite TARGET."),
            eigenvalues: Eigenvalues = None, density: Density = None,
            young: Optional[float] = typer.Option(None, "--young", help="meshio meshes: Young's modulus [N/mm^2]; "
                                                                        "with --poisson the static centrifugal "
                                                                        "response and geometric stiffness are "
                                                                        "computed (theory 9, 11)."),
            poisson: Optional[float] = typer.Option(None, "--poisson", help="meshio meshes: Poisson's ratio."),
            units: UnitSystem = None,
            transform: bool = typer.Option(False, "--transform", help="Move the frame to the centre of mass and "
                                                                      "the principal axes (theory 4), as the "
                                                                      "CalculiX and meshio readers do."),
            modes: ModeSet = "all"):
    """Convert a body between formats (see `ffrf-advisor formats`); refuses to overwrite without --force."""
    from .io import write_body
    from .io.atomic import check_target
    from .report.console import shown
    check_target(target, force)
    fmt = _writable(target, to_format)
    body = read_any(source, eigenvalues, density, from_format, young=young, poisson=poisson, units=units)
    if transform:
        body = body.moved_to_principal_frame()
    if modes != "all":
        options = AnalysisArgs(eigenvalues=eigenvalues, density=density, units=units).options(_note)
        body = _mode_set(body, modes, options, str(source))
    write_body(body, target, fmt.name, overwrite=force)
    out().print(f"wrote {shown(target)} ({fmt.name}): {shown(body.name)}, {body.nf} modes"
                + ("" if body.fe is not None else ", invariants only"))


@app.command()
@handles_errors
@analysis_options
def export(body: Path = typer.Argument(..., help="Body file with nodal FE data."),
           output: Path = typer.Option(..., "--output", "-o", help="Directory for the body, the scene and the "
                                                                   "script."),
           solver: str = typer.Option("exudyn", "--solver", help="The multibody code: exudyn (for Adams, "
                                                                 "RecurDyn and Chrono see `settings`)."),
           modes: ModeSet = "all",
           omega0: str = typer.Option("0,0,0", "--omega0", help="The scene's initial angular velocity WX,WY,WZ "
                                                                "[rad/s]."),
           q0: Optional[str] = typer.Option(None, "--q0", help="Initial modal coordinates (body units), or 'qmax'."),
           qd0: Optional[str] = typer.Option(None, "--qd0", help="Initial modal velocities (body units)."),
           t_end: float = typer.Option(0.1, "--t-end", help="End time [s]."),
           step: Optional[float] = typer.Option(None, "--step", help="Fixed RK44 step [s] (default: 0.1 over the "
                                                                     "highest mode's circular frequency)."),
           output_step: Optional[float] = typer.Option(None, "--output-step", help="Sampling interval [s] "
                                                                                   "(default: 500 samples)."),
           force: bool = typer.Option(False, "--force", help="Replace the files in OUTPUT."), *, args: AnalysisArgs):
    """Write the body and a runnable script for another multibody code (docs/export.md): for EXUDYN the data
    of its ObjectFFRFreducedOrder and run_exudyn.py, which runs a free-body scene and writes its trajectory."""
    from .export import exudyn
    from .report.console import shown
    from .sim.model import initial_state
    from .sim.setup import simulation_setup
    from .units import TIME
    if solver != "exudyn":
        raise FFRFError(f"--solver {solver!r}: expected exudyn (export writes EXUDYN bodies; for "
                        f"{', '.join(s for s in SOLVERS if s != 'exudyn')} see `ffrf-advisor settings --solver`)")
    options = args.options(_note)
    b = _mode_set(args.read(body), modes, options, str(body))
    seconds = float(TIME[b.units.time])
    setup = simulation_setup(b, t_end, step if step is not None else exudyn.default_step(b) * seconds,
                             output_step, "rk4")
    y0 = initial_state(b, *_start(b, options, setup.per_second, omega0, q0, qd0))
    scene = exudyn.scene_of(y0, b.nf, setup.t_end, setup.step, setup.output_step)
    paths = exudyn.write(b, scene, output, str(body), force)
    out().print(f"wrote {', '.join(shown(p) for p in paths)}: {shown(b.name)}, {b.nf} modes; run it with "
                f"python {shown(paths[-1])} (needs pip install exudyn)")
    notes().print(f"note: {exudyn.NOTE}", markup=False, highlight=False)


@app.command()
@handles_errors
def augment(body: Path = typer.Argument(..., help="Body file with FE data and material."),
            output: Path = typer.Option(..., "--output", "-o", help="Body file to write (.ffrf.h5)."),
            axes: str = typer.Option("1,2,3", "--axes", help="Principal axes whose static centrifugal deflection "
                                                             "joins the modes, e.g. 3 or 1,2,3."),
            force: bool = typer.Option(False, "--force", help="Overwrite OUTPUT.")):
    """Add the static centrifugal deflections as residual vectors (theory 11): the fix when the kept modes
    cannot carry the widening."""
    from .adequacy import basis_errors
    from .augment import augment as add_residual_vectors, parse_axes
    from .io import write_body
    from .io.atomic import check_target
    from .report.console import shown
    chosen = parse_axes(axes)
    check_target(output, force)
    b = read_any(body)
    new = add_residual_vectors(b, chosen, str(body))
    write_body(new, output, "ffrf-h5", overwrite=force)
    errors = basis_errors(new)
    out().print(f"wrote {shown(output)}: {shown(new.name)}, {b.nf} + {len(chosen)} -> {new.nf} modes; "
                "energy-norm error of the static centrifugal deflection about axes 1, 2, 3: "
                + ", ".join(f"{e:.2g}" for e in errors),
                highlight=False)


@app.command()
@handles_errors
@analysis_options
def modes(body: Path = typer.Argument(..., help="Body file (with FE data: residual vectors and stresses)."),
          scene: Optional[list[str]] = typer.Option(
              None, "--scene", help=f"A scene the body must carry, repeatable: {', '.join(SCENES)} (default: "
                                    "spin-up, torque-pulse, minor-axis)."),
          f_max: Optional[float] = typer.Option(None, "--f-max", min=0.0,
                                                help="Highest frequency the system excites [Hz]."),
          output: Optional[Path] = typer.Option(None, "--output", "-o", help="Write the advised body "
                                                                             "(.ffrf.h5): kept modes and "
                                                                             "residual vectors."),
          force: bool = typer.Option(False, "--force", help="Overwrite OUTPUT."),
          verify: bool = typer.Option(False, "--verify", help="Prove the advised set by simulation against all "
                                                              "modes plus all residual vectors (docs/modes.md)."),
          figures: Optional[Path] = typer.Option(None, "--figures", help="With --verify: directory for the "
                                                                          "mode sets' work-precision chart."),
          as_json: ModesJson = False, *, args: AnalysisArgs):
    """Which modes the scenes need (theory 12): modes in their band or carrying their loads, residual vectors
    where the static error is above the tolerance, the predicted error and the cost saved; --verify proves it."""
    from .io import write_body
    from .io.atomic import check_target
    if unknown := [n for n in scene or () if n not in SCENES]:
        raise FFRFError(f"--scene {unknown[0]!r}: expected one of {', '.join(SCENES)}")
    if output is not None:
        check_target(output, force)
        _writable(output)
    if figures is not None and not verify:
        raise FFRFError("--figures: expected --verify too (the chart is of the simulation)")
    # while the child reads: what follows, and scipy.sparse.linalg for the FE static solves of inertia_loads
    with _importing(".analysis", ".modeset", ".verify.scenes", ".report.modes_out", "scipy.sparse.linalg"):
        read = args.read(body)
    from .modeset import INERTIAL_SCENES, advise_modes, inertia_loads, reduced_body
    from .report.modes_out import modes_json, modes_report, proof_json, proof_report
    names = tuple(scene or INERTIAL_SCENES)
    result = run_analysis(read, args.options(_note))
    loads = inertia_loads(result.body)
    advice = advise_modes(result, names, f_max=f_max, loads=loads)
    if output is not None:
        write_body(reduced_body(result.body, advice, loads, str(body)), output, overwrite=force)
    proof = _mode_set_proof(result, advice, loads, names, figures) if verify else None
    if as_json:
        data = modes_json(advice, result.body.name, str(body), None if output is None else str(output))
        _print_json(data if proof is None else {**data, "verification": proof_json(proof)})
        return
    modes_report(out(), advice, result.body.name)
    if proof is not None:
        proof_report(out(), proof)
    if output is not None:
        notes().print(f"wrote {output}: {advice.size} basis vectors", markup=False, highlight=False)


def _mode_set_proof(result, advice, loads, names, figures: Optional[Path]):
    """modeset_proof.prove with a progress bar, and its chart written into ``figures`` when given."""
    from .report.modes_out import proof_figure
    from .report.progress import step_bar
    from .modeset_proof import prove
    with _compile_note(), step_bar(notes()) as progress:
        proof = prove(result, advice, loads, names, progress)
    if figures is not None:
        figures.mkdir(parents=True, exist_ok=True)
        proof_figure(proof, figures, f"{result.body.name}: mode sets against the reference")
    return proof


@app.command("diff")
@handles_errors
@analysis_options
def diff_command(old: Path = typer.Argument(..., help="The body as it was."),
                 new: Path = typer.Argument(..., help="The body as it is now."),
                 junit: Optional[Path] = typer.Option(None, "--junit", help="Write JUnit XML here."),
                 force: bool = typer.Option(False, "--force", help="Let --junit replace an existing file."),
                 as_json: DiffJson = False, *, args: AnalysisArgs):
    """Are two revisions the same model? Rigid body, frequencies and mode shapes paired by MAC, invariants,
    stale modes (stiffness changed, modes not regenerated), advice; exit 1 when a change exceeds --tolerance."""
    from .io.atomic import atomic_path, check_target
    from .report.diff_out import diff_json, diff_report, write_diff_junit
    from .revision import diff
    if junit is not None:
        check_target(junit, force)
    options = args.options(_note)
    d = diff(args.read(old), args.read(new), options.situation.tolerance, options)
    if junit is not None:
        with atomic_path(junit, overwrite=force) as tmp:
            write_diff_junit(d, str(old), str(new), tmp)
    if as_json:
        _print_json(diff_json(d, str(old), str(new)))
    else:
        diff_report(out(), d, str(old), str(new))
    if not d.same:
        raise typer.Exit(1)


@app.command("schema")
@handles_errors
def schema_command(command: str = typer.Argument(..., help=f"One of: {', '.join(SCHEMA_COMMANDS)}.")):
    """Print the JSON schema of a command's --json output (shipped in the package)."""
    if command not in SCHEMA_COMMANDS:
        raise FFRFError(f"schema {command!r}: expected one of {', '.join(SCHEMA_COMMANDS)}")
    from .schemas import schema_text
    print(schema_text(command), end="")


@app.command("explain")
@handles_errors
def explain(name: Optional[str] = typer.Argument(
        None, help="A term id (cf2), a level (III) or a printed quantity (q_max, s_crit); none: every name.")):
    """What a term id, level or printed quantity means: its entry in the glossary of docs/theory.md (shipped
    with the tool). Example: ffrf-advisor explain cor_coupling"""
    from .glossary import known_names, lookup
    if name is None:
        out().print(", ".join(known_names()), markup=False, highlight=False)
        return
    found = lookup(name)
    if not found:
        raise FFRFError(f"explain {name!r}: expected a term id, level or printed quantity of the glossary "
                        "(`ffrf-advisor explain` lists them; docs/theory.md)")
    for entry in found:
        out().print(entry.text(), markup=False, highlight=False)
    out().print("(docs/theory.md, " + "; ".join(sorted({f"Glossary: {e.table}" for e in found})) + ")",
                markup=False, highlight=False)


@app.command("formats")
def list_formats():
    """The body file formats (name, suffixes, read/write), then the element types each reader takes
    (docs/elements.md)."""
    from .io import formats, support
    rows = [(f.name, " ".join(f.suffixes), "read" + (", write" if f.write else "")) for f in formats()]
    widths = [max(len(r[i]) for r in rows) for i in range(2)]
    for name, suffixes, access in rows:
        out().print(f"{name:{widths[0]}s}  {suffixes:{widths[1]}s}  {access}", markup=False)
    out().print("\nelement types by reader (docs/elements.md):", markup=False, highlight=False)
    for line in support.console_lines(min(out().width, 100)):
        out().print(line, markup=False, highlight=False)


@app.command()
@handles_errors
@analysis_options
def settings(body: Path = typer.Argument(..., help="Body file."),
             solver: str = typer.Option("adams", "--solver", help=f"Solver: {', '.join(SOLVERS)}."),
             as_json: SettingsJson = False, *, args: AnalysisArgs):
    """Solver settings for the advised term set (Adams, RecurDyn, EXUDYN, Chrono; docs/solvers.md), with how
    sure each mapping is and the terms the solver cannot drop or cannot add."""
    from .report.console import settings_report
    from .solver_settings import SETTINGS
    if solver not in SOLVERS:
        raise FFRFError(f"--solver {solver!r}: expected one of {', '.join(SOLVERS)}")
    result = run_analysis(args.read(body, load_fe="summary"), args.options(_note))
    data = {"schema_version": 2, "level": result.advice.level, "terms": list(result.advice.terms),
            **SETTINGS[solver](result.advice.terms), "warnings": list(result.advice.warnings)}
    if as_json:
        _print_json(data)
        return
    settings_report(out(), err(), data)


Terms = Annotated[str, typer.Option("--terms", help="I, II, III, IV, full, advised, or a comma list of term ids.")]
EXIT_DIVERGED = 3


@app.command()
@handles_errors
@analysis_options
def simulate(body: Path = typer.Argument(..., help="Body file."), terms: Terms = "full",
             omega0: str = typer.Option("0,0,0", "--omega0", help="Initial body angular velocity WX,WY,WZ [rad/s]."),
             q0: Optional[str] = typer.Option(None, "--q0", help="Initial modal coordinates (body units), or 'qmax'."),
             qd0: Optional[str] = typer.Option(None, "--qd0", help="Initial modal velocities (body units)."),
             damping: float = typer.Option(0.0, "--damping", help="Modal damping ratio of every mode."),
             t_end: float = typer.Option(..., "--t-end", help="End time [s]."),
             integrator: str = typer.Option("dop853", "--integrator", help=f"One of {', '.join(INTEGRATORS)}."),
             step: Optional[float] = typer.Option(None, "--step", help="Step [s] of the fixed-step methods."),
             rtol: float = typer.Option(1e-8, "--rtol", help="Relative tolerance of the adaptive methods."),
             atol: float = typer.Option(1e-10, "--atol", help="Absolute tolerance of the adaptive methods."),
             output_step: Optional[float] = typer.Option(None, "--output-step", help="Sampling interval [s]."),
             output: Optional[Path] = typer.Option(None, "--output", "-o", help="Trajectory file (.csv or .h5)."),
             force: bool = typer.Option(False, "--force", help="Overwrite OUTPUT."),
             as_json: SimulateJson = False, *, args: AnalysisArgs):
    """Simulate the free body with a term set (theory sections 5, 10); exit 3 when the integration fails."""
    from .io import sha256
    from .io.atomic import not_an_input
    from .names import FIXED
    from .report.console import simulation_report
    from .report.progress import progress_bar
    from .sim.integrate import integrate
    from .sim.model import build_model, initial_state
    from .sim.output import check_output, summary, write_trajectory
    from .sim.setup import check_tolerances, simulation_setup
    from .terms import parse_terms
    if output is not None:
        check_output(output, force)
    b = args.read(body)
    options = args.options(_note)
    if output is not None:
        not_an_input(output)  # before the integration, not after it
    chosen = run_analysis(b, options).advice.terms if terms.strip() == "advised" else parse_terms(terms)
    model = build_model(b, chosen, damping)
    setup = simulation_setup(b, t_end, step, output_step, integrator)
    if integrator not in FIXED:
        check_tolerances(rtol, atol)
    y0 = initial_state(model, *_start(b, options, setup.per_second, omega0, q0, qd0))
    with _compile_note(), progress_bar(notes()) as progress:
        run = integrate(model, y0, setup.t_end, integrator, setup.step, rtol, atol, setup.output_step,
                        progress=progress)
    if output is not None:
        write_trajectory(output, model, run, b.units, {"body": b.name, "body_file": str(body),
                                                       "body_sha256": sha256(body)}, force)
    result = summary(model, run, str(b.units))
    if as_json:
        _print_json(result)
    else:
        simulation_report(out(), result, output)
    if run.failed:
        raise typer.Exit(EXIT_DIVERGED)


def _start(b, options, per_second: float, omega0: str, q0: Optional[str], qd0: Optional[str]):
    """--omega0 [rad/s], --q0 (numbers or 'qmax', theory 6) and --qd0 as (w0, q0, qd0) in the body's units,
    checked (sim.setup.check_initial_state)."""
    import numpy as np
    from .sim.setup import check_initial_state, q_max_of
    per_mode = f"one per mode of the body's {b.nf}"
    start = (q_max_of(b, options.amplitudes) if q0 is not None and q0.strip() == "qmax"
             else numbers("--q0", q0, b.nf, per_mode))
    w0, v0 = numbers("--omega0", omega0, 3, "WX,WY,WZ"), numbers("--qd0", qd0, b.nf, per_mode)
    check_initial_state(b, w0, start, None if v0 is None else np.asarray(v0) * per_second)
    return np.array(w0) * per_second, () if start is None else start, v0 or ()


@app.command("verify")
@handles_errors
@analysis_options
def verify_command(body: Path = typer.Argument(..., help="Body file."),
                   scene: Optional[list[str]] = typer.Option(None, "--scene",
                                                             help=f"Scene(s): {', '.join(SCENES)} (default all)."),
                   integrator: str = typer.Option("dop853", "--integrator", help=f"One of {', '.join(INTEGRATORS)}."),
                   step: Optional[float] = typer.Option(None, "--step", help="Step [s] of a fixed-step integrator."),
                   rtol: float = typer.Option(1e-8, "--rtol", help="Relative tolerance of an adaptive integrator."),
                   repeats: int = typer.Option(1, "--repeat", help="Runs per term set, timed serially, the minimum counting (1: costs from each set's compiled seconds per evaluation)."),
                   axis: Optional[int] = typer.Option(None, "--axis", help="Principal axis of the scenes (1-3; "
                                                                           "default: each rigidly stable principal "
                                                                           "axis)."),
                   criterion: str = typer.Option("response", "--criterion",
                                                 help="Judge by response errors (frequencies, means, oscillation "
                                                      "sizes, peak stress) or by trajectory errors."),
                   output: Optional[Path] = typer.Option(None, "--output", "-o", help="Directory for the figures."),
                   quick: bool = typer.Option(False, "--quick", help="The scenes and the verdict only: no "
                                              "work-precision, stability or Campbell studies."),
                   jobs: int = typer.Option(1, "--jobs", "-j", min=1, help="Local processes for the scenes' "
                                            "runs (each run's repeats stay serial; runs share the cores)."),
                   fail_on: str = typer.Option("never", "--fail-on", metavar="never|unsafe|conservative",
                                               help="Exit 1 when the verdict is unsafe (or no verdict), or also "
                                                    "when it is conservative."),
                   as_json: VerifyJson = False, *, args: AnalysisArgs):
    """Verify the advice by simulation: scenes, term sets, errors, cost, stability, Campbell, figures."""
    from .report.console import verification_report
    from .report.verify_json import study_json
    from .sim.setup import simulation_setup
    from .verify.checks import FAILING, check_verify_options
    from .verify.scenes import SceneOptions
    names = list(scene or SCENES)
    options = args.options(_note)
    tolerance = options.situation.tolerance
    check_verify_options(names, tolerance, integrator, step, rtol, repeats, output, criterion, fail_on)
    b = args.read(body, load_fe="summary")  # the analysis and the simulator need no nodal data
    result = run_analysis(b, options)
    h = None if step is None else simulation_setup(b, 1.0, step, None, integrator).step
    st, figures = _study(output, result, names, tolerance, integrator, h, rtol, repeats, SceneOptions(axis=axis),
                         criterion, quick, jobs)
    data = study_json(st, str(body), figures)
    if as_json:
        _print_json(data)
    else:
        verification_report(out(), data)
    if st.verification.verdict.verdict in FAILING[fail_on]:
        raise typer.Exit(1)


# The commands above, built when looked up (LazyCommands) instead of all of them before parsing.
COMMANDS = {info.name or typer.main.get_command_name(info.callback.__name__): info for info in app.registered_commands}
app.registered_commands = []
