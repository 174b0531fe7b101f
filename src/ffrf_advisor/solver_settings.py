"""The advisor's term set as solver settings (docs/solvers.md cites the sources).

Adams: modal formulation and INVARIANTS= pattern (docs/adams_invariants.md
section 2.2); RecurDyn: the RFlex mass-invariant option Partial or Full;
EXUDYN: its one switch of all inertia terms; Chrono: its modal assembly, which
has no inertia-term switch. Each mapping carries how sure it is: "seen" in a
public source, "inferred" from seen sources and the invariant algebra,
"recalled" or "guess" (no source found); and the terms the solver cannot drop
(it keeps them although the advice does not) or cannot add (the advice needs
them, the solver has none).
"""
from __future__ import annotations

from dataclasses import dataclass

from .names import SOLVERS  # noqa: F401 (defined in names: the CLI's help lists them)
from .terms import BY_ID, FULL, GROUPS, ordered


@dataclass(frozen=True)
class AdamsOption:
    name: str
    off: tuple[int, ...]
    source: str

    @property
    def pattern(self) -> str:
        return ":".join("F" if i in self.off else "T" for i in range(1, 10))


ADAMS_OPTIONS = (
    AdamsOption("constant coupling", (5, 8, 9),
                "name seen (Adams Flex, formulations); invariant set recalled, unconfirmed"),
    AdamsOption("partial coupling", (5, 9),
                "seen: Adams' default, keeps only the W1 terms (guideline paper); that this means I5 and I9 off "
                "is inferred (I5 gives W3, I9 gives W2)"),
    AdamsOption("custom coupling", (9,),
                "name seen; this pattern (W3 kept, W2 dropped) is inferred from the invariant algebra"),
    AdamsOption("full coupling", (),
                "seen: full coupling keeps all terms; the all-true pattern is inferred"),
)
PATTERN_NOTE = ("INVARIANTS=c1:...:c9 with one true/false flag per invariant is seen (FLEX_BODY statement); "
                "the token spelling T/F separated by ':' is a guess")


def _carried(off: tuple[int, ...]) -> tuple[str, ...]:
    """The FFRF terms whose Adams invariants are all on."""
    return tuple(t for t in FULL if not set(BY_ID[t].adams) & set(off))


def _tagged(solver: str, setting: str, statement: str, sure: str, has: tuple[str, ...], terms, source: str,
            **extra) -> dict:
    """The common part of every solver's settings: what the solver then evaluates against the advice."""
    return {"solver": solver, "setting": setting, "statement": statement, "sure": sure,
            "cannot_drop": list(ordered(set(has) - set(terms))), "cannot_add": list(ordered(set(terms) - set(has))),
            "source": source, **extra}


def adams_settings(terms: tuple[str, ...]) -> dict:
    """The lightest Adams option whose invariants carry every term, and why."""
    needed = sorted({i for t in terms for i in BY_ID[t].adams})
    option = next(o for o in ADAMS_OPTIONS if not set(needed) & set(o.off))
    return _tagged("adams", option.name, f"FLEX_BODY/id, ..., INVARIANTS={option.pattern}",
                   "seen" if option.source.startswith("seen") else "inferred", _carried(option.off), terms,
                   option.source, formulation=option.name, invariants=option.pattern,
                   needed_invariants={t: [f"I{i}" for i in BY_ID[t].adams] for t in terms}, pattern_note=PATTERN_NOTE)


RECURDYN_SOURCE = ("seen: RecurDyn help (2024), Flexibility dialog, RFlex page: Mass Invariant Partial does not compute "
                   "the invariants N4 and N6, Full (the default) computes all; RFlex invariant variables page: N4 "
                   "(3x3 per mode pair) and N6 (3x1 per mode pair). That N4 carries the W2 terms and N6 the W3 terms "
                   "(Adams I9 and I5) is inferred from their dimensions")


def recurdyn_settings(terms: tuple[str, ...]) -> dict:
    """Partial when the advice needs no W2 or W3 term, else Full."""
    deformation = set(GROUPS["W2"]) | set(GROUPS["W3"])
    full = bool(set(terms) & deformation)
    has = FULL if full else tuple(t for t in FULL if t not in deformation)
    setting = "Full" if full else "Partial"
    return _tagged("recurdyn", setting, f"RFlex body, Mass Invariant = {setting}", "inferred", has, terms,
                   RECURDYN_SOURCE)


def exudyn_settings(terms: tuple[str, ...]) -> dict:
    """EXUDYN evaluates every inertia term or none (``computeFFRFterms``) and has no geometric stiffening."""
    return _tagged("exudyn", "computeFFRFterms=True", "ObjectFFRFreducedOrder(..., computeFFRFterms=True)", "seen",
                   FULL, terms, "seen: EXUDYN 1.13.6 documentation, ObjectFFRFreducedOrder (computeFFRFterms): "
                   "one switch turns all inertia terms on or off; no geometric stiffening. False would drop the terms "
                   "the advice keeps too")


def chrono_settings(terms: tuple[str, ...]) -> dict:
    """Chrono::Modal's ChModalAssembly: no inertia-term switch in its public API; what it evaluates is not
    documented there (a guess: all of the FFRF set, no geometric stiffening)."""
    return _tagged("chrono", "ChModalAssembly (no inertia-term switch)", "ChModalAssembly with the body's modes; "
                   "SetUseStaticCorrection(true) where `ffrf-advisor modes` advises residual vectors", "guess", FULL,
                   terms, "seen: Chrono::Modal ChModalAssembly class reference (reduction type Herting or "
                   "Craig-Bampton, static correction, internal-node update): no switch of inertia terms; which "
                   "terms it evaluates and whether it stiffens is a guess")


SETTINGS = {"adams": adams_settings, "recurdyn": recurdyn_settings, "exudyn": exudyn_settings,
            "chrono": chrono_settings}  # names.SOLVERS, in this order
