"""Response-based measures of theory section 7: what cf2 and the deformation-dependent Coriolis terms do.

Both are sign-independent (they use no modal amplitude of unknown sign) and
grow with the spin speed, which keeps the rules of section 8 monotone:

- ``r_cf2(a, s)``: the change of the static centrifugal response by cf2 at
  spin s about the unit axis a, ``q0 = Omega^-2 f``, ``q2 = (Omega^2 -
  s^2 Kc(a))^-1 f`` with ``f = f_cf1(s a)``, as ``sum sigma |q2 - q0| /
  sum sigma |q0|`` (plain norms without stress data; 0 when f vanishes),
  or the frequency shift ``max |Omega_p(s) - Omega_p| / Omega_p`` of
  ``Omega^2 - s^2 Kc(a)``, whichever is larger; infinite at and beyond
  s_crit(a).
- ``r_cor(a, s)``: the full set and the full set without cor_quad and
  cor_coupling, both linearised at steady spin (sim.linearise, the
  Campbell diagram's linearisation): ``max_p |f_p(full) - f_p(without)| /
  f_p(full)`` over the flexible modes; infinite when a mode has lost its
  frequency in either (a flexible instability; the rigid tumbling about
  the middle axis does not count).
"""
from __future__ import annotations

import numpy as np

from .body import FlexibleBody, pairs_at
from .significance import f_cf1
from .terms import FULL

WITHOUT_DEFORMATION_CORIOLIS = tuple(t for t in FULL if t not in ("cor_quad", "cor_coupling"))


def softening_matrix(body: FlexibleBody, a: np.ndarray) -> np.ndarray:
    """``Kc(a) = sum_kl a_k a_l W2_kl`` (nf x nf): cf2 at spin s about a is the stiffness ``-s^2 Kc(a)``."""
    nf = body.nf
    W2 = body.W2.reshape(3, nf, 3, nf)
    K = np.einsum("k,kplr,l->pr", a, W2, a)
    return 0.5 * (K + K.T)


def geometric_matrix(body: FlexibleBody, a: np.ndarray) -> np.ndarray:
    """``G(a) = sum_kl a_k a_l G_kl`` (theory 9), zero when the body carries no geometric stiffness."""
    if body.geometric is None:
        return np.zeros((body.nf, body.nf))
    return pairs_at(body.geometric, a)


def r_cf2(body: FlexibleBody, a, s: float) -> float:
    """Change of the static centrifugal response and of the frequencies by cf2 at spin s about a."""
    a = np.asarray(a, float) / np.linalg.norm(a)
    lam = np.asarray(body.eigenvalues, float)
    K = np.diag(lam) - s**2 * (softening_matrix(body, a) - geometric_matrix(body, a))
    mu = np.linalg.eigvalsh(K)
    if mu.min() <= 0:
        return np.inf
    shift = float(np.max(np.abs(np.sqrt(mu) - np.sqrt(np.sort(lam))) / np.sqrt(np.sort(lam))))
    f = f_cf1(body, s * a)
    q0 = f / lam
    weights = np.ones(body.nf) if body.sigma_max is None else np.asarray(body.sigma_max)
    base = float(weights @ np.abs(q0))
    static = 0.0 if base <= 1e-300 else float(weights @ np.abs(np.linalg.solve(K, f) - q0)) / base
    return max(static, shift)


def frequency_change(body: FlexibleBody, terms, reference_terms, a, s: float) -> float:
    """``max_p |f_p(reference) - f_p(terms)| / f_p(reference)`` of the two sets linearised at steady spin s
    about a; infinite when a mode has lost its frequency in the set only, NaN (no comparison) when in the
    reference (the rigid tumbling about the middle axis does not count); 0 at rest (every set then has the
    frequencies Omega)."""
    from .sim.linearise import linearise
    from .sim.model import build_model
    if s == 0:
        return 0.0
    ref = linearise(build_model(body, reference_terms), a, s)
    other = linearise(build_model(body, terms), a, s)
    if len(ref.frequencies) != body.nf:
        return np.nan
    if len(other.frequencies) != body.nf:
        return np.inf
    f, g = ref.frequencies, other.frequencies
    return float(np.max(np.abs(f - g) / f)) if len(f) else 0.0


def r_cor(body: FlexibleBody, a, s: float) -> float:
    """Frequency change by cor_quad and cor_coupling at steady spin s about a (both sets linearised)."""
    value = frequency_change(body, WITHOUT_DEFORMATION_CORIOLIS, FULL, a, s)
    return np.inf if np.isnan(value) else value  # the full set lost a frequency: treat as significant
