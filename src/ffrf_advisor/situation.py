"""The options of an analysis: the operating point and what the advice needs beyond the body (theory
section 8; thresholds, speeds, config files), and the amplitude options (theory section 6).

Beside the readers it imports nothing heavy (numpy only where an axis is computed): a command builds and
checks its options before it reads a body and imports the analysis while the reading child parses
(gate.AFTER_READ). Their users (guidelines, amplitudes, analysis, predict) take them from here.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from .errors import FFRFError
from .io.atomic import note_input
from .units import MAX_SPEED
from .values import is_number

if TYPE_CHECKING:
    import numpy as np

    from .body import FlexibleBody

SIGMA_ALLOW = 500.0  # N/mm^2, the paper's allowable stress
Q_CAP = 1.0          # in t-mm units: sqrt(t) * mm
EXCITATIONS = ("vibration", "inertial")  # what drives the modes (predict; docs/advice.md)

THRESHOLDS = {
    "widening_stress": 5e-4,   # rule II: centrifugal stress / sigma_allow (docs/verification.md)
    "dI_L": 0.005,             # rule III
    "dI_Q": 0.005,
    "dI_fT": 0.005,
    "dI_Tf": 0.005,
    "r_cf2": 0.005,             # rule III, cf2: response measure r_cf2 at w_op (theory 7)
    "speed_ratio": 0.1,         # rule IV: w_op / (2 pi f_sys)
    "r_cor": 1e-4,              # rule IV, cor_quad + cor_coupling: r_cor at w_op (theory 7; docs/verification.md)
    "softening_warning": 0.5,   # warn when w_op / s_crit exceeds this
    "basis_error": 0.1,         # warn when the kept modes miss the static centrifugal deflection (theory 11)
}
CONNECTIONS = ("free", "soft", "stiff")


PAPER_THRESHOLDS = {"dI_L": 0.05, "dI_Q": 0.05, "dI_fT": 0.05, "dI_Tf": 0.05, "r_cf2": 0.01, "r_cor": 0.01}
# advice from predicted response errors (docs/advice.md); the rules of theory 8 with the thresholds below (the
# tool's advice before predicted errors, tuned on the six samples); the same rules with the paper's thresholds
RULE_SETS = ("predicted", "thresholds", "paper")


@dataclass(frozen=True)
class Situation:
    """What the advisor needs beyond the body. Speeds in rad/s, frequencies in Hz (per second).

    ``spin_axis`` is a body-frame direction, ``principal_axis`` (1-3) a principal axis of I0; neither: each
    principal axis, the worst decides. ``speed_range`` (low, high) replaces ``w_op`` by the range's top
    and the speeds below it; ``excitation`` says what drives the modes (EXCITATIONS; docs/advice.md)."""

    w_op: float | None = None
    f_sys: float | None = None
    connection: str = "free"
    widening: bool | None = None  # None: decided from the centrifugal stress
    thresholds: dict[str, float] = field(default_factory=dict)
    spin_axis: tuple[float, float, float] | None = None
    principal_axis: int | None = None
    tolerance: float = 0.01
    rules: str = "predicted"
    speed_range: tuple[float, float] | None = None
    excitation: str = "vibration"
    config: str | None = None  # the config file applied, named in the operating point

    def axes(self, body: FlexibleBody | None = None) -> list[np.ndarray]:
        """The spin axes evaluated, as body-frame unit vectors: the given one, or the principal axes."""
        import numpy as np
        if self.spin_axis is not None:
            a = np.asarray(self.spin_axis, float)
            return [a / np.linalg.norm(a)]
        axes = list(np.eye(3)) if body is None else list(principal_directions(body.I0).T)
        return axes if self.principal_axis is None else [axes[self.principal_axis - 1]]

    def threshold(self, name: str) -> float:
        base = {**THRESHOLDS, **PAPER_THRESHOLDS} if self.rules == "paper" else THRESHOLDS
        return {**base, **self.thresholds}[name]

    @property
    def at_rest(self) -> bool:
        """No operating speed, or speed 0: only what holds at rest is evaluated."""
        return not self.w_op


def principal_directions(I0: np.ndarray) -> np.ndarray:
    """Principal axes of I0 as columns, numbered and signed after the body axes they lie closest to (the
    identity for a body in its principal frame, theory 4)."""
    import numpy as np
    _, V = np.linalg.eigh(0.5 * (I0 + I0.T))
    order = [int(i) for i in np.argmax(np.abs(V), axis=1)]
    if len(set(order)) < 3:
        order = [0, 1, 2]
    V = V[:, order]
    return V * np.where(np.diag(V) < 0, -1.0, 1.0)


@dataclass(frozen=True)
class AmplitudeOptions:
    """sigma_allow in N/mm^2 and q_cap in t-mm units (both converted to the body's units)."""

    sigma_allow: float = SIGMA_ALLOW
    q_cap: float = Q_CAP
    deflection_cap: float | None = None  # largest nodal deflection / largest dimension of mode 1
    q_max: tuple[float, ...] | None = None  # given per mode, body units


@dataclass(frozen=True)
class Options:
    """One analysis's options: the amplitudes', the situation, and how many modes the ratios take (theory 7;
    None: significance.N_RATIO, or all where fewer)."""

    amplitudes: AmplitudeOptions = field(default_factory=AmplitudeOptions)
    situation: Situation = field(default_factory=Situation)
    n_ratio: int | None = None


def _number(name: str, value, positive: bool) -> None:
    """``value`` must be a finite number, positive (or non-negative): one line naming the option otherwise."""
    ok = is_number(value) and (value > 0 if positive else value >= 0)
    if not ok:
        raise FFRFError(f"{name} {value!r}: expected a finite {'positive' if positive else 'non-negative'} number")


def check_options(options: Options) -> None:
    """Every analysis option finite and in range (theory section 8): NaN or inf would switch rules off."""
    amp, sit = options.amplitudes, options.situation
    _number("--sigma-allow", amp.sigma_allow, True)
    _number("--q-cap", amp.q_cap, True)
    if amp.deflection_cap is not None:
        _number("--deflection-cap", amp.deflection_cap, True)
    if sit.w_op is not None:
        _number("--speed", sit.w_op, False)
        if sit.w_op > MAX_SPEED:
            raise FFRFError(f"--speed {sit.w_op:g} rad/s: expected at most {MAX_SPEED:g} rad/s "
                            f"({MAX_SPEED / (2 * math.pi):.3g} Hz, far above any structure's modes)")
    if sit.f_sys is not None:
        _number("--f-sys", sit.f_sys, True)
    n = options.n_ratio
    if n is not None and (not is_number(n, integer=True) or n < 1):
        raise FFRFError(f"--n-ratio {options.n_ratio!r}: expected a whole number >= 1")
    _number("--tolerance", sit.tolerance, True)
    if sit.rules not in RULE_SETS:
        raise FFRFError(f"--rules {sit.rules!r}: expected one of {', '.join(RULE_SETS)}")
    if sit.excitation not in EXCITATIONS:
        raise FFRFError(f"--excitation {sit.excitation!r}: expected one of {', '.join(EXCITATIONS)}")
    check_thresholds(sit.thresholds, "--threshold")


_SPEED = re.compile(r"^\s*([-+0-9.eE]+)\s*(rad/s|rpm|hz|)\s*$", re.IGNORECASE)


def parse_speed(text: str) -> float:
    """Angular speed in rad/s from '3000rpm', '50Hz', '314rad/s' or a bare number (rad/s)."""
    m = _SPEED.match(str(text))
    try:
        value = float(m.group(1)) if m else math.nan
    except ValueError:
        value = math.nan
    if not m or not math.isfinite(value) or value < 0:
        raise FFRFError(f"speed {text!r}: expected a non-negative number with rad/s, rpm or Hz, e.g. 3000rpm")
    unit = m.group(2).lower()
    return value * {"": 1.0, "rad/s": 1.0, "rpm": 2 * math.pi / 60, "hz": 2 * math.pi}[unit]


def load_config(path: Path | None = None, cwd: Path = Path(".")) -> tuple[dict, str | None]:
    """Options from ``path``, else ``ffrf-advisor.toml`` or ``[tool.ffrf-advisor]`` of pyproject.toml in cwd;
    and the file applied (None: none, or a pyproject.toml without the table)."""
    if path is None:
        if (cwd / "ffrf-advisor.toml").exists():  # a FIFO or directory there is refused, not ignored
            path = cwd / "ffrf-advisor.toml"
        elif (cwd / "pyproject.toml").exists():  # a FIFO, device or directory by that name is refused too
            table = _toml(cwd / "pyproject.toml", TOOL_TABLE).get("tool", {}).get("ffrf-advisor")
            if table is None:
                return {}, None
            return _validated(table, cwd / "pyproject.toml"), f"{cwd / 'pyproject.toml'} [tool.ffrf-advisor]"
        else:
            return {}, None
    return _validated(_toml(path), path), str(path)


CONFIG_BYTES = 1 << 20  # a config file is a regular file of at most 1 MiB
# Where pyproject.toml's text may hold [tool.ffrf-advisor]: "tool" dotted with "ffrf-advisor" in a header or key
# (any quotes and spaces), a [tool] header, a tool = inline table, or an escape (\u, \U) in a quoted key
TOOL_TABLE = re.compile(rb"""tool["']?\s*\.\s*["']?ffrf-advisor"""
                        rb"""|^\s*\[\s*["']?tool["']?\s*\]|^\s*["']?tool["']?\s*=|\\[uU]""", re.MULTILINE)


def _toml(path: Path, may_hold: re.Pattern | None = None) -> dict:
    """The TOML of a config file: a regular file of at most CONFIG_BYTES (a device, FIFO or directory is
    refused before it is opened for reading); {} where ``may_hold`` finds nothing in the text (TOOL_TABLE: most
    projects' pyproject.toml holds no table of this tool and is then not parsed; tomllib's import and parse
    took 10 ms of start-up)."""
    try:
        if not Path(path).is_file():
            kind = "a directory" if Path(path).is_dir() else "not found" if not Path(path).exists() else \
                "a special file (device, FIFO or socket)"
            raise FFRFError(f"{path}: config: expected a regular file, got {kind}")
        with open(path, "rb") as f:
            data = f.read(CONFIG_BYTES + 1)
    except OSError as e:
        raise FFRFError(f"{path}: config: expected readable TOML, got {e}") from None
    if len(data) > CONFIG_BYTES:
        raise FFRFError(f"{path}: config: expected at most 1 MiB, got more")
    note_input(path)
    if may_hold is not None and not may_hold.search(data):
        return {}
    import tomllib  # here: most runs read no config file (4 ms of start-up)
    try:
        return tomllib.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as e:
        raise FFRFError(f"{path}: config: expected readable TOML, got {e}") from None


CONFIG_KEYS = {"sigma_allow", "q_cap", "deflection_cap", "n_ratio", "connection", "speed", "f_sys", "thresholds",
               "spin_axis", "tolerance", "rules", "speed_range", "excitation"}


def _validated(cfg: dict, path: Path) -> dict:
    unknown = set(cfg) - CONFIG_KEYS
    if unknown:
        raise FFRFError(f"{path}: config: unknown key(s) {sorted(unknown)}; expected {sorted(CONFIG_KEYS)}")
    thresholds = cfg.get("thresholds", {})
    if not isinstance(thresholds, dict):
        raise FFRFError(f"{path}: config thresholds: expected a table [thresholds] of NAME = NUMBER, "
                        f"got {thresholds!r}")
    bad = set(thresholds) - set(THRESHOLDS)
    if bad:
        raise FFRFError(f"{path}: config thresholds: unknown {sorted(bad)}; expected {sorted(THRESHOLDS)}")
    check_thresholds(thresholds, f"{path}: config thresholds.")
    return cfg


def check_thresholds(thresholds: dict, source: str) -> None:
    """Every threshold a finite non-negative number (a NaN threshold would switch its rule off)."""
    for key, value in thresholds.items():
        if not is_number(value) or value < 0:
            raise FFRFError(f"{source}{'' if source.endswith('.') else ' '}{key}: expected a finite non-negative "
                            f"number, got {value!r}")
