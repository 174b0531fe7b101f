"""The Lawson DOP853 of sim.lawson in plain numpy, step for step: the reference the tests compare the compiled
scheme against (the same steps, evaluations and samples to round-off). Loads go through ``integrate.Rhs``."""
from __future__ import annotations

import numpy as np

from .dop853 import A, B, C, D, E3, E5, EXPONENT, MAX_FACTOR, MIN_FACTOR, SAFETY, STAGES
from .model import N_ROT, Model


def propagator(model: Model, tau: float) -> np.ndarray:
    """(nf, 2, 2): ``exp(tau M)``, M = [[0, 1], [-lam, -dmp]] per mode, by Sylvester's formula on M's complex
    eigenvalues mu (an independent route to the real closed form of sim.lawson.propagators), by scipy's expm where
    they (nearly) coincide (critical damping)."""
    from scipy.linalg import expm
    M = np.zeros((model.nf, 2, 2))
    M[:, 0, 1], M[:, 1, 0], M[:, 1, 1] = 1.0, -model.eigenvalues, -model.damping
    root = np.sqrt((model.damping / 2 + 0j) ** 2 - model.eigenvalues)
    mu1, mu2 = -model.damping / 2 + root, -model.damping / 2 - root
    I = np.eye(2)
    with np.errstate(all="ignore"):
        E = ((np.exp(mu1 * tau)[:, None, None] * (M - mu2[:, None, None] * I)
              - np.exp(mu2 * tau)[:, None, None] * (M - mu1[:, None, None] * I)) / (mu1 - mu2)[:, None, None]).real
    close = np.abs(mu1 - mu2) * abs(tau) < 1e-3
    if close.any():
        E[close] = expm(tau * M[close])
    return E


def carry(E: np.ndarray, x: np.ndarray) -> np.ndarray:
    """exp(tau L) x for the propagator blocks E (p and w unchanged)."""
    nf = E.shape[0]
    q, v = x[N_ROT:N_ROT + nf], x[N_ROT + nf:]
    return np.concatenate([x[:N_ROT], E[:, 0, 0] * q + E[:, 0, 1] * v, E[:, 1, 0] * q + E[:, 1, 1] * v])


def nonlinear(model: Model, f, t: float, y: np.ndarray) -> np.ndarray:
    """N(t, y) = f(t, y) - L y."""
    nf = model.nf
    out = f(t, y).copy()
    out[N_ROT:N_ROT + nf] = 0.0
    out[N_ROT + nf:] += model.eigenvalues * y[N_ROT:N_ROT + nf] + model.damping * y[N_ROT + nf:]
    return out


def _rms(x, scale) -> float:
    return float(np.sqrt(np.mean((x / scale) ** 2)))


def _shift(model: Model, N: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(s, N_L) of a step from N = N(t, y) (sim.lawson._shift)."""
    nf, lam = model.nf, model.eigenvalues
    shift, base = np.zeros_like(N), np.zeros_like(N)
    on = lam > 0
    base[N_ROT + nf:][on] = N[N_ROT + nf:][on]
    shift[N_ROT:N_ROT + nf][on] = N[N_ROT + nf:][on] / lam[on]
    return shift, base


class _Frame:
    """The propagators of one step from t with step h and shift (s, N_L): ``g(c, V)`` is the G of a stage at node c
    (sim.lawson._g)."""

    def __init__(self, model, f, t, h, shift, base):
        self.model, self.f, self.t, self.h, self.E, self.shift, self.base = model, f, t, h, {}, shift, base

    def prop(self, c: float) -> np.ndarray:
        if c not in self.E:
            self.E[c] = propagator(self.model, c * self.h)
        return self.E[c]

    def g(self, c: float, V: np.ndarray) -> np.ndarray:
        y = self.shift + carry(self.prop(c), V)
        return carry(np.linalg.inv(self.prop(c)), nonlinear(self.model, self.f, self.t + c * self.h, y) - self.base)


def integrate_lawson(model: Model, f, y0, t_end: float, rtol: float, atol, t_out) -> tuple[np.ndarray, int, int]:
    """(samples at t_out, evaluations, accepted steps) of sim.lawson.integrate_lawson, f(t, y) the right-hand side."""
    from .lawson import step_cap
    y, nfev = np.array(y0, float), 2
    N0 = nonlinear(model, f, 0.0, y)
    shift, base = _shift(model, N0)
    cap = step_cap(model.eigenvalues, model.damping)
    h = _initial_step(model, f, y - shift, N0 - base, shift, base, min(t_end, cap), rtol, atol)
    out, row, t, steps = [y.copy()], 1, 0.0, 0
    while t < t_end:
        h = max(h, 10 * abs(np.nextafter(t, np.inf) - t))
        rejected = False
        while True:
            t_new = min(t + min(h, cap), t_end)
            h = t_new - t
            fr, z = _Frame(model, f, t, h, shift, base), y - shift
            K = [N0 - base]
            for s in range(1, STAGES):
                K.append(fr.g(C[s], z + h * (A[s, :s] @ np.array(K))))
            v_new = z + h * (B @ np.array(K))
            y_new = shift + carry(fr.prop(1.0), v_new)
            N_new = nonlinear(model, f, t_new, y_new)
            K.append(carry(np.linalg.inv(fr.prop(1.0)), N_new - base))
            nfev += STAGES
            scale = atol + np.maximum(np.abs(y), np.abs(y_new)) * rtol
            e5, e3 = (carry(fr.prop(1.0), E @ np.array(K)) for E in (E5, E3))
            e5, e3 = np.sum((e5 / scale) ** 2), np.sum((e3 / scale) ** 2)
            err = 0.0 if e5 == 0 and e3 == 0 else abs(h) * e5 / np.sqrt((e5 + 0.01 * e3) * len(y))
            if err < 1.0:
                factor = MAX_FACTOR if err == 0 else min(MAX_FACTOR, SAFETY * err ** EXPONENT)
                h *= min(1.0, factor) if rejected else factor
                break
            h *= max(SAFETY * err ** EXPONENT, MIN_FACTOR)
            rejected = True
        steps += 1
        if row < len(t_out) and t_out[row] <= t_new:
            for s in range(STAGES + 1, 16):
                K.append(fr.g(C[s], z + (t_new - t) * (A[s, :s] @ np.array(K))))
            nfev += 3
            while row < len(t_out) and t_out[row] <= t_new:
                out.append(shift + carry(propagator(model, t_out[row] - t),
                                         _sample(t, t_new - t, z, v_new, np.array(K), t_out[row])))
                row += 1
        y, N0, t = y_new, N_new, t_new
        shift, base = _shift(model, N0)
    return np.array(out), nfev, steps


def _sample(t_old, h, y_old, y_new, K, t_out) -> np.ndarray:
    """DOP853's order-7 interpolant on the v frame (scipy's Dop853DenseOutput)."""
    x = (t_out - t_old) / h
    dy = y_new - y_old
    F = [dy, h * K[0] - dy, 2 * dy - h * (K[STAGES] + K[0])] + [h * (D[r] @ K) for r in range(4)]
    v = np.zeros_like(y_old)
    for r in range(6, -1, -1):
        v = (v + F[r]) * (x if (6 - r) % 2 == 0 else 1 - x)
    return y_old + v


def _initial_step(model, f, z0, g0, shift, base, t_end, rtol, atol) -> float:
    """sim.lawson._initial_step."""
    scale = atol + np.abs(z0) * rtol
    d0, d1 = _rms(z0, scale), _rms(g0, scale)
    h0 = min(1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1, t_end)
    g1 = _Frame(model, f, 0.0, h0, shift, base).g(1.0, z0 + h0 * g0)
    d2 = _rms(g1 - g0, scale) / h0
    h1 = max(1e-6, h0 * 1e-3) if d1 <= 1e-15 and d2 <= 1e-15 else (0.01 / max(d1, d2)) ** (1 / 8)
    return min(100 * h0, h1, t_end)
