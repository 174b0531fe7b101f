"""The advisor's term set as solver settings (Adams: modal formulation and INVARIANTS= pattern).

Mapping of ../shared/adams_invariants.md section 2.2. Each statement carries
how sure it is: "seen" in a public source, "inferred" from seen sources and
the invariant algebra, "recalled" or "guess" (no source found).
"""
from __future__ import annotations

from dataclasses import dataclass

from .names import SOLVERS  # noqa: F401 (defined in names: the CLI's help lists them)
from .terms import BY_ID


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


def adams_settings(terms: tuple[str, ...]) -> dict:
    """The lightest Adams option whose invariants carry every term, and why."""
    needed = sorted({i for t in terms for i in BY_ID[t].adams})
    option = next(o for o in ADAMS_OPTIONS if not set(needed) & set(o.off))
    return {
        "solver": "adams",
        "formulation": option.name,
        "invariants": option.pattern,
        "statement": f"FLEX_BODY/id, ..., INVARIANTS={option.pattern}",
        "needed_invariants": {t: [f"I{i}" for i in BY_ID[t].adams] for t in terms},
        "source": option.source,
        "pattern_note": PATTERN_NOTE,
    }
