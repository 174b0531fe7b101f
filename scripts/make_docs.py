"""Rewrite what the docs quote of the tool's output: python scripts/make_docs.py [--check].

In seconds, from the shipped bodies in sample_bodies/ through the tool's own API and command line (no sample is
rebuilt):

- docs/samples.md, "What the advisor says": the blocks `advice` (the default advice at the moderate speed of
  1 rad/s, free connection), `rules` (the paper's inertia measures and the levels of `--rules thresholds` and
  `--rules paper`) and `stiff` (the levels with `--connection stiff`);
- docs/elements.md: the block `elements`, the element types by reader (io.support, as `formats` prints them);
- README.md, "Quick start": the block `example`, the beginning of what
  `ffrf-advisor analyze sample_bodies/beam.ffrf.h5 --speed 300rad/s` shows at 80 columns without colour
  (stdout and stderr as a terminal shows them).

A block is the text between `<!-- NAME:start -->` and `<!-- NAME:end -->`. With --check nothing is written;
the exit code is 1 when a block differs from what the tool says now (tests/test_docs.py checks the same).
`python scripts/make_samples.py --docs` calls this after regenerating the bodies.
"""
from __future__ import annotations

import argparse
import os
import re
import sys
import textwrap
from pathlib import Path

from ffrf_advisor.amplitudes import AmplitudeOptions
from ffrf_advisor.analysis import Analysis, Options, analyze
from ffrf_advisor.guidelines import LEVELS, Situation, operating_point
from ffrf_advisor.io import read_body
from ffrf_advisor.predict import Candidate, level_of
from ffrf_advisor.samples import SAMPLES

ROOT = Path(__file__).resolve().parent.parent
SAMPLES_MD = ROOT / "docs" / "samples.md"
ELEMENTS_MD = ROOT / "docs" / "elements.md"
README = ROOT / "README.md"
SPEED = 1.0  # rad/s: the moderate speed of docs/samples.md (a vehicle-like rotation rate)

EXAMPLE = ("analyze", "sample_bodies/beam.ffrf.h5", "--speed", "300rad/s")
EXAMPLE_TABLES = 1  # the README shows the output up to the end of its first table
# 80 columns, no colour, whatever the caller's terminal or environment says (rich reads these variables)
EXAMPLE_ENV = {"COLUMNS": "80", "LINES": None, "NO_COLOR": "1", "FORCE_COLOR": None, "TTY_COMPATIBLE": None,
               "TTY_INTERACTIVE": None, "JUPYTER_COLUMNS": None, "CLICOLOR_FORCE": None}


# ------------------------------------------------------------------ blocks
def replace_block(text: str, marker: str, content: str) -> str:
    """``text`` with the lines between <!-- marker:start --> and <!-- marker:end --> replaced by ``content``."""
    pattern = re.compile(rf"(<!-- {marker}:start -->\n).*?(<!-- {marker}:end -->)", re.S)
    if len(pattern.findall(text)) != 1:
        raise SystemExit(f"expected one block <!-- {marker}:start --> ... <!-- {marker}:end -->")
    return pattern.sub(lambda m: m.group(1) + content + m.group(2), text)


def block(text: str, marker: str) -> str:
    """The lines between <!-- marker:start --> and <!-- marker:end --> of ``text``."""
    found = re.findall(rf"<!-- {marker}:start -->\n(.*?)<!-- {marker}:end -->", text, re.S)
    if len(found) != 1:
        raise SystemExit(f"expected one block <!-- {marker}:start --> ... <!-- {marker}:end -->")
    return found[0]


def write_block(path: Path, marker: str, content: str) -> None:
    path.write_text(replace_block(path.read_text(), marker, content))


# ------------------------------------------------------------------ docs/samples.md
def shipped_bodies() -> dict:
    """The six sample bodies as `analyze` reads them (invariants and the nodal summary)."""
    return {name: read_body(ROOT / "sample_bodies" / f"{name}.ffrf.h5", load_fe="summary") for name in SAMPLES}


def analysis(body, **situation) -> Analysis:
    """The analysis at SPEED with the defaults, as `ffrf-advisor analyze BODY --speed 1rad/s [...]`."""
    return analyze(body, Options(situation=Situation(w_op=SPEED, **situation)))


FLOOR = 1e-8  # measures below it are shown as "<1e-8": some vanish by symmetry and would show round-off
FLOOR_TEXT = "1e-8"


def num(x: float) -> str:
    """Two significant figures, without an exponent between 1e-3 and 1e4 (190, not 1.9e+02)."""
    return f"{float(f'{x:.2g}'):g}"


def _worst(c: Candidate) -> str:
    """A candidate's largest predicted error and its kind. Not the axis: where axes tie to round-off (the beam's
    rigid error about axes 1 and 2 differs by 2e-14) the axis named could differ from one CPU to another."""
    kind, value = c.worst
    return f"{kind} {num(value)}"


def _best_below(a: Analysis) -> Candidate | None:
    """Of the sets of the highest level below the advice, the one with the smallest largest predicted error: what
    the advice was one level away from (not named: sets of a level can tie to round-off)."""
    below = [c for c in a.advice.candidates if LEVELS.index(level_of(c.terms)) < LEVELS.index(a.advice.level)]
    if not below:
        return None
    top = max((level_of(c.terms) for c in below), key=LEVELS.index)
    return min((c for c in below if level_of(c.terms) == top), key=lambda c: c.worst[1])


ADVICE_HEADER = ("| body | f1 [Hz] | sigma_1 at q_1 = 1 [N/mm²] | q_max,1 [sqrt(t) mm] | level I: largest predicted "
                 "error [-] | level II: largest predicted error [-] | advised set (its right-hand-side cost / the "
                 "full set's): largest predicted error [-] | level | level, `--excitation inertial` |\n"
                 "|---|---|---|---|---|---|---|---|---|\n")


def advice_row(body) -> str:
    """The advice at SPEED with the defaults (free connection, `--rules predicted`, every principal axis) and the
    numbers that decided it: the predicted response errors (relative; adequate when at most the tolerance / 2)
    of the canonical levels I and II and of the advised set, and the level when only the body's rigid motion
    drives the modes."""
    a = analysis(body)
    by_label = {c.label: c for c in a.advice.candidates}
    chosen = next(c for c in a.advice.candidates if c.terms == a.advice.terms)
    level = lambda name: _worst(by_label[name]) if name in by_label else "-"  # noqa: E731
    return (f"| {body.name} | {body.frequencies_hz[0]:.4g} | {body.sigma_max[0]:.4g} | {a.amplitudes.q_max[0]:.3g} "
            f"| {level('I')} | {level('II')} | {chosen.label} ({chosen.cost:.2f}): {_worst(chosen)} "
            f"| **{a.advice.level}** | {analysis(body, excitation='inertial').advice.level} |")


def _fired(a: Analysis, values: bool = True) -> str:
    """The rules of theory 8 that fired with their measure (the closure to whole energy groups left out)."""
    rules = [r for r in a.advice.rules if r.fired and r.terms and r.value is not None and r.threshold is not None]
    return ", ".join(f"{r.name} {num(r.value)} > {r.threshold:g}" if values else r.name for r in rules) or "none"


RULES_HEADER = ("| body | dI_L, principal axes 1 2 3 [-] | dI_Q, axes 1 2 3 [-] | `--rules thresholds`: level, rules "
                "fired (measure > threshold) | `--rules paper`: level, rules fired |\n|---|---|---|---|---|\n")


def rules_row(body) -> str:
    """The paper's inertia measures (maximum over the first n_ratio modes, as the rules take them) and the levels
    by theory 8's rules with the tool's earlier thresholds and with the paper's, at SPEED, free."""
    thresholds, paper = analysis(body, rules="thresholds"), analysis(body, rules="paper")
    sig = thresholds.significance
    dI = lambda name: " ".join(num(x) if x >= FLOOR else f"<{FLOOR_TEXT}" for x in sig.max_first(name))  # noqa: E731
    return (f"| {body.name} | {dI('dI_L')} | {dI('dI_Q')} | **{thresholds.advice.level}**: {_fired(thresholds)} "
            f"| **{paper.advice.level}**: {_fired(paper, values=False)} |")


def _levels(items: dict) -> str:
    """'I for a, b; III for c (why)' from {name: (level, why)}, levels in order."""
    parts = []
    for lv in LEVELS:
        names = [f"{n} ({why})" if why else n for n, (level, why) in items.items() if level == lv]
        if names:
            parts.append(f"level {lv} for " + (", ".join(names[:-1]) + " and " + names[-1] if len(names) > 1
                                               else names[0]))
    return "; ".join(parts)


def stiff_text(bodies: dict) -> str:
    """What `--connection stiff` gives at SPEED, with the default rules and with `--rules thresholds`."""
    predicted, thresholds = {}, {}
    for name, body in bodies.items():
        a = analysis(body, connection="stiff")
        best = _best_below(a)
        predicted[name] = (a.advice.level, best and f"best level-{level_of(best.terms)} set: {_worst(best)}")
        t = analysis(body, connection="stiff", rules="thresholds")
        thresholds[name] = (t.advice.level, None if t.advice.level == "I" else _fired(t))
    text = (f"With `--connection stiff` (the body's rotation is imposed: no rigid error, and the canonical levels "
            f"are not closed to whole energy groups), otherwise as above, the advice is {_levels(predicted)}. "
            f"With `--rules thresholds` it is {_levels(thresholds)}.")
    return wrapped(text)


def wrapped(text: str) -> str:
    """A paragraph wrapped at 110 columns, as the prose of docs/samples.md."""
    return "\n".join(textwrap.wrap(text, 110, break_long_words=False, break_on_hyphens=False)) + "\n"


def samples_blocks(bodies: dict | None = None) -> dict[str, str]:
    """The generated blocks of docs/samples.md, by marker."""
    bodies = shipped_bodies() if bodies is None else bodies
    n_ratio = analysis(next(iter(bodies.values()))).significance.n_ratio
    amp = AmplitudeOptions()
    where = (f"Operating point, as `ffrf-advisor analyze BODY --speed {SPEED:g}rad/s` states it: "
             f"{operating_point(Situation(w_op=SPEED))}; sigma_allow {amp.sigma_allow:g} N/mm², q_cap {amp.q_cap:g}.")
    return {
        "advice": (wrapped(where) + "\n"
                   + ADVICE_HEADER + "\n".join(advice_row(b) for b in bodies.values()) + "\n"),
        "rules": (wrapped(f"The paper's inertia measures (the largest over the first {n_ratio} modes, as the rules "
                          f"take them; below {FLOOR_TEXT} shown as <{FLOOR_TEXT}) and the levels by theory 8's rules "
                          "at the same point (`--rules thresholds`, `--rules paper`):") + "\n"
                  + RULES_HEADER + "\n".join(rules_row(b) for b in bodies.values()) + "\n"),
        "stiff": stiff_text(bodies),
    }


# ------------------------------------------------------------------ README.md
def _titles(lines: list[str]) -> list[str]:
    """The titles of the tables in ``lines`` (centred above their top border) and the evidence heading."""
    titles = []
    for i, line in enumerate(lines):
        if line.startswith("┏"):
            j = i
            while j > 0 and lines[j - 1].startswith(" ") and lines[j - 1].strip():
                j -= 1
            title = " ".join(x.strip() for x in lines[j:i])
            titles.append(title.split(" (")[0])
        elif line.startswith("evidence per rule"):
            titles.append("evidence per rule")
    return titles


def cli_output(args, columns: int = 80) -> str:
    """What `ffrf-advisor ARGS` shows in a terminal (stdout with the warnings and notes of stderr where they come)
    at ``columns`` columns without colour, run from the repository root; trailing spaces removed (rich pads
    centred titles)."""
    from typer.testing import CliRunner

    from ffrf_advisor.cli import app
    args = [str(ROOT / a) if a.startswith("sample_bodies/") else a for a in args]
    result = CliRunner().invoke(app, args, env={**EXAMPLE_ENV, "COLUMNS": str(columns)})
    if result.exit_code != 0:
        raise SystemExit(f"ffrf-advisor {' '.join(args)}: exit {result.exit_code}: {result.output}")
    text = result.output.replace(f"{ROOT}/", "")
    return "\n".join(line.rstrip() for line in text.splitlines())


def readme_example() -> str:
    """The README's example block: the command and its output to the end of the first table(s), indented as code,
    then how many lines and which tables follow."""
    lines = cli_output(EXAMPLE).splitlines()
    ends = [i for i, line in enumerate(lines) if line.startswith("└")]
    cut = ends[EXAMPLE_TABLES - 1] + 1 if len(ends) >= EXAMPLE_TABLES else len(lines)
    shown, rest = lines[:cut], lines[cut:]
    if rest:
        more = (f"[... {len(rest)} more lines: " + "; ".join(_titles(rest)) + "]")
        shown += textwrap.wrap(more, 80, break_long_words=False, break_on_hyphens=False)
    return "".join(f"    {line}".rstrip() + "\n" for line in ["$ ffrf-advisor " + " ".join(EXAMPLE), *shown])


def readme_blocks() -> dict[str, str]:
    return {"example": readme_example()}


# ------------------------------------------------------------------ docs/elements.md
def elements_blocks() -> dict[str, str]:
    """docs/elements.md's table: io.support's, the one `formats` prints."""
    from ffrf_advisor.io import support
    return {"elements": support.markdown()}


# ------------------------------------------------------------------ main
def rendered() -> dict[Path, str]:
    """Every file with its blocks as the tool would write them now."""
    out = {}
    for path, blocks in ((SAMPLES_MD, samples_blocks()), (README, readme_blocks()), (ELEMENTS_MD, elements_blocks())):
        text = path.read_text()
        for marker, content in blocks.items():
            text = replace_block(text, marker, content)
        out[path] = text
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="write nothing; exit 1 when a block is out of date")
    args = parser.parse_args(argv)
    stale = []
    for path, text in rendered().items():
        if path.read_text() != text:
            stale.append(path)
            if not args.check:
                path.write_text(text)
        print(f"{'stale' if args.check and path in stale else 'wrote' if path in stale else 'unchanged'}: "
              f"{os.path.relpath(path, ROOT)}")
    return 1 if args.check and stale else 0


if __name__ == "__main__":
    sys.exit(main())
