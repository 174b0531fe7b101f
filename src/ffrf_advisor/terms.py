"""The one term catalogue of the FFRF equations of motion (theory section 5): ids, groups, needs, Lagrangian sets.

Every other module (the advisor, the solver settings, the simulator, the
reports) takes its term ids from here. Terms come in groups, one per part of
the kinetic energy ``T = 0.5 w^T (I0 + W1 Qf + Qf^T W2 Qf) w + w^T Qf^T W3 q'
+ 0.5 q'^T q'``; a set made of whole groups (I0 plus any of W1, W2, W3)
follows from a truncated kinetic energy and conserves energy and angular
momentum ("Lagrangian"). ``geo_stiff`` (theory section 9) lies outside the
FFRF kinetic energy: its potential ``0.5 q^T G(w) q`` depends on the spin,
and the flexible equations alone carry it, so a set with it is never
Lagrangian in this sense.
"""
from __future__ import annotations

from dataclasses import dataclass

from .errors import FFRFError


@dataclass(frozen=True)
class Term:
    """One term: its id, energy group, where it acts (rot, flex, both), invariants it needs, and what it is."""

    id: str
    group: str
    where: str
    needs: tuple[str, ...]
    adams: tuple[int, ...]  # Adams invariants carrying it (docs/adams_invariants.md section 3.3)
    text: str


CATALOGUE = (
    Term("gyro0", "I0", "rot", ("I0",), (7,), "-w~ I0 w, mass I0 (always on)"),
    Term("cf1", "W1", "flex", ("W1",), (8,), "[w I] 0.5 W1^T w: centrifugal widening, constant part"),
    Term("inertia_lin", "W1", "rot", ("W1",), (8,), "W1 Qf in I_TT (mass and -w~ I_TT w)"),
    Term("cor1", "W1", "rot", ("W1",), (8,), "-W1 Qf' w"),
    Term("inertia_quad", "W2", "rot", ("W2",), (9,), "Qf^T W2 Qf in I_TT (mass and -w~ I_TT w)"),
    Term("cf2", "W2", "flex", ("W2",), (9,), "[w I] W2 Qf w: deformation-dependent centrifugal, softening"),
    Term("cor_quad", "W2", "rot", ("W2",), (9,), "-(Qf'^T W2 Qf + Qf^T W2 Qf') w"),
    Term("coupling", "W3", "both", ("W3",), (5,), "Qf^T W3 and W3^T Qf in the mass matrix"),
    Term("cor_coupling", "W3", "both", ("W3",), (5,), "-w~ Qf^T W3 q' (rot) and -2 W3^T Qf' w (flex)"),
    Term("geo_stiff", "FE", "flex", ("G",), (), "-G(w) q: geometric stiffening by the centrifugal prestress"),
)
BY_ID = {t.id: t for t in CATALOGUE}
IDS = tuple(BY_ID)
FFRF_GROUPS = ("I0", "W1", "W2", "W3")
GROUPS = {g: tuple(t.id for t in CATALOGUE if t.group == g) for g in (*FFRF_GROUPS, "FE")}
FULL = tuple(t for t in IDS if BY_ID[t].group in FFRF_GROUPS)  # the paper's full FFRF, without geo_stiff

# Canonical sets of the guideline levels (G section 8): what each level adds, all of it.
LEVEL_SETS = {
    "I": ("gyro0",),
    "II": ("gyro0", "cf1"),
    "III": ("gyro0", "cf1", "inertia_lin", "inertia_quad", "cf2", "coupling"),
    "IV": FULL,
}


def ordered(terms) -> tuple[str, ...]:
    """The ids of ``terms`` in catalogue order (unknown ids raise KeyError)."""
    wanted = set(terms)
    unknown = wanted - set(IDS)
    if unknown:
        raise KeyError(", ".join(sorted(unknown)))
    return tuple(t for t in IDS if t in wanted)


def parse_terms(text: str) -> tuple[str, ...]:
    """A term set from the command line: I, II, III, IV, full, or a comma list of ids (gyro0 always added)."""
    key = text.strip()
    if key in LEVEL_SETS:
        return LEVEL_SETS[key]
    if key == "full":
        return FULL
    ids = [t.strip() for t in key.split(",") if t.strip()]
    unknown = [t for t in ids if t not in BY_ID]
    if not ids or unknown:
        raise FFRFError(f"--terms {text!r}: expected I, II, III, IV, full, advised or a comma list of "
                        f"{', '.join(IDS)}" + (f" (unknown: {', '.join(unknown)})" if unknown else ""))
    return ordered({"gyro0", *ids})


def groups_of(terms) -> tuple[str, ...]:
    """The energy groups any term of ``terms`` belongs to."""
    return tuple(g for g in (*FFRF_GROUPS, "FE") if set(GROUPS[g]) & set(terms))


def is_lagrangian(terms) -> bool:
    """True when ``terms`` is gyro0 plus whole FFRF groups: it follows from a truncated kinetic energy."""
    terms = set(terms)
    return "gyro0" in terms and "geo_stiff" not in terms and all(
        set(GROUPS[g]) <= terms for g in groups_of(terms))


def lagrangian_status(terms) -> str:
    """The one wording of every output: "Lagrangian" (gyro0 and whole FFRF groups), "Lagrangian + geo_stiff"
    (the same, with the spin stiffening of theory 9, which lies outside the kinetic energy) or "not
    Lagrangian" (theory 5: energy and |H| drift)."""
    if not is_lagrangian([t for t in terms if t != "geo_stiff"]):
        return "not Lagrangian"
    return "Lagrangian + geo_stiff" if "geo_stiff" in set(terms) else "Lagrangian"


def lagrangian_superset(terms) -> tuple[str, ...] | None:
    """The smallest Lagrangian set containing ``terms``: every group it touches, whole (None with geo_stiff)."""
    if "geo_stiff" in set(terms):
        return None
    return ordered({"gyro0", *(t for g in groups_of(terms) for t in GROUPS[g])})


def needed_invariants(terms) -> tuple[str, ...]:
    """The invariants (I0, W1, W2, W3, G) that ``terms`` need."""
    needs = {n for t in terms for n in BY_ID[t].needs}
    return tuple(n for n in ("I0", "W1", "W2", "W3", "G") if n in needs)
