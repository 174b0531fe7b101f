"""Scenes: the least that shows an effect, with defaults from the body and the analysis (theory section 10, docs/scenes.md).

Every scene is a free body started from a state, possibly driven by a
torque or by a prescribed rotation, for a duration long enough for its
effect (at least a few periods of the first mode and of the rotation).
Speeds are in rad per body time unit, durations in body time units.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..analysis import Analysis
from ..errors import FFRFError
from ..names import SCENES
from ..predict import most_mixed_mode, response_time
from ..sim.loads import LoadProgram, Loads
from ..units import TIME

ABOUT_AN_AXIS = ("free-spin", "mode-release", "spin-up", "torque-pulse")  # about each axis of scene_axes


@dataclass(frozen=True)
class Scene:
    """A scene: start state, drive, modal damping ratio and duration; ``axis`` is 0-based."""

    name: str
    axis: int
    duration: float
    omega0: np.ndarray
    q0: np.ndarray
    qd0: np.ndarray
    loads: Loads = field(default_factory=Loads)
    damping: float = 0.0
    speed: float = 0.0
    text: str = ""

    @property
    def label(self) -> str:
        return f"{self.name} (axis {self.axis + 1})"

    @property
    def prescribed(self) -> bool:
        return self.loads.prescribed is not None

    @property
    def vibrating(self) -> bool:
        """Whether the modes start deflected or moving (else only the rigid motion drives them)."""
        return bool(np.any(self.q0) or np.any(self.qd0))


@dataclass(frozen=True)
class SceneOptions:
    """Settable parameters (None: derived from the body and the analysis). Speeds in rad/s, times in s."""

    axis: int | None = None         # 1-based principal axis
    speed: float | None = None      # the spin; default w_op, else a tenth of the smallest s_crit
    duration: float | None = None
    ramp: float | None = None       # spin-up time T
    pulse: float | None = None      # torque-pulse duration
    damping: float | None = None    # minor-axis modal damping ratio (0.02)


def _first_period(a: Analysis) -> float:
    return 1.0 / float(a.body.frequencies_hz[0])


def default_speed(a: Analysis) -> float:
    """The scenes' spin (body units): w_op when positive; at w_op = 0 a small spin, a hundredth of the
    smallest s_crit (the body is at rest but for what a torque pulse gives it); without w_op a tenth of it;
    2 pi f1 / 10 (or / 100) when the body has no finite s_crit."""
    per_s = float(TIME[a.body.units.time])
    w_op = a.options.situation.w_op
    if w_op:
        return w_op * per_s
    share = 0.01 if w_op == 0 else 0.1
    s_crit = a.significance.s_crit
    if s_crit is not None and np.isfinite(s_crit).any():
        return share * float(np.min(s_crit))
    return share * 2 * np.pi * float(a.body.frequencies_hz[0])


def stable_axes(a: Analysis) -> tuple[int, int]:
    """(major, minor) principal axes: rigid spin about them is stable without dissipation."""
    I = np.diag(a.body.I0)
    return int(np.argmax(I)), int(np.argmin(I))


def deformation_axis(a: Analysis) -> int:
    """Of the two stable axes, the one about which the inertia measures (dI_L, dI_Q, dI_fT) are largest."""
    sig = a.significance
    total = np.zeros(3)
    for m in (sig.dI_L, sig.dI_Q, sig.dI_fT):
        if m is not None:
            total += m.max(axis=1)
    major, minor = stable_axes(a)
    return major if total[major] >= total[minor] else minor


def worst_signs(a: Analysis, q: np.ndarray) -> np.ndarray:
    """q with the sign pattern of the worst Coriolis ratio of theory section 7 (found by significance)."""
    signs = a.significance.signs
    return q if signs is None else q * signs


def _seconds(a: Analysis, value: float | None) -> float | None:
    return None if value is None else value / float(TIME[a.body.units.time])


def _axis(a: Analysis, opts: SceneOptions, default: int) -> int:
    if opts.axis is None:
        return default
    if opts.axis not in (1, 2, 3):
        raise FFRFError(f"--axis {opts.axis}: expected a principal axis 1, 2 or 3")
    return opts.axis - 1


def free_spin(a: Analysis, opts: SceneOptions = SceneOptions()) -> Scene:
    """Spin about a principal axis, modes initially at q_max in the worst sign pattern."""
    k = _axis(a, opts, deformation_axis(a))
    s = opts.speed * TIME[a.body.units.time] if opts.speed is not None else default_speed(a)
    w = s * np.eye(3)[k]
    q0 = worst_signs(a, np.array(a.amplitudes.q_max))
    T = _seconds(a, opts.duration) or response_time(1 / _first_period(a), s)
    return Scene("free-spin", k, T, w, q0, np.zeros(a.body.nf), speed=s,
                 text="free spin, modes at q_max (worst sign pattern)")


def mode_release(a: Analysis, opts: SceneOptions = SceneOptions()) -> Scene:
    """Steady spin about a principal axis, one mode released from its q_max, the others at rest (a knock on the
    spinning body): the mode whose stress the gyroscopic coupling moves most into the others
    (``predict.most_mixed_mode``), the single-mode case the advice's mixing prediction claims."""
    k = _axis(a, opts, deformation_axis(a))
    s = opts.speed * TIME[a.body.units.time] if opts.speed is not None else default_speed(a)
    q_max = np.asarray(a.amplitudes.q_max)
    p = most_mixed_mode(a.body, np.eye(3)[k], s, q_max)
    q0 = np.zeros(a.body.nf)
    q0[p] = q_max[p]
    T = _seconds(a, opts.duration) or response_time(1 / _first_period(a), s)
    return Scene("mode-release", k, T, s * np.eye(3)[k], q0, np.zeros(a.body.nf), speed=s,
                 text=f"steady spin, mode {p + 1} released from q_max")


def spin_up(a: Analysis, opts: SceneOptions = SceneOptions()) -> Scene:
    """Rotation prescribed about a body axis from rest to the speed over the ramp time, then held."""
    k = _axis(a, opts, deformation_axis(a))
    s = opts.speed * TIME[a.body.units.time] if opts.speed is not None else default_speed(a)
    ramp = _seconds(a, opts.ramp) or 10 * _first_period(a)
    T = _seconds(a, opts.duration) or ramp + 5 * _first_period(a)
    nf, t = a.body.nf, a.body.units.time
    loads = Loads.of(LoadProgram(spin=s * np.eye(3)[k], ramp=ramp))
    return Scene("spin-up", k, T, np.zeros(3), np.zeros(nf), np.zeros(nf), loads, speed=s,
                 text=f"prescribed spin-up to {s:.4g} rad/{t} in {ramp:.4g} {t}")


def torque_pulse(a: Analysis, opts: SceneOptions = SceneOptions()) -> Scene:
    """At rest, a sin^2 torque pulse about a principal axis that leaves the body spinning at the speed."""
    k = _axis(a, opts, deformation_axis(a))
    s = opts.speed * TIME[a.body.units.time] if opts.speed is not None else default_speed(a)
    tp = _seconds(a, opts.pulse) or 0.5 * _first_period(a)
    tau0 = 2 * a.body.I0[k, k] * s / tp  # integral of tau0 sin^2(pi t / tp) over tp = tau0 tp / 2
    T = _seconds(a, opts.duration) or tp + 5 * _first_period(a)
    nf, t = a.body.nf, a.body.units.time
    loads = Loads.of(LoadProgram(tau0=tau0 * np.eye(3)[k], pulse=tp))
    return Scene("torque-pulse", k, T, np.zeros(3), np.zeros(nf), np.zeros(nf), loads, speed=s,
                 text=f"torque pulse of {tp:.3g} {t} to {s:.4g} rad/{t}")


def minor_axis(a: Analysis, opts: SceneOptions = SceneOptions()) -> Scene:
    """Spin about the minor axis with a 1 % wobble and modal damping: dissipation drives it to the major axis."""
    _, minor = stable_axes(a)
    k = _axis(a, opts, minor)
    s = opts.speed * TIME[a.body.units.time] if opts.speed is not None else default_speed(a)
    w = s * np.eye(3)[k] + 0.01 * s * np.eye(3)[(k + 1) % 3]
    T = _seconds(a, opts.duration) or min(20 * 2 * np.pi / s, 200 * _first_period(a))
    nf = a.body.nf
    zeta = 0.02 if opts.damping is None else opts.damping
    return Scene("minor-axis", k, T, w, np.zeros(nf), np.zeros(nf), damping=zeta, speed=s,
                 text=f"spin about the minor axis with a 1 % wobble, modal damping {zeta:g}")


BUILDERS = {"free-spin": free_spin, "mode-release": mode_release, "spin-up": spin_up, "torque-pulse": torque_pulse, "minor-axis": minor_axis}


def make_scene(name: str, a: Analysis, opts: SceneOptions = SceneOptions()) -> Scene:
    if name not in BUILDERS:
        raise FFRFError(f"--scene {name!r}: expected one of {', '.join(SCENES)}")
    return BUILDERS[name](a, opts)


def principal_spin_axis(a: Analysis) -> int | None:
    """The 0-based principal axis the analysis' one spin axis lies along (``--spin-axis``); None when the advice is
    for every principal axis or for an oblique one."""
    axes = a.options.situation.axes()
    if len(axes) != 1:
        return None
    e = np.abs(axes[0])  # a unit vector
    k = int(np.argmax(e))
    return k if e[k] > 1 - 1e-9 else None


def scene_axes(a: Analysis, opts: SceneOptions = SceneOptions()) -> tuple[int, ...]:
    """0-based axes of the scenes about an axis: ``opts.axis`` alone when given; else the rigidly stable principal
    axes (the deformation axis first, then the other one), which the advice covers ("each principal axis, the worst
    decides"; the intermediate one is rigidly unstable), and the advice's principal spin axis (theory 8, 10)."""
    if opts.axis is not None:
        return (_axis(a, opts, 0),)
    first = deformation_axis(a)
    axes = [first, *stable_axes(a), principal_spin_axis(a)]
    return tuple(dict.fromkeys(k for k in axes if k is not None))


def make_scenes(names, a: Analysis, opts: SceneOptions = SceneOptions()) -> list[Scene]:
    """The named scenes, those about an axis once per ``scene_axes`` (the first is the one about the deformation
    axis, or about ``opts.axis``); minor-axis once."""
    axes = scene_axes(a, opts)
    return [make_scene(n, a, o) for n in names
            for o in ([replace(opts, axis=k + 1) for k in axes] if n in ABOUT_AN_AXIS else [opts])]
