"""Checks of the assumptions of theory section 1, as numbers with pass/fail (theory section 4).

Every value is dimensionless, scaled so that 1 means "as large as it can
be" (Cauchy-Schwarz bounds for mass-normalised modes).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .body import FlexibleBody
from .units import LENGTH, MASS

TOLERANCES = {
    "mass": 0.0,                 # mass must exceed this
    "com_offset": 1e-6,          # |CoM| / largest dimension
    "principal_axes": 1e-6,      # max |off-diagonal I0| / trace I0
    "mass_normalisation": 1e-6,  # max |Phi^T M Phi - I|
    "free_surface_translation": 1e-6,  # max |sum m S_p| / sqrt(m)
    "free_surface_rotation": 1e-6,     # max |sum m u0~ S_p|_k / sqrt(I0_kk)
    "eigenvalue_order": 0.0,     # number of eigenvalues out of order or <= 0
}

ASSUMPTION = {
    "mass": "positive mass",
    "com_offset": "frame origin at the centre of mass (assumption 1)",
    "principal_axes": "frame axes along the principal axes (assumption 4)",
    "mass_normalisation": "mass-normalised modes (assumption 3)",
    "free_surface_translation": "free-surface modes, translation (assumption 2)",
    "free_surface_rotation": "free-surface modes, mean-axis rotation (assumption 2)",
    "eigenvalue_order": "positive eigenvalues sorted ascending (assumption 3)",
}


# Checks whose value is a sum of products of the source's numbers: limited by their precision.
PRECISION_LIMITED = ("com_offset", "principal_axes", "mass_normalisation", "free_surface_translation",
                     "free_surface_rotation")


@dataclass(frozen=True)
class Check:
    """One check: its value, the tolerance, whether it passed, and the source precision assumed."""

    name: str
    value: float
    tolerance: float
    passed: bool
    precision: str = "double"

    @property
    def assumption(self) -> str:
        return ASSUMPTION[self.name]


def _check(name: str, value: float, tolerances: dict[str, float], precision: str) -> Check:
    tol = tolerances[name]
    passed = value > tol if name == "mass" else value <= tol
    return Check(name, float(value), tol, bool(passed and np.isfinite(value)), precision)


def source_tolerances(digits: int | None) -> dict[str, float]:
    """Tolerances for data with ``digits`` significant digits: at least 10^(1 - digits) for the checks
    PRECISION_LIMITED (a 6-digit .frd cannot show mass normalisation better than about 1e-5)."""
    if digits is None:
        return dict(TOLERANCES)
    floor = 10.0 ** (1 - digits)
    return {k: max(v, floor) if k in PRECISION_LIMITED else v for k, v in TOLERANCES.items()}


def check_values(body: FlexibleBody) -> dict[str, float]:
    """The raw dimensionless numbers behind each check."""
    J = body.integrals
    I0 = J.I0()
    nf = J.nf
    diag = np.sqrt(np.clip(np.diag(I0), 1e-300, None))
    lam = body.eigenvalues
    values = {
        "mass": J.mass,
        "com_offset": float(np.linalg.norm(J.com)) / body.largest_dimension(),
        "principal_axes": float(np.abs(I0 - np.diag(np.diag(I0))).max() / np.trace(I0)),
        "free_surface_translation": float(np.abs(J.mode_sum).max() / np.sqrt(J.mass)) if nf else 0.0,
        "free_surface_rotation": float((np.abs(J.mean_axis_residual()) / diag[:, None]).max()) if nf else 0.0,
        "eigenvalue_order": float(np.sum(np.diff(lam) < 0) + np.sum(lam <= 0)),
    }
    if J.Sbar is not None:  # an invariants file without I9 has had its I6 checked by the reader
        values["mass_normalisation"] = float(np.abs(J.modal_mass() - np.eye(nf)).max()) if nf else 0.0
    return values


def run_checks(body: FlexibleBody, tolerances: dict[str, float] | None = None) -> list[Check]:
    """All checks of theory section 4 against the documented tolerances, widened to the precision of the
    body's source data (provenance.digits), or the given ones."""
    digits = body.provenance.digits
    tol = {**source_tolerances(digits), **(tolerances or {})}
    precision = "double" if digits is None else f"{digits} significant digits"
    return [_check(name, value, tol, precision) for name, value in check_values(body).items()]


PLAUSIBLE_DENSITY = (1.0, 1e5)  # kg/m^3: below air; 4x osmium (22,590), which no mass distribution explains
DENSITY_UNITS = {"kg/m^3": 1.0, "g/cm^3": 1e3, "kg/cm^3": 1e6, "kg/mm^3": 1e9, "t/mm^3": 1e12}  # in kg/m^3


def apparent_density(body: FlexibleBody) -> float:
    """Mass over the volume of the solid box with the body's mass and second moments [kg/m^3]: the material's
    density for a solid box, less for thin walls (the carbody: 31), rarely above it (mass near the CoM)."""
    return _density(body, body.equivalent_box())


def _density(body: FlexibleBody, box: np.ndarray) -> float:
    """``apparent_density`` with the body's ``equivalent_box`` given."""
    u = body.units
    volume = float(np.prod(box)) * float(LENGTH[u.length]) ** 3
    return body.mass * float(MASS[u.mass]) / volume if volume > 0 else float("inf")


ENGINEERING_DENSITY = (300.0, 23e3)  # kg/m^3: light wood and foamed polymers; above osmium (22,590)


def solid_density(body: FlexibleBody) -> float | None:
    """Mass over the volume of the solid cells [kg/m^3] (the material's density, plus any masses on nodes); None
    without solid cells or where nodes carry rotary inertia (shells and beams hold mass outside the solids)."""
    fe = body.fe
    if fe is None or fe.rotary is not None or not fe.mesh.cells:
        return None
    from .stress_bound import solid_volume  # the FE toolkit: only where FE data are read
    volume = solid_volume(fe.mesh)
    return _per_m3(body, volume) if volume > 0 else None


def _per_m3(body: FlexibleBody, volume: float) -> float:
    """The body's mass over ``volume`` (body units) in kg/m^3."""
    u = body.units
    return body.mass * float(MASS[u.mass]) / (volume * float(LENGTH[u.length]) ** 3)


def density_text(body: FlexibleBody) -> str:
    """The density for a headline: over the solid cells' volume where known, else the apparent density."""
    rho = solid_density(body)
    if rho is None:
        return f"apparent density {apparent_density(body):.4g} kg/m^3 (equivalent box)"
    return f"density {rho:.4g} kg/m^3 (solid cells)"


def density_warnings(body: FlexibleBody) -> tuple[str, ...]:
    """Warnings naming the likely cause when the density of the solids is outside ENGINEERING_DENSITY (without
    solid cells: the apparent density outside PLAUSIBLE_DENSITY, else the mass more than the densest material
    filling the bounding box), or the mass too small for its inertia within the bounding box."""
    rho = solid_density(body)
    first = _apparent_warning(body) if rho is None else _solid_warning(body, rho)
    return first + (() if first else _overfilled(body)) + _underfilled(body)


def _unit_guess(body: FlexibleBody, rho: float) -> str:
    """The density unit that, read as the body's, would give ``rho`` from a steel-to-aluminium-like material."""
    u = body.units
    native = float(MASS[u.mass] / LENGTH[u.length] ** 3)
    likely = [name for name, size in DENSITY_UNITS.items() if 300 <= rho * size / native <= 3e4 and size != native]
    return f"; a density in {likely[0]} read as {u.mass}/{u.length}^3?" if likely else ""


def _apparent_warning(body: FlexibleBody) -> tuple[str, ...]:
    box = body.equivalent_box()
    rho = _density(body, box)
    if PLAUSIBLE_DENSITY[0] <= rho <= PLAUSIBLE_DENSITY[1]:
        return ()
    u = body.units
    return (f"implausible density: mass {body.mass:.4g} {u.mass} in its equivalent solid box of "
            f"{' x '.join(f'{e:.3g}' for e in box)} {u.length} is {rho:.3g} kg/m^3, outside "
            f"{PLAUSIBLE_DENSITY[0]:g}-{PLAUSIBLE_DENSITY[1]:g} kg/m^3 (units {u}){_unit_guess(body, rho)}",)


def _solid_warning(body: FlexibleBody, rho: float) -> tuple[str, ...]:
    if ENGINEERING_DENSITY[0] <= rho <= ENGINEERING_DENSITY[1]:
        return ()
    u = body.units
    return (f"implausible density: mass {body.mass:.4g} {u.mass} over the solid cells' volume is {rho:.4g} kg/m^3, "
            f"outside engineering materials ({ENGINEERING_DENSITY[0]:g}-{ENGINEERING_DENSITY[1]:g} kg/m^3; units "
            f"{u}){_unit_guess(body, rho)}; or a damaged density or mass, or point masses heavier than the solids",)


def _overfilled(body: FlexibleBody) -> tuple[str, ...]:
    """The mass is at most the densest material filling the bounding box B of the nodes (``_extents``)."""
    B = _extents(body)
    volume = 0.0 if B is None else float(np.prod(B))
    rho = _per_m3(body, volume) if volume > 0 else 0.0
    if rho <= ENGINEERING_DENSITY[1]:
        return ()
    u = body.units
    return (f"mass {body.mass:.4g} {u.mass} does not fit the bounding box {_dims(B)} {u.length}: {rho:.4g} kg/m^3 "
            f"filling it, denser than any material{_unit_guess(body, rho)} (or a damaged mass)",)


def _underfilled(body: FlexibleBody) -> tuple[str, ...]:
    """The equivalent box of mass and inertia is at most sqrt(3) B per axis: a mass on an interval of width B has
    a variance of at most B^2 / 4 (Popoviciu), a box's is its width^2 / 12."""
    B = _extents(body)
    e = body.equivalent_box()
    if B is None or not np.any(np.sort(e) > np.sqrt(3) * np.sort(B) + 1e-9 * B.max()):  # 1e-9: round-off of I
        return ()
    u = body.units
    return (f"mass {body.mass:.4g} {u.mass} too small for its inertia I0: its equivalent solid box {_dims(e)} "
            f"{u.length} cannot lie in the bounding box {_dims(B)} {u.length} (a damaged mass or I0, or mass and "
            "inertia in different units)",)


def _extents(body: FlexibleBody) -> np.ndarray | None:
    """Extents of the nodes' bounding box in the body's (principal) frame; a cube of the largest dimension where
    only that is cached; None without nodes or where shells' and beams' mass reaches beyond their nodes."""
    if body.integrals.rotary is not None:
        return None
    if body.fe is not None:
        lo, hi = body.fe.mesh.bounding_box()
        return hi - lo
    summary = body.nodal_summary()
    return None if summary is None else np.full(3, summary.largest_dimension)


def _dims(a: np.ndarray) -> str:
    return " x ".join(f"{x:.3g}" for x in a)


def source_warnings(body: FlexibleBody) -> tuple[str, ...]:
    """The warnings a reader left in the provenance notes (``warning:`` in a note: a constrained run's rigid-mode
    count, a mass that differs from the code's own), so that the advice carries them, not only ``info``."""
    return tuple(f"source: {note}" for note in body.provenance.notes if "warning:" in note)


def check_warnings(checks: list[Check]) -> tuple[str, ...]:
    """One warning per failed check: what failed, by how much, and the precision assumed."""
    return tuple(f"check {c.name} failed: {c.value:.3g} against {c.tolerance:.1e} ({c.assumption}; source data "
                 f"assumed {c.precision}); results carry that caveat" for c in checks if not c.passed)
