"""Units of an MAPDL run: the /UNITS record of the .rst, a ``units`` option, or the system under which the
file's materials are plausible; turned into a unit system of this package (ffrf_advisor.units).

MAPDL stores numbers as given and records the system only when /UNITS named one. Each system is its
length in m and its mass unit in kg (time is the second in all): a system this package has no name for
(CGS, uMKS, BFT, BIN) is converted to t-mm-N-s by scaling lengths and masses exactly.
"""
from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from ..checks import PLAUSIBLE_DENSITY
from ..errors import BodyFileError
from ..units import LENGTH, MASS, SI, TMM, Units, UnitsError

LBF = Fraction(45359237, 10**8) * Fraction(980665, 10**5)  # pound-force in N, exact
FOOT, INCH = Fraction(3048, 10**4), Fraction(254, 10**4)  # m
SYSTEMS = {"SI": (Fraction(1), Fraction(1)), "MKS": (Fraction(1), Fraction(1)),
           "MPA": (Fraction(1, 1000), Fraction(1000)), "CGS": (Fraction(1, 100), Fraction(1, 1000)),
           "uMKS": (Fraction(1, 10**6), Fraction(1)),
           "BFT": (FOOT, LBF / FOOT), "BIN": (INCH, LBF / INCH)}  # (length unit in m, mass unit in kg)
HEADER = {"SI": "SI", "CSG": "CGS", "MKS": "MKS", "MPA": "MPA", "uMKS": "uMKS",  # ansys-mapdl-reader's names
          "U.S. Customary units (feet)": "BFT", "U.S. Customary units (inches)": "BIN"}
SOUND = (10.0, 3e4)  # m/s, sqrt(E / rho): rubber ~30, metals ~5000, diamond 18,000


@dataclass(frozen=True)
class UnitChoice:
    """The body's units and the factors that take the file's lengths and masses to them."""

    units: Units
    length: float
    mass: float
    note: str


def system_of(name: str, where) -> tuple[Fraction, Fraction]:
    """(length in m, mass in kg) of an MAPDL /UNITS name or of a unit string like 't-mm-N-s'."""
    if name in SYSTEMS:
        return SYSTEMS[name]
    try:
        u = Units.parse(name)
    except UnitsError as e:
        raise BodyFileError(where, "units", f"an MAPDL system ({', '.join(SYSTEMS)}) or units like 't-mm-N-s'",
                            str(e)) from None
    return LENGTH[u.length], MASS[u.mass]


def plausible(system: tuple[Fraction, Fraction], materials: list[tuple[float, float]]) -> bool:
    """Every material (E, rho in the file's numbers) has a plausible density and speed of sound in ``system``."""
    metre, kg = (float(x) for x in system)
    return all(PLAUSIBLE_DENSITY[0] <= rho * kg / metre**3 <= PLAUSIBLE_DENSITY[1]
               and SOUND[0] <= np.sqrt(E / rho) * metre <= SOUND[1] for E, rho in materials)


def _fits(materials: list[tuple[float, float]]) -> list[str]:
    """The MAPDL systems (one name per distinct system) under which the materials are plausible."""
    names: dict[tuple, str] = {}
    for name, system in SYSTEMS.items():
        if plausible(system, materials):
            names.setdefault(system, name)
    return list(names.values())


def _evidence(materials: list[tuple[float, float]], system) -> str:
    """Density and speed of sound of (up to three) materials in ``system``, for notes and messages."""
    metre, kg = (float(x) for x in system)
    return "; ".join(f"E {E:.4g}, DENS {rho:.4g}: {rho * kg / metre**3:.3g} kg/m^3, {np.sqrt(E / rho) * metre:.3g} m/s"
                     for E, rho in materials[:3])


def choose(path, header: str, materials: list[tuple[float, float]], option: str | None) -> UnitChoice:
    """The run's units: the /UNITS record, else the option (checked against the materials), else the one MAPDL
    system under which the materials are plausible, else t-mm-N-s assumed, as the other readers do."""
    stated = HEADER.get(header)
    if option is not None:
        system = system_of(option, path)
        if stated is not None and SYSTEMS[stated] != system:
            raise BodyFileError(path, "/UNITS", f"{option} as the units option says (or no option)", stated)
        if materials and not plausible(system, materials):
            raise BodyFileError(path, "units", f"units under which the materials have a density of "
                                f"{PLAUSIBLE_DENSITY[0]:g}-{PLAUSIBLE_DENSITY[1]:g} kg/m^3 and a speed of sound of "
                                f"{SOUND[0]:g}-{SOUND[1]:g} m/s (they fit: {', '.join(_fits(materials)) or 'none'})",
                                f"{option}: {_evidence(materials, system)}")
        return _converted(system, f"units {option} (the units option)")
    if stated is not None:
        return _converted(SYSTEMS[stated], f"units {stated} (/UNITS of the .rst)")
    fits = _fits(materials)
    if len(fits) == 1:
        return _converted(SYSTEMS[fits[0]], f"units {fits[0]}, the one MAPDL system under which the materials "
                          f"are plausible (/UNITS not given; {_evidence(materials, SYSTEMS[fits[0]])})")
    fit = ", ".join(fits) if fits else "no MAPDL system" if materials else "nothing: none has EX and DENS"
    return _converted(SYSTEMS["MPA"], f"units t-mm-N-s assumed (/UNITS not given; the materials fit {fit})")


def _converted(system: tuple[Fraction, Fraction], note: str) -> UnitChoice:
    """The package's units with the same length and mass as ``system`` where it has them, else t-mm-N-s."""
    own = [u for u in (SI, TMM, *(Units(m, l, "s") for m in MASS for l in LENGTH)) if _has_force(u)
           and (LENGTH[u.length], MASS[u.mass]) == system]
    units = own[0] if own else TMM
    length, mass = system[0] / LENGTH[units.length], system[1] / MASS[units.mass]
    if (length, mass) != (1, 1):
        note += f"; converted to {units} (lengths x {float(length):.9g}, masses x {float(mass):.9g})"
    return UnitChoice(units, float(length), float(mass), note)


def _has_force(u: Units) -> bool:
    """Whether ``u`` is a consistent system with a named force unit (t-mm-N-s, kg-m-N-s, ...)."""
    try:
        return bool(u.force)
    except UnitsError:
        return False
