"""Consistent unit systems (mass-length-force-time) with exact conversion factors.

Factors to SI are kept as fractions so that a conversion factor for any
dimension M^a L^b T^c (a, b, c multiples of 1/2) is computed exactly and
rounded once.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

MASS = {"t": Fraction(1000), "kg": Fraction(1), "g": Fraction(1, 1000)}
LENGTH = {"m": Fraction(1), "cm": Fraction(1, 100), "mm": Fraction(1, 1000)}
TIME = {"s": Fraction(1), "ms": Fraction(1, 1000)}
FORCE = {"kN": Fraction(1000), "N": Fraction(1), "mN": Fraction(1, 1000), "uN": Fraction(1, 10**6)}
MAX_SPEED = 1e9  # rad/s: far above any structure's modes; a larger speed is a mistake in the input


class UnitsError(ValueError):
    """A unit system string that is unknown or not consistent."""


@dataclass(frozen=True)
class Units:
    """A consistent unit system, e.g. ``Units.parse('t-mm-N-s')``."""

    mass: str = "t"
    length: str = "mm"
    time: str = "s"

    @property
    def force(self) -> str:
        f = MASS[self.mass] * LENGTH[self.length] / TIME[self.time] ** 2
        for name, value in FORCE.items():
            if value == f:
                return name
        raise UnitsError(f"{self.mass}-{self.length}-{self.time} has no named force unit")

    @property
    def stress(self) -> str:
        return f"{self.force}/{self.length}^2"

    @property
    def frequency(self) -> str:
        """Cycles per time unit: Hz for seconds (one name for it in every command)."""
        return "Hz" if self.time == "s" else f"1/{self.time}"

    def __str__(self) -> str:
        return f"{self.mass}-{self.length}-{self.force}-{self.time}"

    @classmethod
    def parse(cls, text: str) -> "Units":
        """Parse 'mass-length-force-time' (e.g. 't-mm-N-s', 'kg-m-N-s'); the force must be consistent."""
        parts = text.strip().split("-")
        if len(parts) != 4:
            raise UnitsError(f"units {text!r}: expected 'mass-length-force-time', e.g. 't-mm-N-s'")
        mass, length, force, time = parts
        for value, table, what in ((mass, MASS, "mass"), (length, LENGTH, "length"),
                                   (time, TIME, "time"), (force, FORCE, "force")):
            if value not in table:
                raise UnitsError(f"units {text!r}: unknown {what} unit {value!r}; known: {', '.join(table)}")
        units = cls(mass, length, time)
        if units.force != force:
            raise UnitsError(f"units {text!r}: {mass}, {length} and {time} imply force unit {units.force}, not {force}")
        return units

    def factor_to(self, other: "Units", M: float = 0, L: float = 0, T: float = 0) -> float:
        """Factor converting a quantity of dimension M^M L^L T^T from self to other units."""
        doubled = [int(round(2 * e)) for e in (M, L, T)]
        if any(abs(d - 2 * e) > 1e-12 for d, e in zip(doubled, (M, L, T))):
            raise UnitsError("exponents must be multiples of 1/2")
        ratios = (MASS[self.mass] / MASS[other.mass], LENGTH[self.length] / LENGTH[other.length],
                  TIME[self.time] / TIME[other.time])
        f2 = Fraction(1)
        for r, d in zip(ratios, doubled):
            f2 *= r**d
        if any(d % 2 for d in doubled):
            return math.sqrt(float(f2))
        return float(_sqrt_exact(f2))


def _sqrt_exact(f2: Fraction) -> Fraction:
    """The square root of a fraction that is a perfect square of a fraction."""
    num, den = math.isqrt(f2.numerator), math.isqrt(f2.denominator)
    return Fraction(num, den)


TMM = Units("t", "mm", "s")
SI = Units("kg", "m", "s")

# Dimensions (M, L, T) of the quantities a body carries. Mass-normalised modes
# have S^T M S = I, so S ~ M^-1/2 and q ~ M^1/2 L (theory section 6).
DIM = {
    "mass": (1, 0, 0),
    "length": (0, 1, 0),
    "inertia": (1, 2, 0),
    "Ibar": (0.5, 1, 0),
    "Sbar": (0, 0, 0),
    "mode_sum": (0.5, 0, 0),
    "mode": (-0.5, 0, 0),
    "mode_rotation": (-0.5, -1, 0),  # small rotation per unit modal coordinate (theory 3b)
    "q": (0.5, 1, 0),
    "eigenvalue": (0, 0, -2),
    "stiffness": (1, 0, -2),
    "stress": (1, -1, -2),
    "modal_stress": (0.5, -2, -2),  # stress per unit modal coordinate
    "density": (1, -3, 0),
    "stress_per_spin2": (1, -1, 0),      # stress per (rad per time unit)^2 (theory 11)
    "compliance_per_spin4": (1, 2, 2),   # f^T u of the centrifugal load per (rad per time unit)^4 (theory 11)
}


def factor(src: Units, dst: Units, quantity: str) -> float:
    """Conversion factor of a named quantity (see DIM) from src to dst units."""
    return src.factor_to(dst, *DIM[quantity])
