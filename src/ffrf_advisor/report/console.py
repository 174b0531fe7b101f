"""Rich console rendering of a body summary (the `info` command)."""
from __future__ import annotations

import unicodedata
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.markup import escape
from rich.padding import Padding
from rich.table import Table
from rich.text import Text

from ..adequacy import summary as basis_summary
from ..body import FlexibleBody
from ..guidelines import softening_situations
from ..checks import Check, density_text, density_warnings
from ..predict import KINDS, MARGIN, level_of
from ..sim.cost import cost_ratio
from ..terms import lagrangian_status


def _unit(text: str) -> str:
    """``[text]`` escaped, so that rich prints a unit in brackets instead of reading it as markup."""
    return escape(f"[{text}]")


SHOWN_CHARS, SHOWN_NOTES = 200, 20  # what a body file may put on the terminal per field and in notes


def shown(text, limit: int = SHOWN_CHARS) -> str:
    """Text from a body file made safe to display: control characters (terminal escapes) replaced by '?',
    markup escaped, cut to ``limit`` characters with the count of the rest."""
    text = "".join("?" if unicodedata.category(c) == "Cc" else c for c in str(text))
    extra = len(text) - limit
    return escape(text[:limit]) + (f"... (+{extra} characters)" if extra > 0 else "")


def _matrix(a: np.ndarray) -> str:
    return "\n".join("  ".join(f"{x:>12.5e}" for x in row) for row in np.atleast_2d(a))


def body_summary(console: Console, body: FlexibleBody, checks: list[Check]) -> None:
    """Mass, CoM, I0, eigenfrequencies and modal stress, and the checks of theory section 4."""
    u = body.units
    console.print(f"[bold]{shown(body.name)}[/bold]  units {u}  ({body.provenance.mass_matrix} mass; "
                  f"{shown(body.provenance.source)})")
    notes = body.provenance.notes
    for note in notes[:SHOWN_NOTES]:
        console.print(f"  {shown(note)}")
    if len(notes) > SHOWN_NOTES:
        console.print(f"  ... {len(notes) - SHOWN_NOTES} more notes")
    console.print(f"mass      {body.mass:.6e} {u.mass}; {density_text(body)}", highlight=False)
    console.print(f"CoM       [{', '.join(f'{x:.4e}' for x in body.com)}] {u.length}")
    offset = next((c for c in checks if c.name == "com_offset"), None)
    if offset is not None and offset.passed:
        console.print(f"          at the frame origin to round-off: |CoM| / size = {offset.value:.1e} "
                      f"<= {offset.tolerance:.0e}")
    console.print(f"I0 {_unit(f'{u.mass} {u.length}^2')}\n{_matrix(body.I0)}")
    fitted_table(console, f"{body.nf} flexible modes", ["mode", f"f {_unit(u.frequency)}",
                 f"lambda {_unit(f'1/{u.time}^2')}", f"sigma_vM,max at q=1 {_unit(u.stress)}"],
                 [[str(p + 1), f"{body.frequencies_hz[p]:.4f}", f"{body.eigenvalues[p]:.6e}",
                   "-" if body.sigma_max is None else f"{body.sigma_max[p]:.4e}"] for p in range(body.nf)])
    checks_table(console, checks)
    for w in density_warnings(body):
        console.print(f"[yellow]warning[/yellow]: {escape(w)}", highlight=False)
    failed = [c for c in checks if not c.passed]
    if failed:
        frame = {"com_offset", "principal_axes"}
        fix = ("fix: `ffrf-advisor convert BODY OUT --transform` moves the frame to the CoM and the principal axes "
               "(theory section 4)" if {c.name for c in failed} <= frame
               else "the stiffness is stored: the basis can be transformed (theory section 4)"
               if body.nodal_summary() is not None and body.nodal_summary().stiffness
               else "no stiffness matrix: results carry the caveat that these assumptions fail")
        console.print(f"[yellow]warning[/yellow]: {len(failed)} assumption(s) fail: "
                      + "; ".join(c.assumption for c in failed) + f" — {fix}")


def checks_table(console: Console, checks: list[Check]) -> None:
    """Each check's value against its tolerance, pass (green) or FAIL (red)."""
    fitted_table(console, "checks (theory section 4)", ["check", "value", "tolerance", "result"],
                 [[c.name, f"{c.value:.3e}", f"{'>' if c.name == 'mass' else '<='} {c.tolerance:.1e}",
                   "[green]pass[/green]" if c.passed else "[red]FAIL[/red]"] for c in checks], left=("check", "result"))


def _lagrangian(adv, nf: int) -> str:
    """lagrangian_status of the advised set; when not Lagrangian, its smallest Lagrangian superset and cost."""
    status = lagrangian_status(adv.terms)
    if status != "not Lagrangian":
        return f"   ({status})"
    superset = adv.lagrangian_superset
    return ("\n[yellow]not Lagrangian[/yellow] (theory 5: energy and |H| drift); smallest Lagrangian superset: "
            + (f"{', '.join(superset)} (right-hand side x{cost_ratio(superset, adv.terms, nf):.2f})" if superset
               else "none"))


def analysis_summary(console: Console, a, warnings: Console | None = None, modes: str | None = None) -> None:
    """Level and term set on top, then amplitudes, significance tables and the evidence per rule; the warnings
    on ``warnings`` (the CLI: stderr) when given; ``modes``: the mode-set line (modeset, theory 12)."""
    b, amp, sig, adv = a.body, a.amplitudes, a.significance, a.advice
    u = b.units
    console.print(f"[bold]{shown(b.name)}[/bold]: level [bold]{adv.level}[/bold]   terms: {', '.join(adv.terms)}"
                  + _lagrangian(adv, b.nf))
    console.print(f"operating point: {adv.operating_point}", highlight=False)
    console.print(f"body: mass {b.mass:.4g} {u.mass}, {density_text(b)}", highlight=False)
    console.print(f"decided by: {adv.decided_by}", highlight=False)
    if modes:
        console.print(f"mode set: {modes}", highlight=False)
    for w in adv.warnings:
        (warnings or console).print(f"[yellow]warning[/yellow]: {w}")
    _candidates(console, a)
    headers = ("mode", f"f {_unit(u.frequency)}", f"q_max {_unit(f'sqrt({u.mass}) {u.length}')}", "governs",
               "sigma / sigma_allow", "deflection / L")
    rows = [(str(p + 1), f"{b.frequencies_hz[p]:.4g}", f"{amp.q_max[p]:.4e}", amp.governs[p],
             "-" if amp.stress_utilisation is None else f"{amp.stress_utilisation[p]:.3g}",
             "-" if amp.deflection_ratio is None else f"{amp.deflection_ratio[p]:.3g}") for p in range(b.nf)]
    fitted_table(console, f"maximum modal coordinates (theory 6; q_cap {amp.q_cap:.4g}, "
                          f"sigma_allow {amp.sigma_allow:.4g} {u.stress})", headers, rows, left=("governs",))
    rows = [[str(k + 1), *(_max(sig.max_first(name), k) for name in ("dI_L", "dI_Q", "dI_fT")),
             "n/a" if sig.s_crit is None else f"{sig.s_crit[k]:.4g}",
             "n/a" if sig.s_crit_stiffened is None else f"{sig.s_crit_stiffened[k]:.4g}"] for k in range(3)]
    fitted_table(console, f"significance per axis (max over the first {sig.n_ratio} modes; theory 7)",
                 ["axis", "dI_L", "dI_Q", "dI_fT", f"s_crit {_unit(f'rad/{u.time}')}", "with G"], rows)
    console.print(f"dI_Tf max {_max(sig.max_first('dI_Tf'))};  "
                  f"Coriolis ratio {_ratio(sig.coriolis)} (as in the paper {_ratio(sig.coriolis_paper)});  "
                  f"centrifugal ratio {_ratio(sig.centrifugal)} (as in the paper {_ratio(sig.centrifugal_paper)}); "
                  f"first {sig.n_ratio} modes, {sig.sign_search or 'not evaluable'}", highlight=False)
    for k, text in enumerate(softening_situations(a) or ()):
        console.print(f"softening about axis {k + 1}: {text}", highlight=False)
    if sig.not_evaluable:
        console.print(f"not evaluable (n/a): {', '.join(sig.not_evaluable)}")
    fitted_table(console, "magnitudes (G Tables 2, 3)", ["matrix", "max |entry|", "mean |nonzero|", "Frobenius"],
                 [[name, f"{m.max_abs:.3e}", f"{m.mean_nonzero:.3e}", f"{m.frobenius:.3e}"]
                  for name, m in sig.magnitudes.items()])
    _basis_table(console, a)
    _evidence(console, adv.rules)


def fitted_table(console: Console, title: str, headers, rows, left=(), prose: str | None = None) -> None:
    """A table whose columns are as wide as their longest value or header (where that is wider than the
    console, header word: headers break at blanks, values never; the ``prose`` column, a left-justified text,
    wraps at blanks into the width the others leave, at least its longest word); where that is still wider than
    the console, one stacked block per row instead (right at any width). Where no value wraps, ``_boxed`` draws
    it line by line as rich would (rich lays out each cell on its own: 0.5 ms a row)."""
    plain = [_plain(h) for h in headers]
    text = [[_plain(v) for v in r] for r in rows]  # what a value shows: its markup (a colour) takes no width
    frame = 3 * len(headers) + 1
    k = headers.index(prose) if prose in headers else None
    widths = _widths(text, plain, k, whole=True)
    if sum(widths) + frame > console.width:
        widths = _widths(text, plain, k, whole=False)
    wraps = False  # a prose value wraps in its cell
    if k is not None:
        widths[k] = max(widths[k], min(max(len(r[k]) for r in text), console.width - frame - sum(widths) + widths[k]))
        wraps = any(len(r[k]) > widths[k] for r in text)
    if sum(widths) + frame <= console.width:
        t = Table(title=title)
        for h, w in zip(headers, widths):
            t.add_column(h, justify="left" if h in left or h == prose else "right", width=w)
        if not wraps and rows:
            _boxed(console, t, widths, rows)
            return
        for row in rows:
            t.add_row(*row)
        console.print(t)
        return
    console.print(title, highlight=False)
    for row in text:
        console.print(f"{plain[0]} {row[0]}:", highlight=False)
        console.print(Padding(escape("; ".join(f"{h} {v}" for h, v in zip(plain[1:], row[1:]))), (0, 0, 0, 4)),
                      highlight=False)


def _boxed(console: Console, table: Table, widths: list[int], rows) -> None:
    """``table`` (a rich Table with a title and its columns, no rows yet) with ``rows`` of one line each, drawn
    line by line as rich draws it: the title wrapped and centred over the table's width, the headers wrapped
    into their columns and aligned to the bottom, the box of table.box; the body as plain lines (a value's
    markup rendered where it has some). rich lays out every cell of a table on its own (a 100-mode body's
    q_max table: 25-30 ms); this takes a few."""
    pad = [w + 2 for w in widths]
    box = table.box.substitute(console.options, safe=console.safe_box)
    title = console.render_str(table.title or "", style="table.title", highlight=False)
    for line in title.wrap(console, sum(pad) + len(pad) + 1, justify="center") if table.title else ():
        console.print(line, no_wrap=True, crop=False)
    heads = [console.render_str(c.header, style="table.header", highlight=False).wrap(console, w, justify=c.justify)
             for c, w in zip(table.columns, widths)]
    height = max(len(h) for h in heads)
    console.print(box.get_top(pad), highlight=False, no_wrap=True, crop=False)
    for k in range(height):
        line = Text(box.head_left)
        for i, (h, w) in enumerate(zip(heads, widths)):
            edge = Text(" ", style="table.header")
            line.append_text(edge + h[k - height + len(h)] + edge if k >= height - len(h)
                             else Text(" " * (w + 2), style="table.header"))  # above a shorter header
            line.append(box.head_right if i == len(widths) - 1 else box.head_vertical)
        console.print(line, no_wrap=True, crop=False)
    console.print(box.get_row(pad, "head"), highlight=False, no_wrap=True, crop=False)
    if any("[" in v or not v.isascii() for row in rows for v in row):  # markup rendered, cells measured as rich
        body = Text("\n").join(Text(box.foot_left) + Text(box.foot_vertical).join(
            Text(" ") + _padded(_cell(v), w, c.justify) + Text(" ") for v, w, c in zip(row, widths, table.columns))
            + Text(box.foot_right) for row in rows)
    else:
        just = [str.ljust if c.justify == "left" else str.rjust for c in table.columns]
        body = "\n".join(box.foot_left + box.foot_vertical.join(f" {j(v, w)} " for v, w, j in zip(row, widths, just))
                         + box.foot_right for row in rows)
    console.print(body, markup=False, highlight=False, no_wrap=True, crop=False)
    console.print(box.get_bottom(pad), highlight=False, no_wrap=True, crop=False)


def _cell(value: str) -> Text:
    """A value as rich shows it in a cell: its markup rendered."""
    return Text.from_markup(value, emoji=False) if "[" in value else Text(value)


def _padded(text: Text, width: int, justify: str) -> Text:
    """``text`` padded with blanks to ``width`` on the side ``justify`` leaves free."""
    gap = " " * max(width - text.cell_len, 0)
    return text + gap if justify == "left" else Text(gap) + text


def _plain(value: str) -> str:
    """The text ``value`` shows, its rich markup (``[green]``) taken out."""
    return _cell(value).plain if "[" in value else value


def _widths(rows, headers: list[str], prose: int | None, whole: bool) -> list[int]:
    """``fitted_table``'s column widths: the longest value (word, in the ``prose`` column) or header (``whole``)
    or header word."""
    head = (lambda h: [len(h)]) if whole else (lambda h: [len(w) for w in h.split()])  # noqa: E731
    return [max([len(w) for r in rows for w in r[k].split()] + head(h)) if k == prose
            else max([len(r[k]) for r in rows] + head(h)) for k, h in enumerate(headers)]


def _candidates(console: Console, a) -> None:
    """Each candidate set with its predicted errors (docs/advice.md) and cost, the advised one marked."""
    adv, sit = a.advice, a.options.situation
    if not adv.candidates:
        return
    rows = [[c.label, level_of(c.terms), f"{c.cost:.2f}", *(f"{c.errors[k]:.2g}" for k in KINDS),
             ("yes" if c.meets(sit.tolerance) else "no") + ("<-" if set(c.terms) == set(adv.terms) else "")]
            for c in sorted(adv.candidates, key=lambda c: c.cost)]
    fitted_table(console, f"predicted response errors per term set (adequate: all <= {sit.tolerance:g} / "
                 f"{MARGIN:g}; docs/advice.md)", ["set", "level", "rhs", *KINDS, "ok"], rows, left=("set",))


def _evidence(console: Console, rules) -> None:
    """One block per rule, stacked (right at any width): level, measure, value against threshold and outcome
    on one line, the terms it adds and the reason indented below."""
    console.print("[bold]evidence per rule (theory 8)[/bold]")
    for rule in rules:
        fired = "not evaluated" if rule.fired is None else ("fired" if rule.fired else "not fired")
        value = "" if rule.value is None else f"{rule.value:.3g}"
        if rule.threshold is not None and rule.value is not None:
            value += f" (threshold {rule.threshold:g})"
        console.print(f"{rule.rule:<4}{rule.name:<19}{value + '  ' if value else ''}{fired}", highlight=False)
        terms = f"-> {', '.join(rule.terms)}\n" if rule.terms else ""
        console.print(Padding(escape(terms + rule.reason), (0, 0, 0, 4)), highlight=False)


def _basis_table(console: Console, a) -> None:
    """Can the kept modes carry the centrifugal load (theory 11): per principal axis."""
    w_op, u = a.options.situation.w_op, a.body.units
    rows = basis_summary(a.body, w_op)
    if rows is None:
        console.print("basis adequacy (theory 11): not available (needs the body's FE data and material)")
        return
    at = f"at {w_op:.4g} rad/s" if w_op is not None else "per (rad/s)^2"
    fitted_table(console, f"can the kept modes carry the centrifugal load? (theory 11, {at})",
                 ["axis", "energy error", f"exact stress {_unit(u.stress)}", f"modal stress {_unit(u.stress)}"],
                 [[str(r["axis"]), f"{r['energy_error']:.3g}", f"{r['sigma_exact']:.3g}",
                   "n/a" if r["sigma_modal"] is None else f"{r['sigma_modal']:.3g}"] for r in rows])


def _max(values, k=None) -> str:
    """max of a measure (row k), or 'n/a' when it is not evaluable."""
    if values is None:
        return "n/a"
    return f"{np.max(values if k is None else values[k]):.3e}"


def _ratio(r) -> str:
    if r is None:
        return "n/a"
    return f"{r.text()} (|num| {r.numerator:.3e}, |den| {r.denominator:.3e})"


def simulation_report(console: Console, s: dict, output) -> None:
    """The summary of one simulation run (sim.output.summary) in a few lines."""
    lag = lagrangian_status(s["terms"])
    console.print(f"terms: {', '.join(s['terms'])} ({lag})", highlight=False)
    step = "" if s["step"] is None else f", step {s['step']:.3g} {s['units'].split('-')[-1]}"
    console.print(f"{s['integrator']}{step}: {s['steps']} steps, {s['rhs_evaluations']} right-hand sides, "
                  f"{s['wall_s']:.3g} s wall", highlight=False)
    drift = lambda x: "n/a" if x is None else f"{x:.2e}"  # noqa: E731
    console.print(f"drift (relative): energy {drift(s['energy_drift'])}, |H| {drift(s['H_drift'])}, "
                  f"quaternion norm {s['quaternion_norm_drift']:.2e}", highlight=False)
    if s["failed"]:
        console.print(f"[red]FAILED[/red] at t = {s['t_fail']:.6g}: {s['reason']}", highlight=False)
    if output is not None:
        console.print(f"wrote {output} ({s['samples']} samples)", highlight=False)


def _err(x) -> str:
    return "fail" if x is None else f"{x:.1e}"


VERIFY_COLUMNS = {"response": {"w_response": "w", "q_response": "q", "stress_peak": "peak stress",
                                "frequency": "frequency"},
                  "trajectory": {"w": "w", "orientation": f"angle {_unit('rad')}", "q": "q", "stress": "stress"}}
VERDICT_COLOUR = {"agree": "green", "conservative": "yellow", "unsafe": "red", "no verdict": "magenta"}
CRITERION_TEXT = {"response": "frequencies at the spin, means and oscillation sizes, peak stress",
                  "trajectory": "pointwise along the run; phase errors count"}


def _scene_verdict(v: dict) -> str:
    """A scene's own verdict, with why when it gives none."""
    colour = VERDICT_COLOUR[v["verdict"]]
    why = "".join(f": {u['reason']}" for u in v["unjudged"])
    return f"[{colour}]{v['verdict']}[/{colour}]{why}"


def _studies_report(console: Console, s: dict, campbell: dict, t: str) -> None:
    """The stability numbers and the Campbell errors of a verification; ``t`` the body's time unit."""
    console.print(f"RK4 step limit at rest: {s['rk4_limit_rest']['measured']:.4g} {t} measured, "
                  f"{s['rk4_limit_rest']['predicted']:.4g} {t} = 2 sqrt 2 / Omega_max", highlight=False)
    onset = s["divergence_onset"]
    if onset:
        console.print(f"softening divergence about axis {onset['axis']}: at {onset['measured']:.4g} rad/{t} "
                      f"by simulation, s_crit {onset['s_crit']:.4g} rad/{t}; without cf2 "
                      + ("bounded" if onset["bounded_without_cf2"] else "NOT bounded")
                      + ("" if onset.get("bounded_with_geo_stiff") is None else
                         "; with geo_stiff " + ("bounded" if onset["bounded_with_geo_stiff"] else "NOT bounded")),
                      highlight=False)
    console.print(campbell_line(campbell, t), highlight=False)


def campbell_line(campbell: dict, t: str) -> str:
    """The Campbell errors of each set against the scenes' reference, naming it, the axis and the speed (a JSON
    of schema 3 before the reference was named: "the full set")."""
    where = f" about principal axis {campbell['axis_of_error']} at {campbell['speed']:.4g} rad/{t}"
    return (f"Campbell, largest frequency error against the reference ({campbell.get('reference', 'full set')})"
            + where + ": " + ", ".join(f"{k} {_err(x)}" for k, x in campbell["frequency_error"].items()))


def gate_summary(results: list[dict], max_level: str) -> str:
    """One line: how many bodies are within ``max_level``, exceed it, or could not be read."""
    errors = sum(1 for r in results if r["error"])
    within = sum(1 for r in results if not r["error"] and r["within"])
    exceeding = len(results) - errors - within
    verdict = "FAILED" if errors or exceeding else "passed"
    bodies = f"{len(results)} {'body' if len(results) == 1 else 'bodies'}"
    return f"gate {verdict}: {bodies}, {within} within level {max_level}, {exceeding} above it, {errors} unreadable"


def gate_report(console: Console, warnings: Console, results: list[dict], max_level: str, point: str) -> None:
    """gate's text: the operating point, a line per body (ok / EXCEEDS / ERROR) with the rule that decided, its
    warnings on ``warnings`` (stderr), and the summary line."""
    console.print(f"operating point: {point}", highlight=False)
    for r in results:
        status = "ERROR" if r["error"] else ("ok" if r["within"] else "EXCEEDS")
        text = r["error"] or f"{r['file']}: level {r['level']} (max {max_level})"
        if r["error"] and not text.startswith(r["file"]):
            text = f"{r['file']}: {text}"  # errors that name no file get it once
        console.print(f"{status:8s} {shown(text, 2000)}", highlight=False)
        if r["analysis"] is not None:
            console.print(f"{'':8s} decided by: {r['analysis']['decided_by']}", highlight=False)
        for w in r["warnings"]:
            warnings.print(f"{shown(r['file'])}: warning: {shown(w, 2000)}", highlight=False)
    console.print(gate_summary(results, max_level), highlight=False)


def settings_report(console: Console, warnings: Console, data: dict) -> None:
    """settings' text: the level and terms, the solver's setting and how sure it is, what each term needs
    (Adams), what the solver cannot drop or add; the warnings on ``warnings`` (stderr)."""
    for w in data["warnings"]:
        warnings.print(f"warning: {w}", highlight=False)
    console.print(f"level {data['level']}: terms {', '.join(data['terms'])}")
    console.print(f"{data['solver']}: [bold]{escape(data['setting'])}[/bold]   (mapping {data['sure']})")
    console.print(f"  {escape(data['statement'])}", highlight=False)
    for term, invs in data.get("needed_invariants", {}).items():
        console.print(f"  {term:13s} " + (f"needs {', '.join(invs)}" if invs else
                                          "no invariant carries it: the solver needs its own stress stiffening "
                                          "(theory 9)"), highlight=False)
    for key, text in (("cannot_drop", "kept although the advice drops them (cost, no error)"),
                      ("cannot_add", "needed by the advice, not available: expect its error")):
        if data[key]:
            console.print(f"  {key.replace('_', ' ')}: {', '.join(data[key])}: {text}", highlight=False)
    console.print(f"source: {data['source']}", highlight=False)
    if "pattern_note" in data:
        console.print(f"note: {data['pattern_note']}", highlight=False)


def verification_report(console: Console, d: dict) -> None:
    """The verdict on top, then per scene the errors, drift and speed-up of each set, stability and Campbell."""
    v = d["verdict"]
    colour = VERDICT_COLOUR[v["verdict"]]
    console.print(f"[bold]{d['body']['name']}[/bold]: advice level {v['advised_level']} "
                  f"[{colour}]{v['verdict'].upper()}[/{colour}]", highlight=False)
    console.print(v["text"], highlight=False)
    driven = "" if d["advice"]["excitation"] == "vibration" else ", modes driven by the rigid motion only"
    console.print(f"advice at {d['advice']['speed_rad_s']:.4g} rad/s{driven}; judged by the {d['criterion']} errors "
                  f"({CRITERION_TEXT[d['criterion']]})", highlight=False)
    columns = VERIFY_COLUMNS[d["criterion"]]
    for scene in d["scenes"]:
        fitted_table(console, f"{scene['label']}: {scene['text']}; reference self-convergence "
                              f"{_err(scene['reference']['self_check']['error'])}; {_scene_verdict(scene['verdict'])}",
                     ["set", *columns.values(), "ok", "speed-up"],
                     [[r["set"], *(_err(r["errors"][k]) for k in columns), "yes" if r["meets"] else "[red]no[/red]",
                       "-" if r["speedup"] is None else f"{r['speedup']:.2f}"]
                      for r in d["results"] if r["scene"] == scene["label"]], left=("set",))
    if d["stability"] is None:
        console.print("quick: no work-precision, stability or Campbell studies (run without --quick for them)",
                      highlight=False)
    else:
        _studies_report(console, d["stability"], d["campbell"], d["body"]["units"].split("-")[-1])
    if d["figures"]:
        console.print(f"figures: {len(d['figures'])} files in {Path(d['figures'][0]).parent}", highlight=False)
