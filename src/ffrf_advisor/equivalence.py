"""Are two FE modal bodies the same model? Comparison to the accuracy of their eigenpairs (docs/samples.md).

Two runs of the same recipe on two machines agree only to what their
eigensolvers resolved, and their modes may differ in sign or, inside a
cluster of (near-)equal eigenvalues, by a rotation. This module compares two
bodies on the same mesh independently of both, with tolerances computed
from the data and the stiffness matrix K:

- each eigenpair's accuracy is its residual ``r_p = K phi_p - lambda_p M phi_p``
  in the ``M^-1`` norm plus the rounding of computing it,
  ``e_p = |r_p|_{M^-1} + eps || |K| |phi_p| ||_{M^-1}``; by Bauer-Fike an exact
  eigenvalue lies within ``e_p``. Body ``a`` is held to the accuracy of the
  reference ``b``: ``|lambda_a - lambda_b| <= 2 e_b`` (a first-order bound,
  10 to 1000 times the differences seen between machines; a bound with
  ``e_a`` would pass any model whose eigenpairs are near those of K, such
  as the same mesh with E changed by 0.1 %);
- each body must be an eigen-solution at all: ``e_p <= RESIDUAL_MAX lambda_p``
  plus the rounding times ``sqrt(nnz per row of K)`` (a statistical bound
  for the rounding of the products). ARPACK at tol=0 leaves ``e_p`` of
  1e-7..2e-5 of lambda on the samples, the ill-conditioned thin plate 8e-2;
  two modes of different eigenvalues mixed leave about their difference;
- mode accuracy (Davis-Kahan): ``sin theta_p <= e_p / gap_p`` with ``gap_p``
  the distance to the nearest other eigenvalue (0 for the rigid modes; the
  last mode's unknown upper neighbour is taken as far as its lower one).
  Modes whose bound exceeds ``CLUSTER_ANGLE`` form a cluster, compared as a
  subspace with the cluster's gap to the rest;
- modes are aligned per cluster by the orthogonal factor of
  ``Phi_a^T M Phi_b`` (a sign for a single mode), then each mode-dependent
  quantity is compared with the bound that ``theta`` from ``e_a + e_b`` implies:
  ``|dPhi|_M <= theta``, ``|dIbar_kl| <= theta sqrt(I_kk)``,
  ``|dSbar_pq| <= theta_p + theta_q``, ``|d sum m S| <= theta sqrt(m)``,
  and the largest stress of a single mode by first-order perturbation,
  ``|dsigma_p| <= sum_{q != p} (e_a + e_b)_p / |lambda_q - lambda_p| sigma_q``;
- the principal frame turns by ``dR <= eps |I0| / gap(I0)`` (its eigenvalue
  gaps, first order), which moves points by ``dR L`` and turns every mode;
- sums over n nodes (mass, first moment, I) agree to ``n eps`` of their
  natural scale (m, m L, m L^2; worst-case summation).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .body import FlexibleBody
from .fe.assembly import full_mass

EPS = np.finfo(float).eps
RESIDUAL_MAX = 0.1    # relative residual above which a pair is no eigenpair
CLUSTER_ANGLE = 1e-2  # rad: modes not determined better than this are compared as a subspace


@dataclass(frozen=True)
class Finding:
    """One compared quantity: largest difference, its tolerance (same units), and whether it holds."""

    quantity: str
    difference: float
    tolerance: float

    @property
    def ok(self) -> bool:
        return bool(self.difference <= self.tolerance)


@dataclass(frozen=True)
class Comparison:
    """The findings of a comparison and the clusters of modes compared as subspaces (0-based)."""

    findings: tuple[Finding, ...]
    clusters: tuple[tuple[int, ...], ...]

    @property
    def ok(self) -> bool:
        return all(f.ok for f in self.findings)

    def failed(self) -> list[Finding]:
        return [f for f in self.findings if not f.ok]

    def summary(self) -> str:
        return "; ".join(f"{f.quantity}: {f.difference:.3g} {'<=' if f.ok else '>'} {f.tolerance:.3g}"
                         for f in self.findings)


def _m_inverse_norms(Ms: sp.sparray, V: np.ndarray) -> np.ndarray:
    """Column norms ``sqrt(v^T M^-1 v)`` of V (3n x k, node-interleaved) with M = Ms kron I3."""
    n, k = Ms.shape[0], V.shape[1]
    solve = spla.factorized(sp.csc_array(Ms))
    W = np.stack([solve(np.ascontiguousarray(c)) for c in V.reshape(n, 3 * k).T], axis=1)
    return np.sqrt(np.abs(np.einsum("ip,ip->p", V, W.reshape(3 * n, k))))


def eigenpair_accuracy(K: sp.sparray, body: FlexibleBody) -> tuple[np.ndarray, np.ndarray]:
    """Per mode: (e_p, rounding_p) with ``e_p = |r_p|_{M^-1} + rounding_p`` (eigenvalue units)."""
    Ms, nf = body.fe.Ms, body.nf
    X = body.fe.Phi.reshape(-1, nf)
    R = K @ X - (full_mass(Ms) @ X) * body.eigenvalues
    rounding = EPS * _m_inverse_norms(Ms, np.abs(K) @ np.abs(X))
    return _m_inverse_norms(Ms, R) + rounding, rounding


def clusters(eigenvalues: np.ndarray, accuracy: np.ndarray) -> tuple[tuple[int, ...], ...]:
    """Runs of consecutive modes whose neighbour gap gives an angle bound above CLUSTER_ANGLE."""
    groups, current = [], [0]
    for p in range(1, len(eigenvalues)):
        gap = eigenvalues[p] - eigenvalues[p - 1]
        if gap <= 0 or max(accuracy[p], accuracy[p - 1]) / gap > CLUSTER_ANGLE:
            current.append(p)
        else:
            groups.append(tuple(current))
            current = [p]
    groups.append(tuple(current))
    return tuple(groups)


def cluster_angles(eigenvalues: np.ndarray, accuracy: np.ndarray, groups) -> np.ndarray:
    """Davis-Kahan bound sin theta per mode: the cluster's accuracy over its gap to the rest (at most 1)."""
    lam = np.asarray(eigenvalues, float)
    theta = np.ones(len(lam))
    for g in map(list, groups):
        others = np.delete(lam, g)
        lo, hi = lam[g].min(), lam[g].max()
        below, above = others[others < lo], others[others > hi]
        gap_down = lo - (below.max() if below.size else 0.0)
        gap_up = above.min() - hi if above.size else gap_down  # unknown next mode: as far as the last gap
        gap = min(gap_down, gap_up)
        if gap > 0:
            theta[g] = min(accuracy[g].max() / gap, 1.0)
    return theta


def alignment(Phi_a: np.ndarray, Phi_b: np.ndarray, M: sp.sparray, groups) -> np.ndarray:
    """Block-diagonal orthogonal Q (nf x nf) with Phi_a Q closest to Phi_b in the M-norm, per cluster."""
    nf = Phi_a.shape[-1]
    O = Phi_a.reshape(-1, nf).T @ (M @ Phi_b.reshape(-1, nf))
    Q = np.zeros((nf, nf))
    for g in groups:
        ix = np.ix_(g, g)
        U, _, Vt = np.linalg.svd(O[ix])
        Q[ix] = U @ Vt
    return Q


def frame_turn_bound(body: FlexibleBody) -> float:
    """First-order turn (rad) of the principal frame by round-off in I0: eps |I0| / min eigenvalue gap."""
    ev = np.linalg.eigvalsh(body.I0)
    gap = np.diff(ev).min()
    return float(min(EPS * ev.max() / gap, 1.0)) if gap > 0 else 1.0


def compare_modal_bodies(a: FlexibleBody, b: FlexibleBody, K: sp.sparray) -> Comparison:
    """Compare body ``a`` with body ``b`` (same mesh, nodal FE data on both; K in their frame)."""
    if a.fe is None or b.fe is None:
        raise ValueError("both bodies need nodal FE data (mesh, Ms, modes)")
    if a.nf != b.nf or a.fe.mesh.n_nodes != b.fe.mesh.n_nodes:
        return Comparison((Finding(f"size ({a.nf} vs {b.nf} modes, {a.fe.mesh.n_nodes} vs "
                                   f"{b.fe.mesh.n_nodes} nodes)", 1.0, 0.0),), ())
    (ea, ra), (eb, rb) = eigenpair_accuracy(K, a), eigenpair_accuracy(K, b)
    acc = ea + eb
    groups = clusters(b.eigenvalues, acc)
    turn = frame_turn_bound(b)
    theta = cluster_angles(b.eigenvalues, acc, groups) + 2 * turn
    Q = alignment(a.fe.Phi, b.fe.Phi, full_mass(b.fe.Ms), groups)
    row = np.sqrt(np.diff(sp.csr_array(K).indptr).max())
    converged = max((e / (RESIDUAL_MAX * body.eigenvalues + row * r)).max() for e, r, body in ((ea, ra, a), (eb, rb, b)))
    findings = (_global_findings(a, b, turn)
                + [Finding("residual / eigenpair limit", converged, 1.0),
                   Finding("eigenvalues / accuracy", (np.abs(a.eigenvalues - b.eigenvalues) / (2 * eb)).max(), 1.0)]
                + _modal_findings(a, b, theta, Q)
                + _stress_findings(a, b, acc, groups))
    return Comparison(tuple(findings), tuple(g for g in groups if len(g) > 1))


def _global_findings(a: FlexibleBody, b: FlexibleBody, turn: float) -> list[Finding]:
    """Mesh, mass, first moment and second moments: nodal sums, to n eps of their scales."""
    m, L, n = b.mass, b.largest_dimension(), b.fe.mesh.n_nodes
    sums = n * EPS
    cells_a, cells_b = a.fe.mesh.cells, b.fe.mesh.cells
    same_cells = cells_a.keys() == cells_b.keys() and all(np.array_equal(cells_a[t], cells_b[t]) for t in cells_b)
    ia, ib = a.integrals, b.integrals
    return [
        Finding("cells differ (0: no)", 0.0 if same_cells else 1.0, 0.0),
        Finding("points / L", np.abs(a.fe.mesh.points - b.fe.mesh.points).max() / L, turn + sums),
        Finding("mass / m", abs(ia.mass - m) / m, sums),
        Finding("first moment / (m L)", np.abs(ia.first_moment - ib.first_moment).max() / (m * L), turn + sums),
        Finding("I / (m L^2)", np.abs(ia.I - ib.I).max() / (m * L**2), 2 * turn + sums),
    ]


def _modal_findings(a: FlexibleBody, b: FlexibleBody, theta: np.ndarray, Q: np.ndarray) -> list[Finding]:
    """Modes, Ibar, mode sums and Sbar of ``a`` after the alignment Q, over their angle bounds."""
    nf, m = b.nf, b.mass
    D = a.fe.Phi.reshape(-1, nf) @ Q - b.fe.Phi.reshape(-1, nf)
    dphi = np.sqrt(np.abs(np.einsum("ip,ip->p", D, full_mass(b.fe.Ms) @ D)))
    ia, ib = a.integrals, b.integrals
    sqrt_I = np.sqrt(np.clip(np.diag(ib.I), 0, None))
    findings = [
        Finding("modes |dPhi|_M / bound", (dphi / theta).max(), 1.0),
        Finding("Ibar / bound", (np.abs(ia.Ibar @ Q - ib.Ibar) / (sqrt_I[:, None, None] * theta)).max(), 1.0),
        Finding("mode sums / bound", (np.abs(ia.mode_sum @ Q - ib.mode_sum) / (np.sqrt(m) * theta)).max(), 1.0),
    ]
    if ib.Sbar is not None and ia.Sbar is not None:
        dS = np.abs(np.einsum("pr,klpq,qs->klrs", Q, ia.Sbar, Q) - ib.Sbar)
        findings.append(Finding("Sbar / bound", (dS / (theta[:, None] + theta[None, :])).max(), 1.0))
    return findings


def _stress_findings(a: FlexibleBody, b: FlexibleBody, acc: np.ndarray, groups) -> list[Finding]:
    """Largest von Mises of single modes (inside a cluster it depends on the rotation: not compared)."""
    if a.sigma_max is None or b.sigma_max is None:
        return []
    lam, sa, sb = b.eigenvalues, a.sigma_max, b.sigma_max
    ratio = 0.0
    for p in (g[0] for g in groups if len(g) == 1):
        others = np.arange(len(lam)) != p
        bound = acc[p] * np.sum(sb[others] / np.abs(lam[others] - lam[p])) + len(lam) * EPS * sb[p]
        ratio = max(ratio, abs(sa[p] - sb[p]) / bound)
    return [Finding("single-mode stress / bound", ratio, 1.0)]
