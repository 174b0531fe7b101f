"""The versioned JSON of `verify` (schema: src/ffrf_advisor/schemas/verify.json), read from a verify.study.Study."""
from __future__ import annotations

import datetime as _dt
from dataclasses import asdict
from pathlib import Path

import numpy as np

from ..io import sha256
from ..sim.integrate import EXPONENTIAL
from ..units import TIME
from ..verify.runner import REF_RTOL, SELF_CHECK, Verdict
from ..verify.measures import worst
from ..verify.scenes import Scene
from ..verify.study import Study
from ..verify.workprecision import pareto
from .json_out import json_number
from .verify_input import SCHEMA_VERSION, operating_point



def _clean(obj):
    """Dataclasses, arrays and numpy scalars to JSON values (inf and NaN to null)."""
    if hasattr(obj, "__dataclass_fields__"):
        return {k: _clean(v) for k, v in asdict(obj).items()}
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, np.ndarray)):
        return [_clean(v) for v in obj]
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return json_number(obj)
    return obj


def _verdict(v: Verdict) -> dict:
    return {"verdict": v.verdict, "advised_level": v.advised_level, "cheapest": v.cheapest, "text": v.text,
            "broken": [{"scene": s, "quantity": q, "error": e} for s, q, e in v.broken],
            "unjudged": [{"scene": s, "reason": why} for s, why in v.unjudged]}


def _scene(st: Study, s: Scene, per_s: float) -> dict:
    """A scene, its reference with the self-check, and its own verdict."""
    ver = st.verification
    ref, verdict = ver.references[s.label], ver.scene_verdicts[s.label]
    check = {"error": worst(ref.self_error, ver.criterion), "limit": SELF_CHECK * ver.tolerance,
             "converged": not verdict.unjudged}
    return {"name": s.name, "label": s.label, "axis": s.axis + 1, "duration": s.duration,
            "speed_rad_s": s.speed / per_s, "damping": s.damping, "text": s.text,
            "reference": {"integrator": EXPONENTIAL, "rtol": REF_RTOL, "self_error": ref.self_error,
                          "self_check": check, "self_checked": ref.self_checked, "wall_s": ref.wall_s,
                          "rhs_evaluations": ref.run.nfev, "self_check_evaluations": ref.self_check_nfev},
            "verdict": _verdict(verdict)}


def _studies(st) -> dict:
    """work_precision, stability and campbell; null each where ``verify --quick`` left them out."""
    if st.work_precision is None:
        return {"work_precision": None, "stability": None, "campbell": None}
    ver = st.verification
    return {"work_precision": {"scene": ver.scenes[0].label, "timing": "wall time of one run (the minimum over "
                               "--repeat runs where asked), serially on this machine", "points": st.work_precision,
                               "pareto": pareto(st.work_precision)},
            "stability": st.stability,
            "campbell": _campbell(st.campbell)}


def _campbell(c: dict) -> dict:
    """The Campbell diagram's data: speeds and branches per axis (NaN, as null, where not drawn; gaps say why),
    and each set's frequency error against the reference of the scenes at the scenes' speed about their axis."""
    return {"axis_of_error": c["axis_of_error"] + 1, "speed": c["speed"], "reference": c["reference"],
            "reference_terms": list(c["reference_terms"]), "frequency_error": c["frequency_error"],
            "s_crit": c["s_crit"], "s_crit_with_geo_stiff": c["s_crit_stiffened"], "speeds": c["speeds"],
            "sets": {label: list(terms) for label, terms in c["sets"].items()},
            "frequencies": {str(k + 1): v for k, v in c["by_axis"].items()},
            "gaps": {str(k + 1): v for k, v in c["gaps"].items()}}


def _body(a, source: str) -> dict:
    """The body verified: its file (with the file's SHA-256 where it is one), name, units and mode count."""
    sha = {"sha256": sha256(source)} if Path(source).is_file() else {}
    return {"file": source, **sha, "name": a.body.name, "units": str(a.body.units), "nf": a.body.nf}


def study_json(st: Study, source: str, figures: tuple[str, ...] = ()) -> dict:
    """The documented JSON of ``verify --json`` (src/ffrf_advisor/schemas/verify.json), with the paths of the
    figures written (report.verify_figures.write_figures)."""
    a, ver = st.analysis, st.verification
    per_s = float(TIME[a.body.units.time])
    return _clean({
        "schema_version": SCHEMA_VERSION,
        "body": _body(a, source),
        "operating_point": operating_point(st.asked or a.options.situation),
        "date": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "advice": {"level": a.advice.level, "terms": list(a.advice.terms), "lagrangian": a.advice.lagrangian,
                   "lagrangian_superset": a.advice.lagrangian_superset, "speed_rad_s": a.options.situation.w_op,
                   "excitation": a.options.situation.excitation},
        "tolerance": ver.tolerance,
        "criterion": ver.criterion,
        "integrator": ver.integrator,
        "scenes": [_scene(st, s, per_s) for s in ver.scenes],
        "results": [{"set": r.set.label, "terms": list(r.set.terms), "lagrangian": r.set.lagrangian,
                     "scene": r.scene, "errors": r.errors, "meets": r.meets(ver.tolerance, ver.criterion),
                     "energy_drift": r.energy_drift, "H_drift": r.H_drift, "wall_s": r.wall_s,
                     "rhs_evaluations": r.nfev, "failed": r.failed, "reason": r.reason, "speedup": r.speedup}
                    for r in ver.results],
        "verdict": _verdict(ver.verdict),
        **_studies(st),
        "figures": list(figures),
    })
