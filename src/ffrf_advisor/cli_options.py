"""The one set of reading and analysis options of every command that analyses a body (issue 25): typer
annotations, the AnalysisArgs dataclass built from them, the decorator that gives a command the set, and
their parsing into analysis.Options. No ``from __future__ import annotations`` (typer reads annotations)."""
import functools
import inspect
import math
from collections.abc import Callable
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Optional

import typer

from .errors import FFRFError

if TYPE_CHECKING:
    from .situation import Options

Speed = Annotated[Optional[str], typer.Option("--speed", help="Operating angular speed: 314rad/s, 3000rpm, 50Hz.")]
FSys = Annotated[Optional[float], typer.Option("--f-sys", help="First frequency of the assembled system [Hz].")]
Connection = Annotated[Optional[str], typer.Option("--connection", help="free | soft | stiff (default free).")]
Widening = Annotated[Optional[bool], typer.Option("--widening/--no-widening",
                                                  help="Whether widening / stress recovery matters (default: from stress).")]
SigmaAllow = Annotated[Optional[float], typer.Option("--sigma-allow", help="Allowable stress [N/mm^2] (500).")]
QCap = Annotated[Optional[float], typer.Option("--q-cap", help="Cap of q_max,1 in t-mm units (1).")]
DeflCap = Annotated[Optional[float], typer.Option("--deflection-cap", help="Largest deflection / largest dimension.")]
QMax = Annotated[Optional[str], typer.Option("--q-max", help="q_max per mode: comma list or a file of numbers.")]
NRatio = Annotated[Optional[int], typer.Option("--n-ratio", help="Modes used for the norm ratios (min(10, nf)).")]
Threshold = Annotated[Optional[list[str]], typer.Option("--threshold", help="Override a threshold: NAME=VALUE.")]
Config = Annotated[Optional[Path], typer.Option("--config", help="TOML config (default ffrf-advisor.toml or pyproject).")]
Tolerance = Annotated[Optional[float], typer.Option(
    "--tolerance", help="Largest relative response error the advised set may make (0.01; docs/advice.md).")]
Rules = Annotated[Optional[str], typer.Option(
    "--rules", help="predicted (default: from predicted response errors), thresholds (theory 8's rules with "
                    "--threshold) or paper (the paper's rules, 5 % and 1 %).")]
Excitation = Annotated[Optional[str], typer.Option(
    "--excitation", help="vibration (default: the modes may vibrate at q_max) or inertial (only the body's own "
                         "rigid motion drives them: spin-up, torque pulses; docs/advice.md).")]
SpeedRange = Annotated[Optional[str], typer.Option(
    "--speed-range", help="Advise for a range of speeds: LOW..HIGH, e.g. 0..3000rpm (instead of --speed).")]


SpinAxis = Annotated[Optional[str], typer.Option(
    "--spin-axis", help="Spin axis: principal axis 1, 2, 3 or a body-frame vector X,Y,Z (default: each, the worst decides).")]
Eigenvalues = Annotated[Optional[str], typer.Option(
    "--eigenvalues", help="meshio meshes: eigenvalues [1/s^2] as a comma list or a file (else field data).")]
Density = Annotated[Optional[float], typer.Option(
    "--density", help="meshio meshes: density [t/mm^3] (else field data).")]
UnitSystem = Annotated[Optional[str], typer.Option(
    "--units", help="ANSYS results without /UNITS: MAPDL's SI, MKS, uMKS, CGS, MPA, BFT, BIN or e.g. t-mm-N-s "
                    "(checked against the materials; else the one system they fit).")]

@dataclass(frozen=True)
class AnalysisArgs:
    """The one set of reading and analysis options, the same on every command that analyses a body, as the
    command line gave them (None: config file or default); each field's annotation is its typer option."""
    speed: Speed = None
    speed_range: SpeedRange = None
    f_sys: FSys = None
    connection: Connection = None
    widening: Widening = None
    sigma_allow: SigmaAllow = None
    q_cap: QCap = None
    deflection_cap: DeflCap = None
    q_max: QMax = None
    n_ratio: NRatio = None
    threshold: Threshold = None
    config: Config = None
    spin_axis: SpinAxis = None
    tolerance: Tolerance = None
    rules: Rules = None
    excitation: Excitation = None
    eigenvalues: Eigenvalues = None
    density: Density = None
    units: UnitSystem = None

    def options(self, note: Callable[[str], None]) -> "Options":
        """situation.Options from defaults < config file < command line; ``note`` tells how a bare speed
        was read."""
        return build_options(self, note)

    def read(self, path: Path, **how):
        """The body at ``path``, with the reader options (--eigenvalues, --density, --units)."""
        return read_any(path, self.eigenvalues, self.density, units=self.units, **how)

    def mesh_options(self) -> dict:
        return mesh_options(self.eigenvalues, self.density, units=self.units)


ANALYSIS_OPTIONS = {f.name: f.type for f in fields(AnalysisArgs)}  # name -> typer option


def analysis_options(fn):
    """Give the command the one set of reading and analysis options: typer sees ANALYSIS_OPTIONS as
    keyword options after the command's own, the command receives them as ``args: AnalysisArgs``."""
    signature = inspect.signature(fn)
    own = [p for p in signature.parameters.values() if p.name != "args"]
    added = [inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=None, annotation=kind)
             for name, kind in ANALYSIS_OPTIONS.items()]

    @functools.wraps(fn)
    def wrapper(*positional, **named):
        given = AnalysisArgs(**{name: named.pop(name) for name in ANALYSIS_OPTIONS})
        return fn(*positional, args=given, **named)
    wrapper.__signature__ = signature.replace(parameters=own + added)
    return wrapper


def is_file(text: str) -> bool:
    """Whether ``text`` names an existing regular file (a long list of numbers is not a path: no OSError)."""
    try:
        return Path(text).is_file()
    except (OSError, ValueError):
        return False


def numbers(option: str, text: str | None, count: int | None = None, what: str = ""):
    """Finite numbers from a comma/blank list or a file of them, exactly ``count`` (``what`` they are) where
    given: a list shorter than the modes was padded with zeros; None stays None."""
    if text is None:
        return None
    source = Path(text).read_text() if is_file(text) else text
    try:
        values = tuple(float(x) for x in source.replace(",", " ").split())
    except ValueError:
        values = (math.nan,)
    if not all(map(math.isfinite, values)):
        raise FFRFError(f"{option}: expected finite numbers separated by commas or blanks (or a file of them), "
                        f"got {text[:80]!r}")
    if count is not None and len(values) != count:
        raise FFRFError(f"{option}: expected {count} numbers ({what}), got {len(values)}")
    return values


def mesh_options(eigenvalues: str | None, density: float | None, young: float | None = None,
                 poisson: float | None = None, units: str | None = None) -> dict:
    """--eigenvalues/--density/--young/--poisson (meshio meshes) and --units (ANSYS) as reader options."""
    return {k: v for k, v in (("eigenvalues", numbers("--eigenvalues", eigenvalues)), ("density", density),
                              ("young", young), ("poisson", poisson), ("units", units)) if v is not None}


def read_any(path: Path, eigenvalues: str | None = None, density: float | None = None, fmt: str | None = None,
             load_fe: bool | str = True, young: float | None = None, poisson: float | None = None,
             units: str | None = None):
    """Read any format with its reader options (io.check_reader_options); ``load_fe`` "summary": what the
    analysis needs of the nodal data (io.ffrf_h5.read)."""
    from .io import check_reader_options, read_body
    given = mesh_options(eigenvalues, density, young, poisson, units)
    check_reader_options(path, given, fmt)
    return read_body(path, fmt, load_fe=load_fe, **given)


def thresholds(items: list[str] | None, base: dict) -> dict:
    from .situation import THRESHOLDS
    out = dict(base)
    for item in items or []:
        name, _, value = item.partition("=")
        if name not in THRESHOLDS:
            raise FFRFError(f"--threshold {item!r}: unknown name; expected one of {', '.join(THRESHOLDS)}")
        try:
            out[name] = float(value)
        except ValueError:
            raise FFRFError(f"--threshold {item!r}: expected NAME=NUMBER") from None
    return out


def spin_axis(text) -> tuple[tuple[float, float, float] | None, int | None]:
    """(body-frame vector, principal axis): '1', '2', '3' are principal axes of I0, 'X,Y,Z' a direction."""
    if text is None:
        return None, None
    if str(text).strip() in ("1", "2", "3"):
        return None, int(str(text).strip())
    if isinstance(text, (list, tuple)):
        text = ",".join(str(x) for x in text)
    values = numbers("--spin-axis", str(text))
    if values is None or len(values) != 3 or not all(map(math.isfinite, values)) or not any(values):
        raise FFRFError(f"--spin-axis {text!r}: expected 1, 2, 3 or three finite numbers X,Y,Z, not all zero")
    return tuple(values), None


def speed_range(text: str | None) -> tuple[float, float] | None:
    """'A..B' with speeds as --speed takes them (e.g. 0..3000rpm: the unit of B applies to a bare A)."""
    if text is None:
        return None
    low, sep, high = str(text).partition("..")
    if not sep:
        raise FFRFError(f"--speed-range {text!r}: expected LOW..HIGH, e.g. 0..3000rpm")
    from .situation import parse_speed
    top = parse_speed(high)
    unit = high.strip().lstrip("+-0123456789.eE").strip()
    bottom = parse_speed(low if not is_number(low) or not unit else low.strip() + unit)
    if bottom > top:
        raise FFRFError(f"--speed-range {text!r}: expected LOW <= HIGH")
    return bottom, top


def is_number(text) -> bool:
    try:
        float(str(text))
    except ValueError:
        return False
    return True


def build_options(given: AnalysisArgs, note: Callable[[str], None]) -> "Options":
    """Options from defaults < config file < command line; ``note`` tells how a bare speed was read."""
    from .situation import AmplitudeOptions, Options, Situation, check_options, load_config, parse_speed
    cfg, config_file = load_config(given.config)
    pick = lambda key, default=None: (getattr(given, key) if getattr(given, key) is not None  # noqa: E731
                                      else cfg.get(key, default))
    speed = pick("speed")
    amp = AmplitudeOptions(sigma_allow=pick("sigma_allow", AmplitudeOptions.sigma_allow),
                           q_cap=pick("q_cap", AmplitudeOptions.q_cap),
                           deflection_cap=pick("deflection_cap"), q_max=numbers("--q-max", given.q_max))
    w_range = speed_range(pick("speed_range"))
    if w_range is not None and speed is not None:
        raise FFRFError("--speed and --speed-range: expected one of them, got both")
    w_op = w_range[1] if w_range is not None else (None if speed is None else parse_speed(speed))
    if w_op and w_range is None and is_number(speed):  # 0 is 0 in every unit
        note(f"note: speed {speed} has no unit: read as {w_op:g} rad/s (write e.g. 3000rpm or 50Hz)")
    vector, principal = spin_axis(pick("spin_axis"))
    situation = Situation(w_op=w_op, f_sys=pick("f_sys"), connection=pick("connection", "free"),
                          widening=given.widening, thresholds=thresholds(given.threshold, cfg.get("thresholds", {})),
                          spin_axis=vector, principal_axis=principal, tolerance=pick("tolerance", Situation.tolerance),
                          rules=pick("rules", Situation.rules), speed_range=w_range,
                          excitation=pick("excitation", Situation.excitation), config=config_file)
    options = Options(amp, situation, pick("n_ratio"))
    check_options(options)
    return options
