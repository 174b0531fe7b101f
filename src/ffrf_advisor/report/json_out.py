"""The versioned JSON of `analyze` and `gate` (schema: docs/json-schema.json)."""
from __future__ import annotations

import math

import numpy as np

from .. import __version__
from ..analysis import Analysis
from ..guidelines import THRESHOLDS
from ..significance import Ratio

SCHEMA_VERSION = 1


def _num(x):
    """JSON number, or null for inf/NaN/None."""
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def _arr(a):
    return None if a is None else [_arr(x) if np.ndim(x) else _num(x) for x in np.asarray(a)]


def _ratio(r: Ratio) -> dict:
    return {"value": _num(r.value), "numerator": r.numerator, "denominator": r.denominator,
            "both_vanish": r.value is None}


def analysis_json(a: Analysis, source: str) -> dict:
    b, amp, sig, adv, sit = a.body, a.amplitudes, a.significance, a.advice, a.options.situation
    return {
        "schema_version": SCHEMA_VERSION,
        "tool": f"ffrf-advisor {__version__}",
        "body": {
            "file": source, "name": b.name, "units": str(b.units), "nf": b.nf, "mass": b.mass,
            "com": _arr(b.com), "I0": _arr(b.I0), "eigenvalues": _arr(b.eigenvalues),
            "frequencies": _arr(b.frequencies_hz), "sigma_max": _arr(b.sigma_max),
            "mass_matrix": b.provenance.mass_matrix, "source": b.provenance.source,
        },
        "situation": {
            "speed_rad_s": _num(sit.w_op), "f_sys_hz": _num(sit.f_sys), "connection": sit.connection,
            "widening": sit.widening, "thresholds": {**THRESHOLDS, **sit.thresholds},
        },
        "level": adv.level,
        "terms": list(adv.terms),
        "energy_consistent": bool(adv.energy_consistent),
        "amplitudes": {
            "q_max": _arr(amp.q_max), "governs": list(amp.governs), "q_cap": amp.q_cap,
            "sigma_allow": amp.sigma_allow, "stress_utilisation": _arr(amp.stress_utilisation),
            "deflection_ratio": _arr(amp.deflection_ratio), "deflection_bounds": _arr(amp.deflection_bounds),
        },
        "significance": {
            "dI_L": _arr(sig.dI_L), "dI_Q": _arr(sig.dI_Q), "dI_fT": _arr(sig.dI_fT), "dI_Tf": _arr(sig.dI_Tf),
            "magnitudes": {k: vars(m) for k, m in sig.magnitudes.items()},
            "n_ratio": sig.n_ratio, "coriolis_ratio": _ratio(sig.coriolis),
            "centrifugal_ratio": _ratio(sig.centrifugal), "s_crit": _arr(sig.s_crit),
        },
        "rules": [{"rule": r.rule, "name": r.name, "value": _num(r.value), "threshold": _num(r.threshold),
                   "fired": None if r.fired is None else bool(r.fired), "terms": list(r.terms), "reason": r.reason} for r in adv.rules],
        "warnings": list(adv.warnings),
    }
