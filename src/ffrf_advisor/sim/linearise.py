"""Linearisation at steady spin: frequencies of a term set against spin speed (Campbell), stability (theory section 10).

Steady spin ``s`` about a principal axis ``a`` with the modes at their static
centrifugal deflection (``q'' = 0`` at ``q' = 0``, ``w = s a``) is the
equilibrium; the Jacobian of the term set's right-hand side in the
coordinates ``(w, q, q')`` (the orientation does not enter the dynamics of a
free body) has eigenvalues ``mu``; each pair ``+-i omega`` is a frequency
``omega / 2 pi``, and an eigenvalue with a positive real part means the
equilibrium is unstable (the term set's own stability limit). The Jacobian
is taken by central differences of the plain-numpy right-hand side with
steps ``1e-6`` of each coordinate's scale (truncation error ``h^2``, far
below the frequency differences reported).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import equations as eq
from .model import Model

UNSTABLE = 1e-6  # growth rate Re(mu) / |mu|_max above which the equilibrium counts as unstable


@dataclass(frozen=True)
class Linearisation:
    """At spin ``s`` about ``axis``: the equilibrium modes, eigenvalues, frequencies [1/time] and stability."""

    s: float
    axis: np.ndarray
    q: np.ndarray
    eigenvalues: np.ndarray
    frequencies: np.ndarray        # oscillations owned by the modes (most of their energy modal)
    rigid_frequencies: np.ndarray  # the wobble of the spinning body
    unstable: bool


def static_deflection(model: Model, w: np.ndarray) -> np.ndarray:
    """``q`` with ``flexible_force(q, 0, w) = 0``: the centrifugal deflection of the term set at spin w."""
    nf, zero = model.nf, np.zeros(model.nf)
    f0 = eq.flexible_force(model, zero, zero, w, zero)
    K = -(eq.flexible_force(model, np.eye(nf), np.zeros((nf, nf)), w, zero) - f0).T  # a column per q = e_j
    return np.linalg.solve(K, f0)


def _rates(model: Model, x: np.ndarray) -> np.ndarray:
    """d(w, q, q')/dt at the states x (..., 3 + 2 nf) of a free body without loads."""
    nf = model.nf
    w, q, qd = x[..., :3], x[..., 3:3 + nf], x[..., 3 + nf:]
    wd, qdd = eq.accelerations(model, q, qd, w, np.zeros(3), np.zeros(nf))
    return np.concatenate([wd, qd, qdd], axis=-1)


def jacobian(model: Model, x: np.ndarray) -> np.ndarray:
    """Central-difference Jacobian of the rates of (w, q, q') at x, all columns in one batched evaluation."""
    h = 1e-6 * np.maximum(np.abs(x), _coordinate_scales(model, x))
    step = np.diag(h)
    return ((_rates(model, x + step) - _rates(model, x - step)) / (2 * h)[:, None]).T


def _coordinate_scales(model: Model, x: np.ndarray) -> np.ndarray:
    """Natural sizes of w, q, q' for difference steps: |w| (or 1), 1/Omega_1 ... in body units."""
    nf = model.nf
    w_scale = max(np.linalg.norm(x[:3]), 1.0)
    om = np.sqrt(np.abs(model.eigenvalues))
    q_scale = np.full(nf, 1.0 / max(om.min(), 1e-12))
    return np.concatenate([np.full(3, w_scale), q_scale * 1e-3, q_scale * 1e-3 * om])


def linearise(model: Model, axis, s: float) -> Linearisation:
    """The term set linearised at steady spin ``s`` (rad per time unit) about unit ``axis``."""
    return _linearised(model, axis, s)[0]


def modal_spectrum(model: Model, axis, s: float) -> tuple[np.ndarray, np.ndarray, bool]:
    """(frequencies [1/time], their mode shapes: the q parts of the eigenvectors as columns (nf, n), unstable)
    of the modes' oscillations at steady spin ``s`` about ``axis``, in ascending frequency."""
    lin, shapes = _linearised(model, axis, s)
    return lin.frequencies, shapes, lin.unstable


def _linearised(model: Model, axis, s: float) -> tuple[Linearisation, np.ndarray]:
    a = np.asarray(axis, float)
    a = a / np.linalg.norm(a)
    w = s * a
    q = static_deflection(model, w)
    x = np.concatenate([w, q, np.zeros(model.nf)])
    mu, V = np.linalg.eig(jacobian(model, x))
    top = np.abs(mu).max() if mu.size else 1.0
    unstable = bool(np.any(mu.real > UNSTABLE * top))
    osc = np.flatnonzero(mu.imag > 1e-9 * top)
    modal = _modal_oscillations(_modal_share(model, V[:, osc]), model.nf)
    own = osc[modal][np.argsort(mu.imag[osc[modal]], kind="stable")]
    to_hz = lambda idx: np.sort(mu.imag[idx]) / (2 * np.pi)  # noqa: E731
    lin = Linearisation(s, a, q, mu, to_hz(own), to_hz(osc[~modal]), unstable)
    return lin, V[3:3 + model.nf, own]


def _modal_oscillations(share: np.ndarray, nf: int) -> np.ndarray:
    """Oscillations owned by the modes: most of their energy modal, at most nf of them (the most modal ones;
    near a crossing the spinning body's wobble can carry just over half its energy in a mode)."""
    modal = share >= 0.5
    if modal.sum() > nf:
        modal[:] = False
        modal[np.argsort(-share, kind="stable")[:nf]] = True
    return modal


def _modal_share(model: Model, V: np.ndarray) -> np.ndarray:
    """Per eigenvector (columns of (w, q, q')): modal energy / (modal + rotational energy)."""
    nf = model.nf
    w, q, qd = V[:3], V[3:3 + nf], V[3 + nf:]
    rot = np.real(np.einsum("ip,ij,jp->p", w.conj(), model.I0, w))
    flex = np.sum(np.abs(qd) ** 2 + np.abs(model.eigenvalues)[:, None] * np.abs(q) ** 2, axis=0)
    return flex / (flex + rot)


def campbell(model: Model, axis, speeds) -> tuple[np.ndarray, np.ndarray]:
    """(flexible frequencies (len(speeds), nf) [1/time], NaN where a mode has lost its frequency; unstable flags)."""
    rows, flags = [], []
    for s in speeds:
        lin = linearise(model, axis, s)
        f = lin.frequencies
        rows.append(np.pad(f, (model.nf - len(f), 0), constant_values=np.nan))
        flags.append(lin.unstable)
    return np.array(rows), np.array(flags)
