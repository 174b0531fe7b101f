"""Errors of a run against the reference, each relative to the reference's amplitude (theory section 10).

- ``w``: max_t |w - w_ref| / max_t |w_ref|
- ``orientation``: max_t angle(A_ref^T A) in rad, from the relative quaternion ``r = p_ref^* p``:
  ``2 atan2(|r_vec|, |r_0|)`` (accurate for small angles, unlike ``2 acos |p_ref . p|``)
- ``q``: max_t |q - q_ref| / max(max_t |q_ref|, FLOOR |q_max|)
- ``stress``: recovered stress sigma(t) = sum_p sigma_p |q_p|,
  max_t |sigma - sigma_ref| / max(max_t sigma_ref, FLOOR sigma_allow)
The floors keep a scene whose reference barely deforms (a slow spin) from
calling a set wrong for missing a deformation far below the allowable: an
error counts relative to at least a tenth of the allowable modal amplitude
and stress (theory section 6), so with a 1 % tolerance a set may miss at
most 1e-3 of the allowable stress (0.5 N/mm^2 for steel at 500 N/mm^2). A run that failed, or ended early, has infinite
errors.
"""
from __future__ import annotations

import numpy as np

from ..sim.integrate import Run
from ..sim.model import N_ROT

QUANTITIES = ("w", "orientation", "q", "stress")
FLOOR = 0.1  # of |q_max| and of sigma_allow


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


def errors(run: Run, ref: Run, sigma: np.ndarray | None, q_max: np.ndarray | None = None,
           sigma_allow: float = 0.0) -> dict[str, float]:
    """The four errors of ``run`` against ``ref`` on the reference's sample times (same grid required)."""
    if run.failed or len(run.t) != len(ref.t) or not np.allclose(run.t, ref.t, rtol=0, atol=1e-9 * ref.t[-1]):
        return {k: np.inf for k in QUANTITIES}
    nf = (ref.y.shape[1] - N_ROT) // 2
    y, r = run.y, ref.y
    angle = relative_angle(r[:, :4], y[:, :4])
    q, qr = y[:, N_ROT:N_ROT + nf], r[:, N_ROT:N_ROT + nf]
    weights = np.ones(nf) if sigma is None else np.asarray(sigma)
    s, sr = np.abs(q) @ weights, np.abs(qr) @ weights
    return {
        "w": _relative(np.linalg.norm(y[:, 4:7] - r[:, 4:7], axis=1), np.linalg.norm(r[:, 4:7], axis=1)),
        "orientation": float(angle.max()),
        "q": _relative(np.linalg.norm(q - qr, axis=1), np.linalg.norm(qr, axis=1),
                       0.0 if q_max is None else FLOOR * float(np.linalg.norm(q_max))),
        "stress": _relative(s - sr, sr, FLOOR * sigma_allow if sigma is not None else 0.0),
    }


def worst(errs: dict[str, float]) -> float:
    """The largest of the errors (orientation in rad counts like a relative error)."""
    return max(errs.values())
