"""Run the reference and the term sets through the scenes; errors, cost, speed-up and the verdict (theory section 10).

Reference: the full term set at ``REF_RTOL`` with the exponential
integrator (sim.lawson: the modal oscillators exact, the steps set by
the spin, loads and couplings), its error estimated and,
where the estimate does not show convergence, checked by
self-convergence (verify.reference); a scene whose reference did not
converge gives no verdict. Every set is run once with the same
integrator and sampled on the reference's grid. Its cost is its
evaluations times its set's compiled seconds per evaluation, measured
once per set in a short loop (sim.timing): the speed-up column is free
of the timer's noise, and no run is repeated only to be timed (``repeats``
> 1 takes the minimum wall time of that many serial runs). A set meets the
tolerance by a criterion (``measures.CRITERIA``): ``response`` (default:
frequencies at the scene's spin, means, oscillation sizes and peak stress,
which is what the advisor's measures bound) or ``trajectory`` (the
pointwise errors of theory section 10, where a frequency error ``e`` costs
about ``2 pi N e`` after N periods).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..analysis import Analysis, analyze
from ..response import frequency_change
from ..pool import cpus, mapper, threads
from ..predict import level_of
from ..sim.cost import rhs_cost
from ..sim.integrate import EXPONENTIAL, FIXED, Run, integrate
from ..sim.model import Model, build_model, initial_state
from ..sim.output import summary
from ..sim.timing import evaluation_seconds, timed
from ..terms import FULL, LEVEL_SETS, is_lagrangian, lagrangian_superset, ordered
from ..units import TIME
from .measures import CRITERIA, worst
from .reference import (REF_RTOL, SELF_CHECK, Reference, estimated, needs_tight, scene_errors, self_check,  # noqa: F401
                        self_checked)
from .scenes import Scene

SAMPLES = 400  # samples per scene, shared by every run


@dataclass(frozen=True)
class TermSet:
    label: str
    terms: tuple[str, ...]

    @property
    def lagrangian(self) -> bool:
        return is_lagrangian(self.terms)


@dataclass(frozen=True)
class SetResult:
    """One term set in one scene."""

    set: TermSet
    scene: str
    errors: dict
    energy_drift: float | None
    H_drift: float | None
    wall_s: float
    nfev: int
    failed: bool
    reason: str
    speedup: float | None = None  # cost(full) / cost(this set), same integrator
    cost_s: float | None = None   # evaluations x the set's compiled seconds per evaluation (sim.timing)
    run: Run | None = field(default=None, compare=False, repr=False)  # the samples, for the trajectory figures

    def meets(self, tolerance: float, criterion: str = "response") -> bool:
        return not self.failed and worst(self.errors, criterion) <= tolerance


@dataclass(frozen=True)
class Verdict:
    """'agree', 'conservative', 'unsafe' or 'no verdict', what broke the advice, the cheapest adequate canonical
    set, and the scenes without a verdict (their reference did not self-converge)."""

    verdict: str
    advised_level: str
    cheapest: str | None
    broken: tuple[tuple[str, str, float], ...]  # (scene, quantity, error) above the tolerance
    text: str
    unjudged: tuple[tuple[str, str], ...] = ()  # (scene, why it gives no verdict)


@dataclass(frozen=True)
class Verification:
    tolerance: float
    integrator: str
    scenes: tuple[Scene, ...]
    references: dict
    results: tuple[SetResult, ...]
    verdict: Verdict
    scene_verdicts: dict  # scene label -> its own Verdict
    criterion: str = "response"
    extra: dict = field(default_factory=dict)


def advice_speed(a: Analysis, scenes) -> float:
    """The speed [rad/s] the advice must hold for: w_op, or the highest spin of the scenes when higher."""
    per_s = float(TIME[a.body.units.time])
    return max([a.options.situation.w_op or 0.0] + [sc.speed / per_s for sc in scenes])


def for_scenes(a: Analysis, scenes) -> Analysis:
    """``a``, or ``a`` analysed again for the motion it is checked against: at the scenes' highest spin when
    that exceeds w_op (a torque pulse from rest leaves the body spinning; without --speed the scenes spin at a
    default speed), and with the modes driven by the rigid motion only when no scene starts them vibrating
    (docs/advice.md, excitation)."""
    speed, sit = advice_speed(a, scenes), a.options.situation
    excitation = "vibration" if any(sc.vibrating for sc in scenes) else "inertial"
    if sit.w_op is not None and speed <= sit.w_op and excitation == sit.excitation:
        return a
    return analyze(a.body, replace(a.options, situation=replace(sit, w_op=max(speed, sit.w_op or 0.0),
                                                                 excitation=excitation)))


def stiffened(a: Analysis, terms) -> tuple[str, ...]:
    """``terms`` with geo_stiff beside cf2 when the body carries its geometric stiffness (theory 9, 10: the
    reference and the canonical levels then include the stiffening that balances the softening)."""
    if a.body.geometric is None or "cf2" not in terms:
        return tuple(terms)
    return ordered({*terms, "geo_stiff"})


def canonical(a: Analysis) -> dict[str, tuple[str, ...]]:
    """The canonical level sets I-IV for this body (IV: the full set, with geo_stiff where carried)."""
    return {lv: stiffened(a, t) for lv, t in LEVEL_SETS.items()}


def verdict_sets(a: Analysis) -> dict[str, tuple[str, ...]]:
    """The level sets the verdict weighs the advice against, as the advisor may choose them: closed to whole
    energy groups unless the body is stiffly connected (docs/advice.md), keyed by their level, cheapest first."""
    stiff = a.options.situation.connection == "stiff"
    out: dict[str, tuple[str, ...]] = {}
    for terms in LEVEL_SETS.values():
        terms = stiffened(a, terms if stiff else lagrangian_superset(terms))
        out.setdefault(level_of(terms), terms)
    return out


def term_sets(a: Analysis) -> tuple[TermSet, ...]:
    """The advised set, the canonical levels (IV is the full set), the verdict's closed level sets not among
    them, and the advice's smallest Lagrangian superset."""
    sets = [TermSet("advised", a.advice.terms)] + [TermSet(lv if lv != "IV" else "IV (full)", t)
                                                   for lv, t in canonical(a).items()]
    sets += [TermSet(f"{lv} (closed)", t) for lv, t in verdict_sets(a).items() if t not in [s.terms for s in sets]]
    superset = lagrangian_superset(a.advice.terms)
    if superset is not None and superset not in [s.terms for s in sets]:
        sets.append(TermSet("Lagrangian superset", superset))
    return tuple(sets)


def distinct(sets: tuple[TermSet, ...]) -> tuple[TermSet, ...]:
    """The first of each group of sets with the same terms (the advised set is often a canonical level): they
    make the same evaluations, so each group is run once and its run serves every set in it."""
    first: dict = {}
    for ts in sets:
        first.setdefault(ts.terms, ts)
    return tuple(first.values())


def grid_step(scene: Scene, step: float | None) -> tuple[float, float | None]:
    """(output step, integration step): the output step is a whole number of integration steps."""
    out = scene.duration / SAMPLES
    if step is None:
        return out, None
    return out, out / np.ceil(out / step - 1e-9)


def state_scales(model: Model, scene: Scene) -> np.ndarray:
    """Absolute-tolerance scales of the state: 1 (quaternion), the speed, q and q' of the scene's size."""
    om = np.sqrt(np.abs(model.eigenvalues))
    q = np.maximum(np.abs(scene.q0), 1e-6 * max(np.abs(scene.q0).max(), 1e-30)) if scene.q0.any() else 1.0 / om
    w = max(np.linalg.norm(scene.omega0), scene.speed, 1e-12)
    return np.concatenate([np.ones(4), np.full(3, w), q * np.ones(model.nf), om * q])


def run_scene(model: Model, scene: Scene, integrator: str = "dop853", step: float | None = None,
              rtol: float = 1e-8) -> Run:
    """One run of ``model`` through ``scene``, sampled every duration / SAMPLES."""
    out, h = grid_step(scene, step if integrator in FIXED else None)
    y0 = initial_state(model, scene.omega0, scene.q0, scene.qd0)
    atol = rtol * state_scales(model, scene)
    return integrate(model, y0, scene.duration, integrator, h, rtol, atol, out, scene.loads)


def reference(a: Analysis, scene: Scene) -> Reference:
    """The full set at REF_RTOL with the exponential integrator (sim.lawson), its error not yet estimated
    (verify.reference)."""
    run = run_scene(reference_model(a, scene), scene, EXPONENTIAL, rtol=REF_RTOL)
    return Reference(run, {}, run.wall_s, 0)


def reference_model(a: Analysis, scene: Scene) -> Model:
    """The model of the reference: the full set, with geo_stiff where carried."""
    return build_model(a.body, stiffened(a, FULL), scene.damping)


def frequency_error(a: Analysis, terms, scene: Scene) -> float:
    """The set's linearised flexible frequencies at the scene's spin about its axis against the full set's."""
    full = stiffened(a, FULL)
    if tuple(terms) == full:
        return 0.0
    return frequency_change(a.body, terms, full, np.eye(3)[scene.axis], scene.speed)


def run_set(a: Analysis, ts: TermSet, scene: Scene, ref: Reference, integrator: str, step: float | None,
            rtol: float, repeats: int) -> SetResult:
    """Errors of one set against the reference; its wall time from one run (sim.timing.timed: ``repeats`` runs,
    or a few where a run is shorter than the timer can tell, the minimum counting)."""
    model = build_model(a.body, ts.terms, scene.damping)
    run, wall = timed(lambda: run_scene(model, scene, integrator, step, rtol), repeats)
    s = summary(model, run, str(a.body.units))
    errs = {**scene_errors(a, run, ref.run), "frequency": frequency_error(a, ts.terms, scene)}
    return SetResult(ts, scene.label, errs, s["energy_drift"], s["H_drift"], wall, run.nfev, run.failed, run.reason,
                     run=run)


def verify(a: Analysis, scenes, tolerance: float = 0.01, integrator: str = "dop853", step: float | None = None,
           rtol: float = 1e-8, repeats: int = 1, criterion: str = "response", jobs: int = 1,
           progress=None, untimed=None) -> Verification:
    """Every term set through every scene against the reference, and the verdict on the advice by ``criterion``;
    the references, then one run of each distinct set (``distinct``; ``repeats`` > 1: the minimum wall time of
    that many, taken serially in its worker), then the references' self-checks where needed (verify.reference),
    on ``jobs`` local processes; ``progress(label, done, total)`` is told of each finished run; ``untimed()`` is
    called after the references and before the first timed run (it waits for work done beside the references,
    which nothing times)."""
    scenes, sets = tuple(scenes), term_sets(a)
    work = _Work(a, scenes, distinct(sets), integrator, step, rtol, repeats, tolerance, criterion)
    refs, rows = _runs(work, jobs, progress or _silent, untimed or _silent)
    run_of = {(r.scene, r.set.terms): r for r in _costed(a, scenes, rows)}
    results = []
    for sc in scenes:
        scene_rows = [replace(run_of[sc.label, ts.terms], set=ts) for ts in sets]
        full = next(r for r in scene_rows if r.set.label == "IV (full)")
        results += [_with_speedup(r, full) for r in scene_rows]
    results = tuple(results)
    per_scene = {sc.label: judge(a, tuple(r for r in results if r.scene == sc.label), refs, tolerance, criterion)
                 for sc in scenes}
    return Verification(tolerance, integrator, scenes, refs, results,
                        judge(a, results, refs, tolerance, criterion), per_scene, criterion)


@dataclass(frozen=True)
class _Work:
    """What every run of one verification shares (set before the workers fork, so never pickled per task)."""

    a: Analysis
    scenes: tuple[Scene, ...]
    sets: tuple[TermSet, ...]
    integrator: str
    step: float | None
    rtol: float
    repeats: int
    tolerance: float
    criterion: str


_work: _Work | None = None


def _runs(work: _Work, jobs: int, progress, untimed) -> tuple[dict, list[SetResult]]:
    """The scenes' references (on two threads beside one job), ``untimed()``, every (scene, set) run, then the
    references' error estimates and the self-checks they call for, in order, each finished run told to
    ``progress``."""
    global _work
    _work = work
    n = len(work.scenes) * (1 + len(work.sets))
    pairs = [(i, j) for i in range(len(work.scenes)) for j in range(len(work.sets))]
    try:
        tasks = max(len(work.scenes), len(pairs))  # no more workers than the widest of its maps hands out
        with mapper(jobs, tasks=tasks) as map_, threads(min(2, cpus())) as threaded:  # its threads start with its map
            # The references and their checks time nothing: beside one job they take two threads (DOP853 releases
            # the GIL).
            untimed_map = threaded if jobs <= 1 else map_
            refs = _told(untimed_map(_reference_run, range(len(work.scenes))), progress, 0,
                         n, lambda i: f"reference {work.scenes[i].label}")
            untimed()
            rows = _told(map_(_set_run, pairs, [refs[i] for i, _ in pairs]), progress, len(refs), n,
                         lambda k: f"{work.scenes[pairs[k][0]].label}: {work.sets[pairs[k][1]].label}")
            refs = _estimated(work, refs, rows)
            check = [i for i, ref in enumerate(refs) if needs_tight(ref, work.tolerance, work.criterion)]
            for i, tight in zip(check, untimed_map(_tight_run, check)):
                refs[i] = self_checked(work.a, refs[i], tight)
    finally:
        _work = None
    return {sc.label: ref for sc, ref in zip(work.scenes, refs)}, rows


def _estimated(work: _Work, refs: list[Reference], rows: list[SetResult]) -> list[Reference]:
    """The references with their error estimates from the full set's runs (verify.reference.estimated)."""
    full = stiffened(work.a, FULL)
    run_of = {r.scene: r.run for r in rows if r.set.terms == full}
    return [estimated(work.a, ref, run_of.get(sc.label)) for sc, ref in zip(work.scenes, refs)]


def _told(results, progress, before: int, total: int, label) -> list:
    """The results, ``progress(label(k), before + k + 1, total)`` after the k-th arrives."""
    out = []
    for k, r in enumerate(results):
        out.append(r)
        progress(label(k), before + k + 1, total)
    return out


def _silent(*_) -> None:
    """No progress shown (nothing to wait for)."""


def _reference_run(i: int) -> Reference:
    return reference(_work.a, _work.scenes[i])


def _tight_run(i: int) -> Run:
    """Scene i's reference model at REF_RTOL / 100 (the self-check)."""
    sc = _work.scenes[i]
    return run_scene(reference_model(_work.a, sc), sc, EXPONENTIAL, rtol=REF_RTOL / 100)


def _set_run(pair: tuple[int, int], ref: Reference) -> SetResult:
    w = _work
    return run_set(w.a, w.sets[pair[1]], w.scenes[pair[0]], ref, w.integrator, w.step, w.rtol, w.repeats)


def _costed(a: Analysis, scenes, rows: list[SetResult]) -> list[SetResult]:
    """The rows with their cost: evaluations times the set's compiled seconds per evaluation, measured once per
    set here, after every run (sim.timing.evaluation_seconds; at the first scene's initial state)."""
    sc = scenes[0]
    per = {}
    for terms in dict.fromkeys(r.set.terms for r in rows):
        model = build_model(a.body, terms)
        per[terms] = evaluation_seconds(model, initial_state(model, sc.omega0, sc.q0, sc.qd0))
    return [replace(r, cost_s=r.nfev * per[r.set.terms]) for r in rows]


def _with_speedup(r: SetResult, full: SetResult) -> SetResult:
    """cost(full) / cost(set) (``_costed``); exactly 1 for the full set's own terms (the same evaluations)."""
    if set(r.set.terms) == set(full.set.terms):
        return replace(r, speedup=1.0)
    return replace(r, speedup=full.cost_s / r.cost_s if r.cost_s > 0 else None)


def judge(a: Analysis, results: tuple[SetResult, ...], references: dict, tolerance: float,
          criterion: str = "response") -> Verdict:
    """The verdict over the scenes of ``results`` whose reference self-converged (the worst decides); the others
    give no verdict and are named."""
    scenes = dict.fromkeys(r.scene for r in results)
    unjudged = tuple((s, why) for s in scenes if (why := self_check(a, references[s], tolerance, criterion)))
    skipped = {s for s, _ in unjudged}
    judged = tuple(r for r in results if r.scene not in skipped)
    if not judged:
        text = (f"no verdict: {unjudged[0][0]}: {unjudged[0][1]}" if len(unjudged) == 1 else
                f"no verdict: the reference did not self-converge in any of the {len(unjudged)} scenes "
                f"({', '.join(s for s, _ in unjudged)}); each scene says why")
        return Verdict("no verdict", a.advice.level, None, (), text, unjudged)
    v = _judge_converged(a, judged, tolerance, criterion)
    if not unjudged:
        return v
    return replace(v, unjudged=unjudged, text=f"{v.text}; {len(unjudged)} of {len(scenes)} scenes gave no verdict "
                   f"and do not count (reference did not self-converge): {', '.join(s for s, _ in unjudged)}")


def _judge_converged(a: Analysis, results: tuple[SetResult, ...], tolerance: float, criterion: str) -> Verdict:
    """Whether the advice meets the tolerance everywhere, what broke it, and the cheapest adequate level."""
    advised = [r for r in results if r.set.label == "advised"]
    broken = tuple((r.scene, q, float(r.errors[q])) for r in advised for q in CRITERIA[criterion]
                   if not r.failed and r.errors[q] > tolerance) + tuple(
        (r.scene, "failed: " + r.reason, float("inf")) for r in advised if r.failed)
    choices = verdict_sets(a)
    cheapest = next((lv for lv, terms in choices.items()
                     if all(r.meets(tolerance, criterion) for r in results if r.set.terms == terms)), None)
    nf = a.body.nf
    if broken:
        verdict = "unsafe"
        text = (f"the advice FAILED: level {a.advice.level} misses the tolerance {tolerance:g} in "
                + "; ".join(f"{s}: {q} error {e:.3g}" for s, q, e in broken)
                + (f"; the cheapest adequate canonical set is {cheapest}" if cheapest else ""))
    elif cheapest is not None and rhs_cost(choices[cheapest], nf) < (1 - 1e-9) * rhs_cost(a.advice.terms, nf):
        verdict = "conservative"
        text = (f"the advice holds; it is conservative: level {cheapest} ({', '.join(choices[cheapest])}) "
                f"costs less and already meets the tolerance "
                f"{tolerance:g} in every scene")
    else:
        verdict = "agree"
        text = f"the advice holds: level {a.advice.level} meets the tolerance {tolerance:g} in every scene"
    return Verdict(verdict, a.advice.level, cheapest, broken, text)
