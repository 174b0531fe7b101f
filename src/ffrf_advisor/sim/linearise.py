"""Linearisation at steady spin: frequencies of a term set against spin speed (Campbell), stability (theory section 10).

Steady spin ``s`` about a principal axis ``a`` with the modes at their static
centrifugal deflection (``q'' = 0`` at ``q' = 0``, ``w = s a``) is the
equilibrium; the Jacobian of the term set's right-hand side in the
coordinates ``(w, q, q')`` (the orientation does not enter the dynamics of a
free body) has eigenvalues ``mu``; each pair ``+-i omega`` is a frequency
``omega / 2 pi``, and an eigenvalue with a positive real part means the
equilibrium is unstable (the term set's own stability limit). The
Jacobian's columns of q and q' are exact (``equations.modal_derivatives``:
the forces are polynomials in q and q'); those of w are central differences
with steps ``1e-6`` of |w| (truncation ``h^2``, round-off about 1e-10 of a
column). Central differences in q too, with steps of 1e-6 of q's natural
size, moved a frequency by up to 8e-5 of itself where the centrifugal forces
are large against the stiffness change (the carbody's full set at 3000 rad/s:
eps times those forces over the step; 5e-10 now, tests/test_jacobian.py).

Where the Jacobian decouples, its eigenproblem is solved block by block
(``eigen``): a symmetric body's bending in two planes, its torsion and its
axial modes are independent at some spins, and the dense eigensolver's work
grows with the cube of the size (the 100-mode bar's reference at 300 rad/s,
blocks of 102, 100 and 1 instead of 203: 11 ms instead of 17; its 2 x 2
blocks about another axis: 7 ms instead of 28). Where a coupling vanishes
the Jacobian still holds round-off (the invariants' own, the w columns'
differences: 1e-13 of the largest entry and less on the zoo's bodies), so
blocks are found in the balanced Jacobian ``D^-1 J D`` (D: the difference
steps, a similarity) among the entries above SPLIT of its largest. What lies
between blocks is dropped only while its norm stays below DROPPED of that
entry: the eigenvalues are then exact for a Jacobian that close (they move by
at most that times their condition, Bauer-Fike), which is within the
Jacobian's own round-off (its w columns': eps over the 1e-6 steps, about
2e-10); else the whole matrix is solved, as where nothing decouples. A
block of modes alone whose velocity coupling vanishes (a bar's modes bending
in one plane) is ``[[0, I], [A, 0]]`` in (q, q'): it is solved as second
order, from the eigenproblem of A, half its size (``mu = +-sqrt(lambda)``;
about a fifth of the work), the velocity coupling dropped counting against
the same DROPPED.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from . import equations as eq
from .model import Model

UNSTABLE = 1e-6  # growth rate Re(mu) / |mu|_max above which the equilibrium counts as unstable
# Campbell (``campbell``): a point is not drawn where the static stiffness K(s) of the set (symmetric) has an
# eigenvalue within SINGULAR x Omega_1^2 of zero ("singular": its softest branch is then below sqrt(SINGULAR) = 3 %
# of f_1, the static deflection grows as 1 / lambda and at s_crit itself the linearisation is undefined: a sample
# on s_crit gave frequencies of 2,700 Hz on a beam whose modes lie below 2,000 Hz), nor where the set is unstable:
# K(s) indefinite (past the set's own s_crit, theory 9; a gyroscopic system with negative stiffness may look
# stable undamped, but any dissipation destabilises it, and the frequencies linearised about the large static
# deflection there spiked to 970 Hz from 150 Hz on genstruct1) or an oscillation owned by the modes growing by
# more than GROWTH of its own rate (Re(mu) > GROWTH |Im(mu)|: 0.6 % an oscillation; flutter where branches
# meet). TIE weighs the frequency distance when the MAC ties (degenerate modes).
SINGULAR = 1e-3
GROWTH = 1e-3
TIE = 1e-3
SPLIT = 1e-12    # balanced entries below this fraction of the largest may lie between blocks (module docstring)
DROPPED = 1e-10  # at most this Frobenius norm, over the largest balanced entry, is dropped between blocks


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
    K, f0 = _static_stiffness(model, w)
    return np.linalg.solve(K, f0)


def spin_vector(axis, s: float) -> tuple[np.ndarray, np.ndarray]:
    """(the unit axis, the angular velocity ``w = s a``) of a steady spin ``s`` about ``axis``."""
    a = np.asarray(axis, float)
    a = a / np.linalg.norm(a)
    return a, s * a


def _static_stiffness(model: Model, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(K, f0): the flexible force at spin w and q' = 0 is ``f0 - K q`` (affine in q: K from
    equations.stiffness_columns; Omega^2 - s^2 Kc + s^2 G for the full set)."""
    zero = np.zeros(model.nf)
    return -eq.stiffness_columns(model, w).T, eq.flexible_force(model, zero, zero, w, zero)


def _rates(model: Model, x: np.ndarray, d: eq.Deformed | None = None) -> np.ndarray:
    """d(w, q, q')/dt at the states x (..., 3 + 2 nf) of a free body without loads (``d``: their Deformed
    pieces where the caller has them)."""
    nf = model.nf
    w, q, qd = x[..., :3], x[..., 3:3 + nf], x[..., 3 + nf:]
    wd, qdd = eq.accelerations(model, q, qd, w, np.zeros(3), np.zeros(nf), d)
    return np.concatenate([wd, qd, qdd], axis=-1)


def jacobian(model: Model, x: np.ndarray, steps: np.ndarray | None = None) -> np.ndarray:
    """Jacobian of the rates of (w, q, q') at x: the columns of q and q' exact (equations.modal_derivatives),
    those of w central differences (``steps``: ``_difference_steps`` where the caller has them), x and the six
    states in one batch."""
    nf, h = model.nf, (_difference_steps(model, x) if steps is None else steps)[:3]
    steps = np.zeros((7, len(x)))
    steps[:3, :3], steps[3:6, :3] = np.diag(h), -np.diag(h)
    states = x + steps
    d = eq.Deformed(model, states[:, 3:3 + nf])
    rates = _rates(model, states, d)
    at_x = rates[6, :3], rates[6, 3 + nf:]
    dwd, dqdd = eq.modal_derivatives(model, x[3:3 + nf], x[3 + nf:], x[:3], at_x, d.row(6))
    J = np.zeros((len(x), len(x)))
    J[:, :3] = ((rates[:3] - rates[3:6]) / (2 * h)[:, None]).T
    J[:3, 3:], J[3 + nf:, 3:] = dwd.T, dqdd.T
    J[3:3 + nf, 3 + nf:] = np.eye(nf)  # the rates of q are q'
    return J


def _difference_steps(model: Model, x: np.ndarray) -> np.ndarray:
    return 1e-6 * np.maximum(np.abs(x), _coordinate_scales(model, x))


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


def modal_spectrum(model: Model, axis, s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(frequencies [1/time], their mode shapes: the q parts of the eigenvectors as columns (nf, n), the static
    deflection linearised about) of the modes' oscillations at steady spin ``s`` about ``axis``, in ascending
    frequency."""
    lin, shapes, _ = _linearised(model, axis, s)
    return lin.frequencies, shapes, lin.q


def _linearised(model: Model, axis, s: float, q=None) -> tuple[Linearisation, np.ndarray, np.ndarray]:
    """(the linearisation, the q parts of its modes' eigenvectors (nf, n) in ascending frequency, all the
    eigenvectors as columns of (w, q, q')); ``q``: the static deflection at the spin where the caller has it."""
    a, q, J, steps = equilibrium(model, axis, s, q)
    mu, V = eigen(J, steps)
    top = np.abs(mu).max() if mu.size else 1.0
    osc = np.flatnonzero(mu.imag > 1e-9 * top)
    modal = _modal_oscillations(_modal_share(model, V[:, osc]), model.nf)
    own = osc[modal][np.argsort(mu.imag[osc[modal]], kind="stable")]
    to_hz = lambda idx: np.sort(mu.imag[idx]) / (2 * np.pi)  # noqa: E731
    lin = Linearisation(s, a, q, mu, to_hz(own), to_hz(osc[~modal]), _grows(mu))
    return lin, V[3:3 + model.nf, own], V


def unstable(model: Model, axis, s: float, q=None) -> bool:
    """``linearise(model, axis, s).unstable`` from the eigenvalues alone (no eigenvectors: about a third less
    work at 100 modes); ``q``: the static deflection at the spin where the caller has it."""
    return _grows(eigen(*equilibrium(model, axis, s, q)[2:], vectors=False))


def equilibrium(model: Model, axis, s: float, q=None) -> tuple[np.ndarray, ...]:
    """(the unit axis, the static deflection, the ``jacobian`` of the rates of (w, q, q') there, its
    difference steps) of steady spin s about axis; ``q``: the deflection where the caller has it."""
    a, w = spin_vector(axis, s)
    q = static_deflection(model, w) if q is None else q
    x = np.concatenate([w, q, np.zeros(model.nf)])
    steps = _difference_steps(model, x)
    return a, q, jacobian(model, x, steps), steps


def eigen(J: np.ndarray, steps: np.ndarray, vectors: bool = True):
    """``np.linalg.eig(J)`` (or its eigenvalues alone) of the Jacobian of (w, q, q'), block by block where J
    decouples (module docstring: SPLIT, DROPPED; ``steps``: the difference steps, the balancing D): eigenvectors
    zero outside their block, unit length like eig's; the eigenvalues block after block. Blocks of one kind and
    size go to one stacked call; a block of modes without velocity coupling (``_blocks``) to its half-size
    problem (``_second_order``), or whole where that would lose accuracy."""
    solve = np.linalg.eig if vectors else np.linalg.eigvals
    blocks = _blocks(J, steps)
    if blocks is None:
        return solve(J)
    nf = (len(J) - 3) // 2
    whole, solved = [idx for idx, half in blocks if not half], []
    for size in sorted({len(idx) for idx, half in blocks if half}):
        q = np.array([idx for idx, half in blocks if half and len(idx) == size])
        states, mu, V, kept = _second_order(J[(q + nf)[:, :, None], q[:, None, :]], q, nf, vectors)
        solved.append((states[kept], mu[kept], None if V is None else V[kept]))
        whole += list(states[~kept])
    for size in sorted({len(idx) for idx in whole}):
        idx = np.array([b for b in whole if len(b) == size])  # (blocks of this size, size)
        found = solve(J[idx[:, :, None], idx[:, None, :]])
        solved.append((idx, *(found if vectors else (found, None))))
    return _assembled(len(J), solved, vectors)


def _assembled(n: int, solved: list[tuple], vectors: bool):
    """(eigenvalues (n,), eigenvectors (n, n)) or the eigenvalues of ``eigen`` from its (state indices, mu, V)
    of stacked blocks, the blocks' eigenvalues one after the other."""
    mu, V = np.empty(n, complex), np.zeros((n, n), complex)
    start = 0
    for idx, lam, W in solved:
        cols = start + np.arange(idx.size).reshape(idx.shape)
        mu[cols] = lam
        if vectors:
            V[idx[:, :, None], cols[:, None, :]] = W
        start += idx.size
    return (mu, V) if vectors else mu


def _second_order(A: np.ndarray, q: np.ndarray, nf: int, vectors: bool) -> tuple[np.ndarray, ...]:
    """Stacked blocks of modes (``q``: their indices) where J = [[0, I], [A, 0]] on (q, q'): from the eigenpairs
    (lambda, w) of A those of J, ``mu = +-sqrt(lambda)`` with the columns ``(w, mu w)`` of unit length, half
    the size (about a fifth of the work). The eigensolver's backward error on A, eps max|lambda|, moves each
    lambda by that over |lambda| relative: a block is ``kept`` where that stays within DROPPED (the
    differences' own round-off), else it is to be solved whole (a wide spread of frequencies: from 1 to 1000 the
    half problem's lowest one is 4e-11 off, the whole one's 4e-14). (state indices, mu, V or None, kept)."""
    found = np.linalg.eig(A) if vectors else (np.linalg.eigvals(A), None)
    lam = found[0].astype(complex)
    size = np.abs(lam)
    kept = np.finfo(float).eps * size.max(axis=-1) <= DROPPED * size.min(axis=-1)
    root = np.sqrt(lam)
    mu = np.concatenate([root, -root], axis=-1)
    states = np.concatenate([q, q + nf], axis=-1)
    if not vectors:
        return states, mu, None, kept
    W = np.concatenate([found[1], found[1]], axis=-1) / np.sqrt(1 + np.abs(mu) ** 2)[:, None, :]
    return states, mu, np.concatenate([W, mu[:, None, :] * W], axis=1), kept


def _blocks(J: np.ndarray, steps: np.ndarray) -> list[tuple[np.ndarray, bool]] | None:
    """The independent blocks of J (module docstring) as (index set, half), or None: one block, more dropped
    between blocks than DROPPED allows, or entries not finite (the dense solve reports them). ``half``
    (``_halves``): the block holds q and q' of the same modes alone and is solved as second order, its index
    set then that of q."""
    B = np.abs(J) * steps[None, :] / steps[:, None]  # the balanced D^-1 J D, D = diag(steps)
    top = B.max(initial=0.0)
    if not np.isfinite(top):
        return None
    label = _components(B > SPLIT * top)
    spare = (DROPPED * top) ** 2 - np.sum(B[label[:, None] != label[None, :]] ** 2)
    if label.max(initial=0) == 0 or spare < 0:
        return None
    half = _halves(J, B, label, spare)
    order = np.argsort(label, kind="stable")
    blocks = np.split(order, np.flatnonzero(np.diff(label[order])) + 1)
    return [(idx[:len(idx) // 2] if half[k] else idx, bool(half[k])) for k, idx in enumerate(blocks)]


def _halves(J: np.ndarray, B: np.ndarray, label: np.ndarray, spare: float) -> np.ndarray:
    """Per block (``label``) whether it is solved as second order: it holds q and q' of the same modes alone,
    the q rows of J are q' exactly (``J[q] = [0, 0, I]``, as the differences give them), and its velocity
    coupling, the balanced ``J[q'', q']`` within it, is dropped while the squared norms of those dropped stay
    within ``spare`` (DROPPED's, beside what lies between blocks), blocks taken in order."""
    nf, count = (len(J) - 3) // 2, label.max() + 1
    half = np.zeros(count, dtype=bool)
    q, qd = slice(3, 3 + nf), slice(3 + nf, None)
    if len(J) != 3 + 2 * nf or J[q, :3 + nf].any() or not np.array_equal(J[q, qd], np.eye(nf)):
        return half
    paired = label[q] == label[qd]
    half[:] = True
    half[np.concatenate([label[:3], label[q][~paired], label[qd][~paired]])] = False
    lv = label[qd]
    within = lv[:, None] == lv[None, :]
    lost = np.bincount(np.broadcast_to(lv[:, None], within.shape)[within], weights=B[qd, qd][within] ** 2,
                       minlength=count)
    for k in np.flatnonzero(half):
        half[k] = lost[k] <= spare
        spare -= lost[k] if half[k] else 0.0
    return half


def _components(linked: np.ndarray) -> np.ndarray:
    """Per index its connected component (0, 1, ... in order of first index) of the undirected graph with an
    edge where ``linked[i, j]`` or ``linked[j, i]``: every index takes the least label among its neighbours
    and then its label's label, until nothing changes (scipy.sparse.csgraph would import scipy, which the
    analysis of a cached body never loads)."""
    n = len(linked)
    near = linked | linked.T | np.eye(n, dtype=bool)
    label = np.arange(n)
    while True:
        least = np.where(near, label[None, :], n).min(axis=1)
        least = least[least]
        if np.array_equal(least, label):  # each label is its component's first index: number them in order
            return (np.cumsum(label == np.arange(n)) - 1)[label]
        label = least


def _grows(mu: np.ndarray) -> bool:
    """Whether an eigenvalue's real part exceeds UNSTABLE of the largest modulus."""
    return bool(mu.size and np.any(mu.real > UNSTABLE * np.abs(mu).max()))


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


class Campbell(NamedTuple):
    """Branches of a term set against spin (``campbell``): ``frequencies`` (len(speeds), nf) [1/time], column p
    the branch of mode p, NaN where no point is drawn; ``gaps`` per speed "" (drawn), "singular" (the static
    stiffness is singular: the linearisation is undefined, at s_crit) or "unstable" (past s_crit, or an
    oscillation of the modes grows: the set cannot hold the steady spin)."""

    frequencies: np.ndarray
    gaps: np.ndarray


def campbell(model: Model, axis, speeds) -> Campbell:
    """The flexible frequencies of the term set at steady spin about ``axis`` at each of ``speeds`` (ascending), as
    branches: column p starts as mode p (its shape at rest is the unit vector e_p) and is followed from speed to
    speed by its mode shape, the q part of the eigenvector (modal coordinates are mass-normalised, so the plain
    MAC is the mass-weighted one): the MAC of each branch's last shape with each new shape, assigned by
    ``best_pairs`` (the optimal assignment; ties by frequency), so branches cross where the modes cross instead
    of swapping at the crossing as sorted frequencies do. No point where the linearisation is singular or the set
    unstable (``Campbell.gaps``): a row of NaN, a gap in every branch, not a spike; a single NaN where a branch's
    oscillation belongs to the rigid wobble at that speed (near a crossing with it)."""
    nf, speeds = model.nf, np.asarray(speeds, float)
    f = np.full((len(speeds), nf), np.nan)
    gaps = np.full(len(speeds), "", dtype=object)
    last, last_f = np.eye(nf, dtype=complex), np.sqrt(np.abs(model.eigenvalues)) / (2 * np.pi)
    for i, s in enumerate(speeds):
        freqs, shapes, gaps[i] = _campbell_point(model, axis, s)
        if gaps[i] or not len(freqs):
            continue
        A = last / np.linalg.norm(last, axis=0)
        B = shapes / np.linalg.norm(shapes, axis=0)
        mac = np.abs(A.conj().T @ B) ** 2  # (branches, new oscillations)
        near = np.abs(freqs[None, :] - last_f[:, None]) / max(last_f.max(), freqs.max())
        rows, cols = best_pairs(mac - TIE * np.minimum(near, 1.0))
        f[i, rows] = freqs[cols]
        last[:, rows], last_f[rows] = shapes[:, cols], freqs[cols]
    return Campbell(f, gaps)


def best_pairs(score: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The pairing (rows, cols) of largest total score (rows x columns, any shape). When every row's best column
    is another column, that is it (no pairing beats each row's own maximum); else scipy's linear_sum_assignment,
    whose import (0.45 s with scipy.optimize) the usual, diagonally dominant MAC matrix so does without."""
    rows, cols = np.arange(len(score)), np.argmax(score, axis=1)
    if len(set(cols.tolist())) == len(cols):  # not np.unique: its first call imports numpy.ma (18 ms)
        return rows, cols
    from scipy.optimize import linear_sum_assignment
    return linear_sum_assignment(-score)


def campbell_speeds(k: int, speed: float, s_crits, points: int, margin: float) -> np.ndarray:
    """``points`` speeds from 0 to ``margin`` x the largest of ``speed`` and the finite s_crit about axis k of
    each of ``s_crits`` (arrays per principal axis, or None): each axis its own range."""
    crit = [c[k] for c in s_crits if c is not None and np.isfinite(c[k])]
    return np.linspace(0.0, margin * max([speed, 1e-9, *crit]), points)


def _campbell_point(model: Model, axis, s: float) -> tuple[np.ndarray, np.ndarray, str]:
    """(frequencies, shapes (nf, n), gap) at one speed of ``campbell``; gap "singular" or "unstable" (then the
    frequencies are not to be drawn) or ""."""
    a, w = spin_vector(axis, s)
    K, f0 = _static_stiffness(model, w)
    lam = np.linalg.eigvalsh(0.5 * (K + K.T))  # K is symmetric (Omega^2 - s^2 Kc + s^2 G and the like)
    none = np.array([]), np.zeros((model.nf, 0))
    if np.abs(lam).min() < SINGULAR * np.abs(model.eigenvalues).min():
        return *none, "singular"
    if lam[0] < 0:  # past the set's own s_crit (theory 9)
        return *none, "unstable"
    lin, shapes, V = _linearised(model, a, s, np.linalg.solve(K, f0))
    mu = lin.eigenvalues
    growing = (mu.real > UNSTABLE * np.abs(mu).max()) & (mu.real > GROWTH * np.abs(mu.imag))
    if np.any(_modal_share(model, V[:, growing]) >= 0.5):  # the modes' own: not the rigid tumbling (middle axis)
        return lin.frequencies, shapes, "unstable"
    return lin.frequencies, shapes, ""
