"""Isotropic linear-elastic materials; values in t-mm-N-s."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Material:
    """Young's modulus E, Poisson's ratio nu, density rho (consistent units)."""

    name: str
    E: float
    nu: float
    rho: float

    @property
    def lame(self) -> tuple[float, float]:
        """Lame parameters (lambda, mu)."""
        lam = self.E * self.nu / ((1 + self.nu) * (1 - 2 * self.nu))
        return lam, self.E / (2 * (1 + self.nu))

    @property
    def G(self) -> float:
        return self.lame[1]


STEEL = Material("steel", E=210000.0, nu=0.3, rho=7.85e-9)
ALUMINIUM = Material("aluminium", E=70000.0, nu=0.33, rho=2.70e-9)
TITANIUM = Material("titanium", E=113800.0, nu=0.342, rho=4.43e-9)  # Ti-6Al-4V
