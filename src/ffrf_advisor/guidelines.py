"""Guideline levels I-IV as decision rules (theory section 8, G section 8)."""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .amplitudes import Amplitudes
from .body import FlexibleBody
from .errors import FFRFError
from .names import LEVELS
from .adequacy import basis_errors, modal_widening_stress
from .response import r_cf2, r_cor
from .predict import MARGIN, Candidate, candidate_sets, level_of, predictions
from .significance import Significance
from .situation import CONNECTIONS, RULE_SETS, Situation
from .terms import is_lagrangian, lagrangian_superset, ordered
from .units import TIME

DEFORMATION_CORIOLIS = ("cor_quad", "cor_coupling")  # with cor1: the paper's full Coriolis (G IV)


@dataclass(frozen=True)
class Rule:
    """One decision: the number, its threshold, whether it fired (None: not evaluated) and why."""

    rule: str      # I, II, III, IV
    name: str
    value: float | None
    threshold: float | None
    fired: bool | None
    terms: tuple[str, ...]
    reason: str


@dataclass(frozen=True)
class Advice:
    """The level, its exact term set, the evidence, and whether the set is Lagrangian (theory sections 5, 8);
    with predicted errors (docs/advice.md) every candidate set with its predictions and cost."""

    level: str
    terms: tuple[str, ...]
    rules: tuple[Rule, ...]
    warnings: tuple[str, ...]
    candidates: tuple[Candidate, ...] = ()
    operating_point: str = ""

    @property
    def lagrangian(self) -> bool:
        return is_lagrangian(self.terms)

    @property
    def lagrangian_superset(self) -> tuple[str, ...] | None:
        return lagrangian_superset(self.terms)

    @property
    def decided_by(self) -> str:
        """One sentence naming the rule that decided the level, with its value and threshold: with predicted
        errors the dearest set rejected below the advised one (else the advised set's own margin); with the
        paper's rules the highest fired rule."""
        if any(r.name == "advised" for r in self.rules):
            rejected = [r for r in self.rules if r.fired and r is not BASELINE and r.name != "advised"]
            return (rejected or [r for r in self.rules if r.name == "advised"])[-1].reason
        fired = [r for r in self.rules if r.fired and r.value is not None]
        if not fired:
            return "no measure above its threshold: level I"
        r = max(fired, key=lambda r: LEVELS.index(r.rule))
        return f"rule {r.rule} ({r.name}) {r.value:.3g} > threshold {r.threshold:g}: {r.reason}"


BASELINE = Rule("I", "baseline", None, None, True, ("gyro0",), "gyroscopic term with I0 is always kept")


# ------------------------------------------------------------------ rules
def _per_second(body: FlexibleBody) -> float:
    """Factor from 1/s to 1/(body time unit)."""
    return float(TIME[body.units.time])


def _rule_II(body, amp: Amplitudes, sit: Situation, w_op) -> Rule:
    thr = sit.threshold("widening_stress")
    if sit.widening is not None:
        return Rule("II", "widening", None, None, sit.widening, ("cf1",) if sit.widening else (),
                    "centrifugal widening / stress recovery " + ("matters" if sit.widening else "does not matter")
                    + " (user)")
    if w_op is None:
        return Rule("II", "widening", None, thr, None, (), "not evaluated: no operating speed")
    exact = body.static_centrifugal is not None and sit.spin_axis is None
    if body.sigma_max is None and not exact:
        return Rule("II", "widening", None, thr, None, (), "not evaluated: no modal stress data")
    if exact:  # the exact static FE solution per principal axis (theory 11): right whatever the kept modes
        stress = [body.static_centrifugal.sigma[k] * w_op**2 for k in _principal_indices(sit)]
        source = "exact static FE solution (theory 11)"
    else:
        stress = [modal_widening_stress(body, a) * w_op**2 for a in sit.axes(body)]
        source = "kept modes, sum |q_c,p| sigma_p" + ("" if body.static_centrifugal is None
                                                        else "; the exact solution is per principal axis only")
    k = int(np.argmax(stress))  # the largest centrifugal stress over the spin axes decides
    value = stress[k] / amp.sigma_allow
    fired = value > thr
    return Rule("II", "widening", value, thr, fired, ("cf1",) if fired else (),
                f"static centrifugal stress at w_op is {value:.2%} of sigma_allow ({_axis_text(sit, k)}; "
                f"{source})")


def _basis_warnings(body: FlexibleBody, sit: Situation, w_op) -> list[str]:
    """Principal axes whose centrifugal deflection the kept modes miss (theory 11), with the fix; none for a body
    at rest (w_op 0: no centrifugal load, nothing to miss)."""
    if body.static_centrifugal is None or w_op == 0:
        return []
    thr, s = sit.threshold("basis_error"), (1.0 if w_op is None else w_op)
    at = f"per (rad/{body.units.time})^2" if w_op is None else "at w_op"
    out = []
    for k, e in enumerate(basis_errors(body)):
        if e > thr:
            exact = body.static_centrifugal.sigma[k] * s**2
            modal = "n/a" if body.sigma_max is None else f"{modal_widening_stress(body, np.eye(3)[k]) * s**2:.3g}"
            out.append(f"principal axis {k + 1}: the kept modes miss the centrifugal deflection (energy-norm "
                       f"error {e:.2f} > {thr:g}); widening stress {at} {exact:.3g} {body.units.stress} exact, "
                       f"{modal} from the modes; fix: ffrf-advisor augment BODY -o OUT --axes {k + 1}")
    return out


def _yield_warning(body: FlexibleBody, amp: Amplitudes, sit: Situation, w_op) -> list[str]:
    """The body yields at w_op: the static centrifugal stress of rule II above sigma_allow itself."""
    stress = _rule_II(body, amp, replace(sit, widening=None), w_op)
    if stress.value is None or stress.value <= 1:
        return []
    return [f"the body yields at this speed: {stress.reason}, sigma_allow = {amp.sigma_allow:g} {body.units.stress}"]


def _principal_indices(sit: Situation) -> list[int]:
    return list(range(3)) if sit.principal_axis is None else [sit.principal_axis - 1]


def _axis_text(sit: Situation, k: int) -> str:
    """The k-th axis evaluated, in words."""
    if sit.spin_axis is not None:
        return "spin axis " + ", ".join(f"{x:.3g}" for x in sit.axes()[0])
    return f"principal axis {_principal_indices(sit)[k] + 1}"


def _worst_axis(body: FlexibleBody, sit: Situation, measure) -> tuple[float, int]:
    """(largest value of ``measure(a)`` over the spin axes, its axis index)."""
    values = [measure(a) for a in sit.axes(body)]
    k = int(np.argmax(values))
    return float(values[k]), k


def _speed_ratio(body: FlexibleBody, sit: Situation) -> tuple[float | None, list[str]]:
    """w_op / (2 pi f_sys), both per second; f_sys defaults to the body's first flexible frequency."""
    warnings = []
    f_sys = sit.f_sys
    if f_sys is None:
        f_sys = body.frequencies_hz[0] / _per_second(body)
        warnings.append(f"f_sys not given: using the body's first flexible frequency {f_sys:.4g} Hz "
                        "(the assembled system's is usually lower)")
    if sit.w_op is None:
        return None, warnings
    return sit.w_op / (2 * math.pi * f_sys), warnings


def advise(body: FlexibleBody, amp: Amplitudes, sig: Significance, sit: Situation) -> Advice:
    """The level, the exact term set and the evidence: the cheapest set whose predicted response errors stay
    within the tolerance (docs/advice.md), or with ``sit.rules == "paper"`` the paper's rules (theory 8)."""
    if sit.connection not in CONNECTIONS:
        raise FFRFError(f"connection {sit.connection!r}: expected one of {', '.join(CONNECTIONS)}")
    if sit.rules not in RULE_SETS:
        raise FFRFError(f"--rules {sit.rules!r}: expected one of {', '.join(RULE_SETS)}")
    per_s = _per_second(body)
    w_op = None if sit.w_op is None else sit.w_op * per_s  # rad per body time unit
    stiff = sit.connection == "stiff"
    warnings = list(amp.warnings)
    if sit.rules != "predicted":
        level, terms, rules, more = _paper_rules(body, amp, sig, sit, w_op, stiff)
        candidates: tuple[Candidate, ...] = ()
        warnings += more
    else:
        level, terms, rules, candidates = _predicted(body, amp, sit, stiff)
    warnings += _basis_warnings(body, sit, w_op) + _yield_warning(body, amp, sit, w_op)
    if sig.not_evaluable:
        warnings.append(f"decided without {', '.join(sig.not_evaluable)} ({_lacking(body)}); "
                        "the level may be too low for beam-like or rotationally soft bodies")
    if w_op is not None and sig.s_crit is not None and np.isfinite(sig.s_crit).any():
        k = int(np.argmin(sig.s_crit))
        r = w_op / sig.s_crit[k]
        if r > sit.threshold("softening_warning"):
            warnings.append(f"operating speed is {r:.0%} of the centrifugal-softening limit about axis {k + 1} "
                            f"({sig.s_crit[k] / per_s:.4g} rad/s): {softening_situation(sig, k, per_s)}")
    return Advice(level, terms, tuple(rules), tuple(warnings), candidates, operating_point(sit))


def operating_point(sit: Situation) -> str:
    """The operating point in words: speed with unit (or at rest), axes, connection, f_sys, tolerance, rules,
    and the config file applied."""
    rules = {"paper": "the paper's rules and thresholds", "thresholds": "the rules of theory 8 with thresholds",
             "predicted": f"predicted errors within {sit.tolerance:g} (margin {MARGIN:g})"}[sit.rules]
    if sit.at_rest:
        speed = ("at rest (no speed given: only what holds at rest was evaluated; give --speed)"
                 if sit.w_op is None else "at rest (speed 0)")
    else:
        speed = f"{sit.w_op:.4g} rad/s ({sit.w_op * 30 / math.pi:.4g} rpm)"
        if sit.speed_range is not None:
            speed = (f"{sit.speed_range[0]:.4g}..{sit.speed_range[1]:.4g} rad/s (the range's top and speeds "
                     "below it, the worst decides)")
    axes = ("about spin axis " + ", ".join(f"{x:.3g}" for x in sit.spin_axis) if sit.spin_axis is not None
            else f"about principal axis {sit.principal_axis}" if sit.principal_axis is not None
            else "about each principal axis (the worst decides)")
    modes = "" if sit.excitation == "vibration" else ", modes driven by the rigid motion only"
    f_sys = "" if sit.f_sys is None else f", f_sys {sit.f_sys:.4g} Hz"
    config = "" if sit.config is None else f"; options from {sit.config}"
    return f"{speed} {axes}, connection {sit.connection}{f_sys}{modes}, {rules}{config}"


def _speeds(sit: Situation) -> list[float]:
    """Speeds [rad/s] the predictions are evaluated at: w_op, or the range's ends and 0.1, 0.3, 0.6 of its top."""
    if sit.at_rest:
        return []
    if sit.speed_range is None:
        return [sit.w_op]
    low, high = sit.speed_range
    return sorted({low, high, *(f * high for f in (0.1, 0.3, 0.6) if f * high > low)} - {0.0})


def _predicted(body: FlexibleBody, amp: Amplitudes, sit: Situation, stiff: bool):
    """(level, terms, rules, candidates): the lowest level, then the cheapest set, whose predicted errors all
    stay below tolerance / MARGIN (docs/advice.md); each cheaper set appears as a rule with what excluded it."""
    per_s = _per_second(body)
    sets = candidate_sets(body, stiff)
    if sit.widening:  # the user says widening matters: cf1 is kept whatever its prediction
        sets = [(label, terms) for label, terms in sets if "cf1" in terms]
    found = predictions(body, sets, sit.axes(body), [s * per_s for s in _speeds(sit)], amp.q_max,
                        amp.sigma_allow, stiff, sit.excitation)
    if sit.widening is False:
        found = [replace(c, errors={**c.errors, "static": 0.0}) for c in found]
    rank = lambda c: (LEVELS.index(level_of(c.terms)), round(c.cost, 9), len(c.terms))  # noqa: E731
    chosen = min((c for c in found if c.meets(sit.tolerance)), key=rank)
    thr = sit.tolerance / MARGIN
    rules = [BASELINE]
    for c in sorted(found, key=rank):
        if rank(c) >= rank(chosen):
            break
        kind, value = c.worst
        added = tuple(t for t in chosen.terms if t not in c.terms)
        rules.append(Rule(level_of(c.terms), c.label, value, thr, True, added,
                          f"{c.label} ({', '.join(c.terms)}): predicted {kind} error {value:.3g} "
                          f"({_axis_text(sit, c.axes[kind])}) > {thr:g}: needs {', '.join(added) or 'nothing'}"))
    kind, value = chosen.worst
    reason = ("at rest every prediction vanishes (no spin, no centrifugal load)" if sit.at_rest else
              f"largest predicted error {kind} {value:.3g} ({_axis_text(sit, chosen.axes[kind])}) <= {thr:g}")
    rules.append(Rule(level_of(chosen.terms), "advised", value, thr, True, chosen.terms,
                      f"{chosen.label}: the lowest level, then the cheapest set, whose predicted errors stay below "
                      f"the tolerance {sit.tolerance:g} / {MARGIN:g}; {reason}; right-hand side "
                      f"{chosen.cost:.2f} of the full set's"))
    return level_of(chosen.terms), chosen.terms, rules, tuple(found)


def _paper_rules(body, amp: Amplitudes, sig: Significance, sit: Situation, w_op, stiff: bool):
    """(level, terms, rules, warnings) by the paper's rules with its thresholds (theory section 8)."""
    rules = [BASELINE]
    rules.append(_rule_II(body, amp, sit, w_op))
    measures = {"dI_L": (sig.dI_L, "inertia_lin"), "dI_Q": (sig.dI_Q, "inertia_quad"),
                "dI_fT": (sig.dI_fT, "coupling"), "dI_Tf": (sig.dI_Tf, "coupling")}
    rule3_fired = False
    for name, (values, term) in measures.items():
        thr = sit.threshold(name)
        if values is None:
            rules.append(Rule("III", name, None, thr, None, (), f"not evaluable: {_lacking(body)}"))
            continue
        value = values[..., :sig.n_ratio].max()  # the first n_ratio modes, like the ratios (theory 7)
        over = value > thr
        fired = over and not stiff
        rule3_fired |= fired
        reason = (f"max {name} = {value:.3g} {'>' if over else '<='} {thr:g}"
                  + ("; body stiffly connected: I0 suffices" if over and stiff else ""))
        rules.append(Rule("III", name, float(value), thr, fired, (term,) if fired else (), reason))
    rules.append(_rule_cf2(body, sit, w_op, stiff))  # cf2 alone does not call for Coriolis terms
    ratio, warnings = _speed_ratio(body, sit)
    rules += _rules_IV(body, sig, sit, w_op, ratio, stiff, rule3_fired)
    level = max((r.rule for r in rules if r.fired and r.terms), key=LEVELS.index)
    rules.append(_closure(ordered({t for r in rules for t in r.terms}), level, stiff, body.geometric is not None))
    return level, ordered({t for r in rules for t in r.terms}), rules, warnings


def softening_situations(a) -> list[str] | None:
    """Theory 9's situation about each principal axis of an analysis, None without geometric stiffness."""
    sig = a.significance
    if sig.s_crit_stiffened is None:
        return None
    return [softening_situation(sig, k, _per_second(a.body)) for k in range(3)]


def softening_situation(sig: Significance, k: int, per_s: float) -> str:
    """Which of theory 9's two situations applies about principal axis k, from s_crit with and without G."""
    if sig.s_crit_stiffened is None:
        return ("the linear FFRF without geometric stiffening loses validity there (the body carries no geometric "
                "stiffness: an invariants file, or FE data without a material)")
    stiff = sig.s_crit_stiffened[k]
    if not np.isfinite(stiff) or stiff > 2 * sig.s_crit[k]:
        return ("the body extends across this axis: centrifugal tension stiffens it and cancels the softening "
                + ("entirely" if not np.isfinite(stiff) else f"up to {stiff / per_s:.4g} rad/s")
                + " (geo_stiff, theory 9)")
    return (f"the body is long along this axis: the softening is real, a whirling speed (with stiffening "
            f"{stiff / per_s:.4g} rad/s)")


def _closure(terms: tuple[str, ...], level: str, stiff: bool, has_G: bool) -> Rule:
    """Whole energy groups for a body not stiffly connected: its rotation follows from its own equations, which
    conserve energy and angular momentum only with Lagrangian sets (theory 5; without, a free spin drifts by
    the size of the neglected terms' partners: docs/verification.md)."""
    ffrf = tuple(t for t in terms if t != "geo_stiff")  # geo_stiff lies outside the kinetic energy (theory 9)
    closed = lagrangian_superset(ffrf)
    closed += ("geo_stiff",) if has_G and "cf2" in closed else ()  # cf2 never without its stiffening
    added = tuple(t for t in closed if t not in terms)
    if stiff:
        return Rule(level, "lagrangian_closure", None, None, False, (),
                    "stiffly connected: the rules' set is kept as it is")
    return Rule(level, "lagrangian_closure", None, None, bool(added), added,
                ("whole energy groups (a free body's set must be Lagrangian): adds " + ", ".join(added)) if added
                else "the rules' set is Lagrangian")


def _lacking(body: FlexibleBody) -> str:
    return f"the body has no {' and no '.join(body.integrals.missing)} (e.g. an invariants file without I9)"


def _rule_cf2(body: FlexibleBody, sit: Situation, w_op, stiff: bool) -> Rule:
    """cf2 when r_cf2 at w_op exceeds its threshold (theory 7, 8): its frequency shift matters whether or not the
    widening does (a plate spun about its normal: no in-plane stress, out-of-plane modes softened by 25 %)."""
    thr = sit.threshold("r_cf2")
    if "W2" in body.integrals.missing:
        return Rule("III", "cf2", None, thr, None, (), f"not evaluable: {_lacking(body)}")
    if w_op is None:
        return Rule("III", "cf2", None, thr, None, (), "r_cf2 not evaluated: no operating speed")
    value, k = _worst_axis(body, sit, lambda a: r_cf2(body, a, w_op))
    over = value > thr
    fired = over and not stiff
    geo = body.geometric is not None
    terms = ("cf2", "geo_stiff") if geo else ("cf2",)
    reason = (f"r_cf2 = {value:.3g} {'>' if over else '<='} {thr:g} at w_op ({_axis_text(sit, k)}): change of the "
              "static centrifugal response or of the frequencies by cf2" + (" with geo_stiff (decided together: "
                                                                           "softening without the stiffening that "
                                                                           "balances it is the wrong physics)" if geo else "")
              + ("; stiffly connected" if over and stiff else ""))
    return Rule("III", "cf2", value, thr, fired, terms if fired else (), reason)


def _rules_IV(body, sig, sit, w_op, ratio, stiff, inertia_fired) -> list[Rule]:
    """cor1 when w_op / (2 pi f_sys) is not well below 1; cor_quad and cor_coupling when, besides, an inertia or
    coupling measure of rule III fired or r_cor at w_op exceeds its threshold (theory 8)."""
    thr = sit.threshold("speed_ratio")
    if ratio is None:
        return [Rule("IV", "speed_ratio", None, thr, None, (), "not evaluated: no operating speed")]
    fast = ratio >= thr
    fired = fast and not stiff
    rules = [Rule("IV", "speed_ratio", float(ratio), thr, fired, ("cor1",) if fired else (),
                  f"w_op / (2 pi f_sys) = {ratio:.3g} {'>=' if fast else '<'} {thr:g}"
                  + ("; stiffly connected" if fast and stiff else ""))]
    cthr = sit.threshold("r_cor")
    if body.integrals.missing:
        full = fired and inertia_fired
        reason = ("rule III fired (beam-like or rotationally soft body)" if full
                  else f"r_cor not evaluable: {_lacking(body)}")
        rules.append(Rule("IV", "cor_deformation", None, cthr, True if full else (None if fired else False),
                          DEFORMATION_CORIOLIS if full else (), reason))
        return rules
    value, k = _worst_axis(body, sit, lambda a: r_cor(body, a, w_op))
    full = fired and (inertia_fired or value > cthr)
    reason = (("rule III fired (beam-like or rotationally soft body); " if inertia_fired else "")
              + f"r_cor = {value:.3g} {'>' if value > cthr else '<='} {cthr:g} at w_op ({_axis_text(sit, k)}): "
              "frequency change by the deformation-dependent Coriolis terms"
              + ("" if fired else "; not added: the speed ratio does not call for Coriolis terms"))
    rules.append(Rule("IV", "cor_deformation", value, cthr, full, DEFORMATION_CORIOLIS if full else (), reason))
    return rules
