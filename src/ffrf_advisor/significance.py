"""Significance measures of the inertia terms (theory sections 7 and 9)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .body import FlexibleBody
from .invariants import Qf

N_RATIO = 10
SIGN_SEARCH = 12  # modes whose sign patterns are searched exhaustively (2048 patterns)
TINY = 1e-300


@dataclass(frozen=True)
class Magnitudes:
    """Largest |entry|, mean |entry| of the nonzero entries, Frobenius norm (G Tables 2, 3)."""

    max_abs: float
    mean_nonzero: float
    frobenius: float


@dataclass(frozen=True)
class Ratio:
    """A norm ratio with its numerator and denominator; None when both vanish."""

    numerator: float
    denominator: float

    @property
    def value(self) -> float | None:
        scale = max(self.numerator, self.denominator)
        if scale <= TINY:
            return None
        return np.inf if self.denominator <= 1e-14 * scale else self.numerator / self.denominator

    def text(self) -> str:
        v = self.value
        return "both vanish" if v is None else f"{v:.3e}"


@dataclass(frozen=True)
class Significance:
    """All measures per mode p and axis k at q = q_max,p e_p (one mode at a time).

    Measures that need W2 or W3 are None when the body lacks them (an
    invariants file without I9); ``not_evaluable`` names them.
    """

    dI_L: np.ndarray   # (3, nf) |(W1 Qf)_kk| / I0_kk
    dI_Q: np.ndarray | None   # (3, nf) |(Qf^T W2 Qf)_kk| / I0_kk
    dI_fT: np.ndarray | None  # (3, nf) (C C^T)_kk / I0_kk, C = Qf^T W3
    dI_Tf: np.ndarray | None  # (nf,)   max_r (C^T I0^-1 C)_rr
    magnitudes: dict[str, Magnitudes]
    n_ratio: int
    coriolis: Ratio | None    # |deformation-dependent rotational Coriolis| / |W1 Qf' w|, w = (1,1,1), worst signs
    centrifugal: Ratio | None  # |[w I] W2 Qf w| / |[w I] 0.5 W1^T w|, first n_ratio modes, worst signs
    s_crit: np.ndarray | None  # (3,) centrifugal-softening critical speeds about the principal axes
    not_evaluable: tuple[str, ...] = ()
    coriolis_paper: Ratio | None = None     # the same with every mode in phase ("as in the paper")
    centrifugal_paper: Ratio | None = None
    signs: np.ndarray | None = None          # (nf,) the sign pattern of the worst Coriolis ratio
    sign_search: str = ""                    # how the worst pattern was found
    s_crit_stiffened: np.ndarray | None = None  # (3,) the same with geometric stiffening (theory 9), if carried

    def max_first(self, name: str) -> np.ndarray | None:
        """Per axis (or scalar for dI_Tf), the maximum of a dI measure over the first n_ratio modes."""
        values = getattr(self, name)
        return None if values is None else values[..., :self.n_ratio].max(axis=-1)


def magnitudes(a: np.ndarray) -> Magnitudes:
    a = np.abs(a)
    nonzero = a[a > 1e-12 * max(a.max(), TINY)]
    return Magnitudes(float(a.max()), float(nonzero.mean()) if nonzero.size else 0.0, float(np.linalg.norm(a)))


def inertia_change(body: FlexibleBody, q_max: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """dI_L[k, p] and dI_Q[k, p] (G28): diagonal of W1 Qf and Qf^T W2 Qf over I0_kk (dI_Q None without W2)."""
    nf = body.nf
    I0kk = np.diag(body.I0)
    W1 = body.W1.reshape(3, 3, nf)
    k = np.arange(3)
    dI_L = np.abs(W1[k, k, :]) * q_max / I0kk[:, None]
    if body.W2 is None:
        return dI_L, None
    W2 = body.W2.reshape(3, nf, 3, nf)
    dI_Q = np.abs(np.einsum("kpkp->kp", W2)) * q_max**2 / I0kk[:, None]
    return dI_L, dI_Q


def coupling(body: FlexibleBody, q_max: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """dI_fT[k, p] and dI_Tf[p] (G36-G40) with C = Qf^T W3 for q = q_max,p e_p."""
    nf = body.nf
    W3 = body.W3.reshape(3, nf, nf)  # W3[k, s, r]
    C = W3 * q_max[None, :, None]      # C_p[k, r] = q_p W3[k, p, r], indexed [k, p, r]
    I0 = body.I0
    dI_fT = np.einsum("kpr,kpr->kp", C, C) / np.diag(I0)[:, None]
    I0inv = np.linalg.inv(I0)
    dI_Tf = np.einsum("kpr,kl,lpr->pr", C, I0inv, C).max(axis=1)
    return dI_fT, dI_Tf


def _wI(w: np.ndarray, v: np.ndarray) -> np.ndarray:
    """[w1 I, w2 I, w3 I] v for v of length 3nf."""
    return np.einsum("k,kp->p", w, v.reshape(3, -1))


def coriolis_terms(body: FlexibleBody, q: np.ndarray, qd: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(deformation-dependent rotational Coriolis, W1 Qf' w) of theory section 5 (verified form) at one state:
    the definition that ``_coriolis_parts`` evaluates for all mode pairs at once (the tests hold it to this)."""
    Q, Qd = Qf(q), Qf(qd)
    W2 = body.W2
    dependent = -(Qd.T @ W2 @ Q + Q.T @ W2 @ Qd) @ w - np.cross(w, Q.T @ body.W3 @ qd)
    return dependent, body.W1 @ Qd @ w


def f_cf1(body: FlexibleBody, w: np.ndarray) -> np.ndarray:
    """Constant centrifugal modal force [w I] 0.5 W1^T w (term cf1, theory section 5)."""
    return _wI(w, 0.5 * body.W1.T @ w)


def centrifugal_terms(body: FlexibleBody, q: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """([w I] W2 Qf w, [w I] 0.5 W1^T w) of theory section 5."""
    return _wI(w, body.W2 @ Qf(q) @ w), f_cf1(body, w)


def ratio_state(body: FlexibleBody, q_max: np.ndarray, n: int, signs=None) -> tuple[np.ndarray, np.ndarray]:
    """q and q' of the ratios: first n modes at signs * q_max,p vibrating at Omega_p (theory section 7)."""
    q = np.zeros_like(q_max)
    q[:n] = q_max[:n] * (1.0 if signs is None else np.asarray(signs)[:n])
    return q, np.sqrt(body.eigenvalues) * q


def sign_patterns(n: int) -> np.ndarray:
    """All sign patterns of n modes with the first sign +1 (flipping every sign changes no ratio): (2^(n-1), n)."""
    bits = (np.arange(2 ** max(n - 1, 0))[:, None] >> np.arange(max(n - 1, 0))) & 1
    return np.hstack([np.ones((len(bits), 1)), 1.0 - 2.0 * bits]) if n else np.ones((1, 0))


def _coriolis_parts(body: FlexibleBody, q_max: np.ndarray, n: int, w: np.ndarray):
    """B[:, p, r]: deformation-dependent Coriolis of mode p deflected and mode r moving; D[:, r]: W1 Qf' w of
    mode r moving (both bilinear or linear in the modes, so any sign pattern is a sum of them). ``coriolis_terms``
    of q = a_p e_p, q' = b_r e_r (a = q_max, b = Omega q_max) for every pair at once: with the blocks
    W2[k, i, l, j] (rows k nf + i), W3[k, i, j] and W1[k, l, j],
    ``B[k, p, r] = -a_p b_r (sum_l (W2[k, r, l, p] + W2[k, p, l, r]) w_l + (w x W3[:, p, r])_k)``,
    ``D[k, r] = b_r sum_l W1[k, l, r] w_l``."""
    nf = body.nf
    a = q_max[:n]
    b = np.sqrt(body.eigenvalues[:n]) * a
    W2 = body.W2.reshape(3, nf, 3, nf)[:, :n, :, :n]
    W3 = body.W3.reshape(3, nf, nf)[:, :n, :n]
    sym = np.einsum("krlp,l->kpr", W2, w) + np.einsum("kplr,l->kpr", W2, w)
    B = -(sym + np.cross(w, W3, axisb=0, axisc=0)) * np.outer(a, b)
    D = np.einsum("klr,l->kr", body.W1.reshape(3, 3, nf)[:, :, :n], w) * b
    return B, D


def _worst(num: np.ndarray, den: np.ndarray) -> int:
    """Index of the largest num/den (a vanishing denominator with a finite numerator counts as infinite)."""
    scale = max(num.max(), den.max(), TINY)
    value = np.where(den <= 1e-14 * scale, np.where(num <= 1e-14 * scale, 0.0, np.inf), num / np.maximum(den, TINY))
    return int(np.lexsort((num, value))[-1])


def norm_ratios(body: FlexibleBody, q_max: np.ndarray, n_ratio: int) -> dict:
    """Coriolis (G Table 4) and centrifugal (G Table 5) ratios over the first n_ratio modes, w = (1,1,1):
    the maximum over the modes' sign patterns (exhaustive up to SIGN_SEARCH modes; beyond, the numerator's
    triangle-inequality bound over the all-in-phase denominator, said so) and the all-positive value."""
    n, w = n_ratio, np.ones(3)
    B, D = _coriolis_parts(body, q_max, n, w)
    q, _ = ratio_state(body, q_max, n)
    f1 = f_cf1(body, w)[:n]
    C = np.stack([centrifugal_terms(body, np.eye(body.nf)[p] * q_max[p], w)[0][:n] for p in range(n)], axis=1)
    paper = (Ratio(float(np.linalg.norm(B.sum(axis=(1, 2)))), float(np.linalg.norm(D.sum(axis=1)))),
             Ratio(float(np.linalg.norm(C.sum(axis=1))), float(np.linalg.norm(f1))))
    signs = np.ones(body.nf)
    if n <= SIGN_SEARCH:
        S = sign_patterns(n)
        num = np.linalg.norm(np.einsum("sp,kpr,sr->sk", S, B, S), axis=1)
        den = np.linalg.norm(S @ D.T, axis=1)
        i = _worst(num, den)
        signs[:n] = S[i]
        cf = np.linalg.norm(S @ C.T, axis=1)
        cor, cen = Ratio(float(num[i]), float(den[i])), Ratio(float(cf.max()), paper[1].denominator)
        how = f"maximum over all {len(S)} sign patterns of the first {n} modes"
    else:
        cor = Ratio(float(np.linalg.norm(np.abs(B).sum(axis=(1, 2)))), paper[0].denominator)
        cen = Ratio(float(np.linalg.norm(np.abs(C).sum(axis=1))), paper[1].denominator)
        how = f"triangle-inequality bound over the first {n} modes (more than {SIGN_SEARCH}: not searched)"
    return {"coriolis": cor, "centrifugal": cen, "coriolis_paper": paper[0], "centrifugal_paper": paper[1],
            "signs": signs, "sign_search": how}


def softening_speeds(body: FlexibleBody, stiffened: bool = False) -> np.ndarray:
    """s_crit about each principal axis: s^2 = min eig(Omega^2, Kc(a)), Kc(a) = sum_kl a_k a_l W2_kl, with
    ``stiffened`` min eig(Omega^2, Kc(a) - G(a)) (infinite when no eigenvalue is positive; theory 9)."""
    nf = body.nf
    W2 = body.W2.reshape(3, nf, 3, nf)
    inv_omega = 1 / np.sqrt(body.eigenvalues)
    out = np.full(3, np.inf)
    for k in range(3):
        Kc = W2[k, :, k, :] - (body.geometric[k] if stiffened else 0.0)
        B = inv_omega[:, None] * Kc * inv_omega[None, :]
        mu = np.linalg.eigvalsh(0.5 * (B + B.T)).max()
        if mu > 0:
            out[k] = 1 / np.sqrt(mu)
    return out


def significance(body: FlexibleBody, q_max: np.ndarray, n_ratio: int | None = None) -> Significance:
    """Every measure of theory section 7 for the body at the given q_max."""
    n = min(N_RATIO, body.nf) if n_ratio is None else min(n_ratio, body.nf)
    missing = body.integrals.missing
    dI_L, dI_Q = inertia_change(body, q_max)
    dI_fT, dI_Tf = (None, None) if "W3" in missing else coupling(body, q_max)
    ratios = {} if missing else norm_ratios(body, q_max, n)
    mags = {name: magnitudes(getattr(body, name)) for name in ("I0", "W1", "W2", "W3") if name not in missing}
    s_crit = None if "W2" in missing else softening_speeds(body)
    stiff = None if s_crit is None or body.geometric is None else softening_speeds(body, stiffened=True)
    return Significance(dI_L, dI_Q, dI_fT, dI_Tf, mags, n, ratios.get("coriolis"), ratios.get("centrifugal"), s_crit,
                        not_evaluable(missing), ratios.get("coriolis_paper"), ratios.get("centrifugal_paper"),
                        ratios.get("signs"), ratios.get("sign_search", ""), stiff)


NEEDS = {"dI_Q": ("W2",), "dI_fT": ("W3",), "dI_Tf": ("W3",), "coriolis_ratio": ("W2", "W3"),
         "centrifugal_ratio": ("W2",), "s_crit": ("W2",)}


def not_evaluable(missing: tuple[str, ...]) -> tuple[str, ...]:
    """The measures of theory section 7 that need an invariant in ``missing``."""
    return tuple(name for name, needs in NEEDS.items() if set(needs) & set(missing))
