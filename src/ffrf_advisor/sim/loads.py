"""External loads of a run: a body-frame torque, modal forces and a prescribed rotation (theory section 10).

Loads given as functions of time go through Python at every evaluation (scipy's integrators, the fixed-step
loops with loads). The scenes' shapes are a ``LoadProgram`` as well, a few numbers that the compiled DOP853
(``sim.dop853``) evaluates inside its loop; its functions here are the plain reference the tests compare with.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np


def spin_profile(W: float, T: float) -> Callable:
    """w(t) = (W/T)(t - (T/2 pi) sin(2 pi t/T)) for t < T, then W; and its derivative (theory section 10).
    T = 0: W from the start. ``t`` a number (numbers back: the Python integrators call it per evaluation) or a
    numpy array of times (arrays back)."""
    def rising(t):
        x = 2 * np.pi * t / T
        return (W / T) * (t - T / (2 * np.pi) * np.sin(x)), (W / T) * (1 - np.cos(x))

    def profile(t):
        if not isinstance(t, np.ndarray):
            return (W, 0.0) if t >= T else rising(t)
        held = t >= T
        if held.all():  # T = 0 among others
            return np.full(held.shape, float(W)), np.zeros(held.shape)
        w, a = rising(np.where(held, 0.0, t))
        return np.where(held, W, w), np.where(held, 0.0, a)
    return profile


@dataclass(frozen=True)
class LoadProgram:
    """tau(t) = tau0 sin^2(pi t / pulse) for t < pulse, then 0 (pulse = inf: tau0 throughout); with ``spin``
    the rotation is prescribed, w(t) = spin * spin_profile(1, ramp)(t)."""

    tau0: np.ndarray = field(default_factory=lambda: np.zeros(3))
    pulse: float = np.inf
    spin: np.ndarray | None = None
    ramp: float = 0.0

    def torque(self, t: float) -> np.ndarray:
        if self.pulse == np.inf:
            return np.asarray(self.tau0, float)
        return np.asarray(self.tau0, float) * (np.sin(np.pi * t / self.pulse) ** 2 if t < self.pulse else 0.0)

    def prescribed(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        g, gd = spin_profile(1.0, self.ramp)(t)
        return np.asarray(self.spin, float) * g, np.asarray(self.spin, float) * gd

    def packed(self) -> np.ndarray:
        """[tau0, pulse, spin, ramp, prescribed] as the compiled loop reads it (``dop853._loads_at``)."""
        spin = np.zeros(3) if self.spin is None else np.asarray(self.spin, float)
        return np.concatenate([np.asarray(self.tau0, float), [self.pulse], spin, [self.ramp],
                               [float(self.spin is not None)]])


@dataclass(frozen=True)
class Loads:
    """External torque (body frame) and modal forces as functions of time; ``prescribed`` gives (w, w').
    ``program``: the same loads as a LoadProgram (``Loads.of``), which compiled integrators can run."""

    torque: Callable[[float], np.ndarray] | None = None
    modal: Callable[[float], np.ndarray] | None = None
    prescribed: Callable[[float], tuple[np.ndarray, np.ndarray]] | None = None
    program: LoadProgram | None = None

    @classmethod
    def of(cls, program: LoadProgram) -> "Loads":
        return cls(torque=program.torque if np.any(program.tau0) else None,
                   prescribed=program.prescribed if program.spin is not None else None, program=program)

    @property
    def none(self) -> bool:
        return self.torque is None and self.modal is None and self.prescribed is None

    def compiled(self) -> np.ndarray | None:
        """The packed program when compiled code can run these loads (none, or a program alone), else None."""
        if self.none:
            return LoadProgram().packed()
        return self.program.packed() if self.program is not None and self.modal is None else None
