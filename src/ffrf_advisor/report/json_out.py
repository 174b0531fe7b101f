"""The versioned JSON of `analyze` and `gate` (schema: src/ffrf_advisor/schemas/analyze.json)."""
from __future__ import annotations

import math

import numpy as np

from .. import __version__
from ..adequacy import summary as basis_summary
from ..analysis import Analysis
from ..checks import check_warnings, density_warnings
from ..guidelines import softening_situations
from ..situation import THRESHOLDS
from ..predict import level_of
from ..significance import Ratio
from ..sim.cost import cost_ratio

SCHEMA_VERSION = 4  # 2: cor_full split into cor_quad + cor_coupling, lagrangian; 3: basis_adequacy;
# 4: operating_point, candidates with predicted errors, situation's tolerance, rules, principal axis, range


def json_number(x):
    """JSON number, or null for inf/NaN/None."""
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def json_array(a):
    return None if a is None else [json_array(x) if np.ndim(x) else json_number(x) for x in np.asarray(a)]


def json_ratio(r: Ratio | None) -> dict | None:
    if r is None:
        return None
    return {"value": json_number(r.value), "numerator": r.numerator, "denominator": r.denominator,
            "both_vanish": r.value is None}


def body_json(b, source: str) -> dict:
    """The body's data in its units (the ``body`` object of the analyze and info JSON)."""
    return {
        "file": source, "name": b.name, "units": str(b.units), "nf": b.nf, "mass": b.mass,
        "com": json_array(b.com), "I0": json_array(b.I0), "eigenvalues": json_array(b.eigenvalues),
        "frequencies": json_array(b.frequencies_hz), "sigma_max": json_array(b.sigma_max),
        "mass_matrix": b.provenance.mass_matrix, "source": b.provenance.source,
    }


def checks_json(checks) -> list[dict]:
    """The checks of theory section 4 with the precision each assumed."""
    return [{"name": c.name, "value": json_number(c.value), "tolerance": c.tolerance, "passed": c.passed,
             "precision": c.precision} for c in checks]


def info_json(b, checks, source: str) -> dict:
    """The documented JSON of ``info --json`` (src/ffrf_advisor/schemas/info.json)."""
    return {"schema_version": 1, "body": body_json(b, source), "checks": checks_json(checks),
            "warnings": check_warnings(list(checks)) + density_warnings(b)}


def analysis_json(a: Analysis, source: str) -> dict:
    b, amp, sig, adv, sit = a.body, a.amplitudes, a.significance, a.advice, a.options.situation
    return {
        "schema_version": SCHEMA_VERSION,
        "tool": f"ffrf-advisor {__version__}",
        "body": body_json(b, source),
        "situation": {
            "speed_rad_s": json_number(sit.w_op), "f_sys_hz": json_number(sit.f_sys), "connection": sit.connection,
            "widening": sit.widening, "thresholds": {k: sit.threshold(k) for k in THRESHOLDS},
            "spin_axis": None if sit.spin_axis is None else list(sit.spin_axis),
            "principal_axis": sit.principal_axis, "tolerance": sit.tolerance, "rules": sit.rules,
            "speed_range_rad_s": None if sit.speed_range is None else list(sit.speed_range),
            "at_rest": sit.at_rest, "excitation": sit.excitation, "config": sit.config,
        },
        "operating_point": adv.operating_point,
        "decided_by": adv.decided_by,
        "candidates": [{"label": c.label, "terms": list(c.terms), "level": level_of(c.terms), "cost": c.cost,
                        "errors": {k: json_number(v) for k, v in c.errors.items()},
                        "adequate": c.meets(sit.tolerance)} for c in adv.candidates],
        "level": adv.level,
        "terms": list(adv.terms),
        "lagrangian": adv.lagrangian,
        "lagrangian_superset": None if adv.lagrangian_superset is None else list(adv.lagrangian_superset),
        "lagrangian_superset_cost": None if adv.lagrangian_superset is None
        else cost_ratio(adv.lagrangian_superset, adv.terms, b.nf),
        "amplitudes": {
            "q_max": json_array(amp.q_max), "governs": list(amp.governs), "q_cap": amp.q_cap,
            "sigma_allow": amp.sigma_allow, "stress_utilisation": json_array(amp.stress_utilisation),
            "deflection_ratio": json_array(amp.deflection_ratio), "deflection_bounds": json_array(amp.deflection_bounds),
        },
        "significance": {
            "dI_L": json_array(sig.dI_L), "dI_Q": json_array(sig.dI_Q), "dI_fT": json_array(sig.dI_fT), "dI_Tf": json_array(sig.dI_Tf),
            "magnitudes": {k: vars(m) for k, m in sig.magnitudes.items()},
            "n_ratio": sig.n_ratio, "coriolis_ratio": json_ratio(sig.coriolis),
            "centrifugal_ratio": json_ratio(sig.centrifugal), "coriolis_ratio_paper": json_ratio(sig.coriolis_paper),
            "centrifugal_ratio_paper": json_ratio(sig.centrifugal_paper),
            "ratio_signs": json_array(sig.signs), "ratio_sign_search": sig.sign_search,
            "s_crit": json_array(sig.s_crit),
            "s_crit_stiffened": json_array(sig.s_crit_stiffened),
            "softening_situation": softening_situations(a),
            "not_evaluable": list(sig.not_evaluable),
        },
        "rules": [{"rule": r.rule, "name": r.name, "value": json_number(r.value), "threshold": json_number(r.threshold),
                   "fired": None if r.fired is None else bool(r.fired), "terms": list(r.terms), "reason": r.reason} for r in adv.rules],
        "warnings": list(adv.warnings),
        "basis_adequacy": basis_summary(b, sit.w_op),
        "checks": checks_json(a.checks),
    }
