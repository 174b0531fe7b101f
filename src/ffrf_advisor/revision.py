"""Are two revisions of a body the same model for the multibody code? (`ffrf-advisor diff`, issue 27)

Unlike ``equivalence`` (two runs of one recipe, held to their eigensolvers'
accuracy), a revision may change anything; the question is whether it
changed what the multibody code sees, to a relative ``tolerance``:

- rigid body: mass, centre of mass (relative to the largest dimension),
  inertia tensor I0 (relative to its norm);
- modes paired by shape where both bodies share their nodes (MAC with the
  old body's mass, pairing of largest total MAC, ``sim.linearise.best_pairs``),
  else by order (said so): the frequency of each pair, and ``1 - MAC`` (a
  mode shape that changed while its frequency barely moved);
- the invariants over the paired modes, signs aligned: ``Ibar`` (relative to
  ``sqrt(m) L``), ``Sbar`` (relative to 1, the modal mass);
- stale modes: where a body's stiffness is known (stored K, or assembled
  from its material), its modes' Rayleigh quotients ``phi^T K phi / phi^T M
  phi`` against its stored eigenvalues ("stiffness changed but the mode
  shapes were not regenerated");
- the advice (level and term set) at the same analysis options.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .analysis import Options, analyze
from .body import FlexibleBody
from .fe.assembly import full_mass, stiffness_matrix
from .sim.linearise import best_pairs


@dataclass(frozen=True)
class Change:
    """One compared quantity: its largest relative difference (or 1 for a changed advice), whether that
    exceeds the tolerance, and what was compared."""

    quantity: str
    difference: float
    exceeds: bool
    text: str


@dataclass(frozen=True)
class RevisionDiff:
    changes: list[Change]
    pairs: list[tuple[int, int, float]]  # (old mode, new mode, MAC) 0-based; MAC NaN when paired by order
    paired_by: str
    tolerance: float

    @property
    def same(self) -> bool:
        return not any(c.exceeds for c in self.changes)


def _rel(a, b, scale: float) -> float:
    return float(np.max(np.abs(np.asarray(a, float) - np.asarray(b, float))) / scale) if scale > 0 else 0.0


def shared_nodes(old: FlexibleBody, new: FlexibleBody) -> bool:
    """Whether both bodies carry nodal modes on the same nodes (to round-off of the largest dimension)."""
    if old.fe is None or new.fe is None or old.fe.mesh.n_nodes != new.fe.mesh.n_nodes:
        return False
    X, Y = old.fe.mesh.points, new.fe.mesh.points
    return bool(np.abs(X - Y).max() <= 1e-9 * old.largest_dimension())


def mac_matrix(old: FlexibleBody, new: FlexibleBody) -> tuple[np.ndarray, np.ndarray]:
    """(MAC, cross), both (nf_old, nf_new): ``cross = a^T M b`` and ``MAC = cross^2 / (a^T M a)(b^T M b)``
    with the old body's mass (the sign of ``cross`` turns a new mode onto its old pair)."""
    n = old.fe.mesh.n_nodes
    M = full_mass(old.fe.Ms)
    A, B = old.fe.Phi.reshape(3 * n, -1), new.fe.Phi.reshape(3 * n, -1)
    MA = M @ A
    cross = MA.T @ B
    return cross**2 / np.outer(np.einsum("ip,ip->p", A, MA), np.einsum("ip,ip->p", B, M @ B)), cross


def pairing(old: FlexibleBody, new: FlexibleBody) -> tuple[list[tuple[int, int, float]], str, np.ndarray]:
    """(pairs, how, signs): by MAC on shared nodes, else by order; ``signs`` turn the new modes of the pairs
    onto the old ones (+1 where unknown)."""
    k = min(old.nf, new.nf)
    if not shared_nodes(old, new):
        return [(p, p, np.nan) for p in range(k)], "order (no shared nodes: mode shapes not compared)", np.ones(k)
    mac, cross = mac_matrix(old, new)
    rows, cols = best_pairs(mac)
    pairs = [(int(r), int(c), float(mac[r, c])) for r, c in zip(rows, cols)]
    return pairs, "MAC (shared nodes)", np.sign(cross[rows, cols])


def rayleigh_mismatch(body: FlexibleBody) -> float | None:
    """Largest ``|phi^T K phi / phi^T M phi - lambda| / lambda`` over the modes; None without K or material."""
    fe = body.fe
    if fe is None or (fe.K is None and fe.material is None) or fe.rotary is not None:
        return None
    K = fe.K if fe.K is not None else stiffness_matrix(fe.mesh, fe.material)
    n = fe.mesh.n_nodes
    P = fe.Phi.reshape(3 * n, -1)
    quotient = np.einsum("ip,ip->p", P, K @ P) / np.einsum("ip,ip->p", P, full_mass(fe.Ms) @ P)
    return float(np.max(np.abs(quotient - body.eigenvalues) / body.eigenvalues))


def diff(old: FlexibleBody, new: FlexibleBody, tolerance: float, options: Options | None = None) -> RevisionDiff:
    """The changes from ``old`` to ``new`` (module docstring); both in the same units (the new converted)."""
    new = new.converted(old.units)
    pairs, how, signs = pairing(old, new)
    rows, cols = [p[0] for p in pairs], [p[1] for p in pairs]
    L, m = old.largest_dimension(), old.mass
    change = lambda q, d, text: Change(q, d, d > tolerance, text)  # noqa: E731
    out = [change("mass", _rel(old.mass, new.mass, m), f"{old.mass:.6g} -> {new.mass:.6g} {old.units.mass}"),
           change("centre of mass", _rel(old.com, new.com, L), f"moved by {np.linalg.norm(new.com - old.com):.3g} "
                  f"{old.units.length}"),
           change("I0", _rel(old.I0, new.I0, np.linalg.norm(old.I0)), "inertia tensor at the CoM")]
    if old.nf != new.nf:
        out.append(Change("mode count", 1.0, True, f"{old.nf} -> {new.nf} modes"))
    fo, fn = old.frequencies_hz[rows], new.frequencies_hz[cols]
    worst = int(np.argmax(np.abs(fn - fo) / fo))
    out.append(change("frequencies", float(np.max(np.abs(fn - fo) / fo)),
                      f"paired by {how}; largest at old mode {rows[worst] + 1}: {fo[worst]:.6g} -> "
                      f"{fn[worst]:.6g} Hz" + ("" if rows == cols else "; order changed")))
    macs = np.array([p[2] for p in pairs])
    if np.all(np.isfinite(macs)):
        w = int(np.argmin(macs))
        out.append(change("mode shapes (1 - MAC)", float(1 - macs[w]),
                          f"least similar pair: old mode {rows[w] + 1} / new mode {cols[w] + 1}, MAC {macs[w]:.6f}"))
    out += _invariant_changes(old, new, rows, cols, signs, tolerance)
    for name, body in (("old", old), ("new", new)):
        stale = rayleigh_mismatch(body)
        if stale is not None:
            out.append(change(f"stale modes ({name})", stale, "Rayleigh quotients of the stored modes with the "
                              "body's stiffness against its eigenvalues" + (": the stiffness changed but the mode "
                                                                             "shapes were not regenerated"
                                                                             if stale > tolerance else "")))
    out.append(_advice_change(old, new, options or Options()))
    return RevisionDiff(out, pairs, how, tolerance)


def _invariant_changes(old, new, rows, cols, signs, tolerance: float) -> list[Change]:
    """Ibar and Sbar over the paired modes, the new ones turned by ``signs``."""
    a, b = old.integrals, new.integrals
    Ib = b.Ibar[..., cols] * signs
    Sb = b.Sbar[..., cols, :][..., cols] * np.outer(signs, signs)
    scale = np.sqrt(old.mass) * old.largest_dimension()
    d_I = _rel(a.Ibar[..., rows], Ib, scale)
    d_S = _rel(a.Sbar[..., rows, :][..., rows], Sb, 1.0)
    return [Change("invariants Ibar", d_I, d_I > tolerance, "over the paired modes, relative to sqrt(m) L"),
            Change("invariants Sbar", d_S, d_S > tolerance, "over the paired modes, relative to the modal mass")]


def _advice_change(old, new, options: Options) -> Change:
    a, b = analyze(old, options).advice, analyze(new, options).advice
    same = a.level == b.level and set(a.terms) == set(b.terms)
    return Change("advice", 0.0 if same else 1.0, not same,
                  f"level {a.level} -> {b.level}" + ("" if set(a.terms) == set(b.terms)
                                                     else f"; terms {', '.join(a.terms)} -> {', '.join(b.terms)}"))
