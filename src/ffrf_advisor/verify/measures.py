"""Errors of a run against the reference, each relative to the reference's amplitude (theory section 10).

- ``w``: max_t |w - w_ref| / max_t |w_ref|
- ``orientation``: max_t angle(A_ref^T A) in rad, from the relative quaternion ``r = p_ref^* p``:
  ``2 atan2(|r_vec|, |r_0|)`` (accurate for small angles, unlike ``2 acos |p_ref . p|``)
- ``q``: max_t |q - q_ref| / max(max_t |q_ref|, FLOOR |q_max|)
- ``stress``: recovered stress sigma(t) = sum_p sigma_p |q_p|,
  max_t |sigma - sigma_ref| / max(max_t sigma_ref, FLOOR sigma_allow)
Response errors (phase-free: what a frequency or amplitude error does,
not where in its cycle a run is after many periods; theory section 10,
"criterion"):

- ``w_response``, ``q_response``: the larger of the mean's error
  ``|mean_t x - mean_t x_ref|`` and the oscillation's amplitude
  ``sqrt 2 |rms_t(x - mean x) - rms_t(x_ref - mean x_ref)|``, over the same scales
  as above (both are at most about the frequency error for a run that only
  drifts in phase, and first order in a missing static deflection or a
  changed amplitude);
- ``stress_peak``: ``|max_t sigma - max_t sigma_ref|`` over the stress scale;
- ``frequency``: the linearised frequencies at the scene's spin against the
  full set's (``runner.frequency_error``).

The floors keep a scene whose reference barely deforms (a slow spin) from
calling a set wrong for missing a deformation far below the allowable: an
error counts relative to at least a tenth of the allowable modal amplitude
and stress (theory section 6), so with a 1 % tolerance a set may miss at
most 1e-3 of the allowable stress (0.5 N/mm^2 for steel at 500 N/mm^2). A run that failed, or ended early, has infinite
errors.
"""
from __future__ import annotations

import numpy as np

from ..amplitudes import FLOOR
from ..sim.integrate import Run
from ..sim.model import N_ROT

QUANTITIES = ("w", "orientation", "q", "stress")
RESPONSE = ("w_response", "q_response", "stress_peak", "frequency")
CRITERIA = {"response": RESPONSE, "trajectory": QUANTITIES}


def _relative(diff: np.ndarray, ref: np.ndarray, floor: float = 0.0) -> float:
    scale = max(np.abs(ref).max() if ref.size else 0.0, floor)
    d = np.abs(diff).max() if diff.size else 0.0
    return 0.0 if d == 0 else (np.inf if scale == 0 else float(d / scale))


def relative_angle(p_ref: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Rotation angle of A_ref^T A per row of quaternions (scalar first, not necessarily unit)."""
    a = p_ref / np.linalg.norm(p_ref, axis=1, keepdims=True)
    b = p / np.linalg.norm(p, axis=1, keepdims=True)
    scalar = np.sum(a * b, axis=1)
    vector = a[:, :1] * b[:, 1:] - b[:, :1] * a[:, 1:] - np.cross(a[:, 1:], b[:, 1:])
    return 2 * np.arctan2(np.linalg.norm(vector, axis=1), np.abs(scalar))


def _response(x: np.ndarray, ref: np.ndarray, floor: float = 0.0) -> float:
    """Larger error of the time mean and of the oscillation's amplitude about it (sqrt 2 rms: a sine's amplitude;
    rows: samples), over the scale."""
    mean, mean_ref = x.mean(axis=0), ref.mean(axis=0)
    rms = np.sqrt(np.mean(np.sum((x - mean) ** 2, axis=1)))
    rms_ref = np.sqrt(np.mean(np.sum((ref - mean_ref) ** 2, axis=1)))
    diff = np.array([np.linalg.norm(mean - mean_ref), np.sqrt(2) * abs(rms - rms_ref)])
    return _relative(diff, np.linalg.norm(ref, axis=1), floor)


def errors(run: Run, ref: Run, sigma: np.ndarray | None, q_max: np.ndarray | None = None,
           sigma_allow: float = 0.0) -> dict[str, float]:
    """The trajectory and the response errors (but ``frequency``) of ``run`` against ``ref`` on the reference's
    sample times (same grid required)."""
    if run.failed or len(run.t) != len(ref.t) or not np.allclose(run.t, ref.t, rtol=0, atol=1e-9 * ref.t[-1]):
        return {k: np.inf for k in QUANTITIES + RESPONSE[:-1]}
    nf = (ref.y.shape[1] - N_ROT) // 2
    y, r = run.y, ref.y
    angle = relative_angle(r[:, :4], y[:, :4])
    q, qr = y[:, N_ROT:N_ROT + nf], r[:, N_ROT:N_ROT + nf]
    weights = np.ones(nf) if sigma is None else np.asarray(sigma)
    s, sr = np.abs(q) @ weights, np.abs(qr) @ weights
    q_floor = 0.0 if q_max is None else FLOOR * float(np.linalg.norm(q_max))
    s_floor = FLOOR * sigma_allow if sigma is not None else 0.0
    w, wr = y[:, 4:7], r[:, 4:7]
    return {
        "w": _relative(np.linalg.norm(w - wr, axis=1), np.linalg.norm(wr, axis=1)),
        "orientation": float(angle.max()),
        "q": _relative(np.linalg.norm(q - qr, axis=1), np.linalg.norm(qr, axis=1), q_floor),
        "stress": _relative(s - sr, sr, s_floor),
        "w_response": _response(w, wr),
        "q_response": _response(q, qr, q_floor),
        "stress_peak": _relative(np.array([s.max() - sr.max()]), sr, s_floor),
    }


def worst(errs: dict[str, float], criterion: str = "trajectory") -> float:
    """The largest of the errors a criterion judges by (orientation in rad counts like a relative error; NaN
    entries, quantities without a comparison, do not count)."""
    values = [errs.get(k, 0.0) for k in CRITERIA[criterion]]
    return max(v for v in values if not np.isnan(v))  # NaN: no comparison (the reference lost a frequency)
