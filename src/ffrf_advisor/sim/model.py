"""The arrays a simulation needs, taken from a FlexibleBody for one term set (theory sections 3, 5).

Notation of theory section 3 with ``Ibar[k, l] = x_k^T Ms Phi_l`` and
``Sbar[k, l] = Phi_k^T Ms Phi_l``. The W1, W2 and W3 terms are evaluated
from these blocks (never as dense 3nf x 3nf products):

- ``W1 Qf = 2 tr(C1) I - C1 - C1^T`` with ``C1[k, l] = Ibar[k, l] . q``;
- ``Qf^T W2 Qf = tr(G) I - G`` with ``G[a, b] = q^T Sbar[a, b] q``;
- ``Qf^T W3 = C(q)`` with rows ``C[k] = W3k[k]^T q``,
  ``W3k[k] = sum_ab eps_kab Sbar[a, b]`` (the skew blocks of W3);
- cf1 ``= |w|^2 tr(Ibar) - sum_kl w_k w_l Ibar[k, l]``;
- cf2 ``= |w|^2 sum_m Sbar[m, m] q - sum_kl w_k w_l Sbar[l, k] q``.

The compiled kernels (sim.kernels) read Sbar compactly, about 4.5 nf^2
numbers instead of 12 nf^2 (Sbar and W3k): the upper halves of the
symmetric diagonal blocks ``Sbar[k, k]`` (``diag``) and one block of each
off-diagonal pair, ``off[k] = Sbar[a, b]`` for the cyclic ``(k, a, b)``
(``Sbar[b, a] = Sbar[a, b]^T``), whose skew part is ``W3k[k]``; each
stored in strips of STRIP rows (``strips``), so that one pass over a
strip gives both a block's product and its transpose's. Up to ``tall_max()``
modes, where the strips' rows are too short to vectorise and all blocks
fit in the L2 cache anyway, the kernels take the nine products at once
from ``tall`` instead: ``tall[t]`` holds column t of every block, so
``P.ravel() = sum_t tall[t] x[t]`` is nf contiguous multiply-adds of length
9 nf (9 nf^2 numbers, read once for q and q' together).
"""
from __future__ import annotations

import functools
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from ..body import FlexibleBody
from ..errors import FFRFError
from ..terms import GROUPS, IDS, is_lagrangian, needed_invariants, ordered

N_ROT = 7  # quaternion (4) and angular velocity (3) lead the state vector
STRIP = 4  # rows per strip of the kernels' block storage (kernels._dot4_axpy reads four rows at once)
WIDTH_STEP = 16  # strip widths in multiples of this where free: a vector loop body (4 x 4 doubles on AVX2)
TALL_MAX = 48  # modes up to which the kernels use ``tall`` at least: its 72 nf^2 bytes fit a 256 KiB L2 cache
TALL_L2_SHARE = 0.3  # ... and beyond, while they take at most this share of the processor's L2 cache (``tall_max``)
L2_SYSFS = Path("/sys/devices/system/cpu/cpu0/cache")  # Linux: index*/level, type, size of processor 0's caches
MAX_DAMPING = 10.0  # modal damping ratios above make the modes stiff beyond any integrator's budget


@dataclass(frozen=True)
class Model:
    """One body and one term set, ready to simulate. State ``y = [p (4), w (3), q (nf), q' (nf)]``.

    ``damping`` holds ``2 zeta_p Omega_p`` per mode; ``G`` the six modal
    geometric stiffness matrices (theory section 9, order 11 22 33 12 13 23),
    needed only with ``geo_stiff``.
    """

    terms: tuple[str, ...]
    I0: np.ndarray
    Ibar: np.ndarray      # (3, 3, nf)
    Sbar: np.ndarray      # (3, 3, nf, nf), zeros when no W2 term is on
    W3k: np.ndarray       # (3, nf, nf), zeros when no W3 term is on
    eigenvalues: np.ndarray
    damping: np.ndarray
    G: np.ndarray         # (6, nf, nf), zeros without geo_stiff

    @property
    def nf(self) -> int:
        return len(self.eigenvalues)

    @cached_property
    def kernel_blocks(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(diag, off, tall): Sbar as the compiled kernels read it (module docstring), built at first use (the
        plain-numpy equations, which the advice's linearisations evaluate, never read it). ``diag`` (3, ~nf^2 /
        2): strips of the upper halves of Sbar[k, k]; ``off`` (3, ~nf^2): strips of Sbar[a, b] for the cyclic
        (k, a, b), of W3k / 2 with W3 alone; both (3, 0) up to ``tall_max()`` modes, where ``tall`` (nf, 9 nf) holds
        the same blocks column by column (else (0, 0))."""
        blocks = product_blocks(self.Sbar, None if _carries(self.terms, "W2") else 0.5 * self.W3k)  # zeros without W3
        if self.nf <= tall_max():
            return np.zeros((3, 0)), np.zeros((3, 0)), tall_blocks(*blocks)
        return *compact_blocks(*blocks), np.zeros((0, 0))

    @property
    def flags(self) -> np.ndarray:
        """One 0/1 flag per catalogue term (terms.IDS order), for the compiled kernels."""
        return np.array([t in self.terms for t in IDS], dtype=np.int64)

    @property
    def lagrangian(self) -> bool:
        return is_lagrangian(self.terms)

    def on(self, term: str) -> bool:
        return term in self.terms


def build_model(body: FlexibleBody, terms, damping=0.0, G: np.ndarray | None = None) -> Model:
    """The Model of ``body`` with term set ``terms`` and modal damping ratio(s) ``damping`` (one or per mode);
    ``G`` defaults to the body's geometric stiffness (theory 9)."""
    terms = ordered({"gyro0", *terms})
    ints, nf = body.integrals, body.nf
    G = body.geometric if G is None else G
    missing = [n for n in needed_invariants(terms) if n in ints.missing or (n == "G" and G is None)]
    if missing:
        raise FFRFError(f"{body.name}: term set needs {', '.join(missing)}, which the body does not carry"
                        + (" (geometric stiffness: computed from FE data, theory section 9)" if "G" in missing else ""))
    zeta = np.broadcast_to(np.asarray(damping, float), (nf,)) if np.ndim(damping) == 0 else np.asarray(damping, float)
    if zeta.shape != (nf,) or not np.all(np.isfinite(zeta)) or np.any(zeta < 0) or np.any(zeta > MAX_DAMPING):
        raise FFRFError(f"--damping: expected one or {nf} ratios between 0 and {MAX_DAMPING:g}, got "
                        f"{np.ravel(damping).tolist()[:6]}")
    Sbar = np.array(ints.Sbar) if _carries(terms, "W2") else np.zeros((3, 3, nf, nf))
    W3k = _owned(ints.W3().reshape(3, nf, nf)) if _carries(terms, "W3") else np.zeros((3, nf, nf))
    return Model(terms=terms, I0=_owned(body.I0), Ibar=_owned(ints.Ibar), Sbar=np.ascontiguousarray(Sbar),
                 W3k=W3k, eigenvalues=_owned(body.eigenvalues),
                 damping=2 * zeta * np.sqrt(np.abs(body.eigenvalues)),
                 G=np.zeros((6, nf, nf)) if G is None else _owned(G))


def _carries(terms, group: str) -> bool:
    """Whether ``terms`` hold a term of the invariants group ``group`` (terms.GROUPS)."""
    return any(t in terms for t in GROUPS[group])


def _owned(x) -> np.ndarray:
    """A writeable C-ordered float copy: the compiled kernels see one signature whatever the body's arrays are
    (read-only as read from a file, views of a mode subset)."""
    return np.array(x, dtype=float, order="C")


def product_blocks(Sbar: np.ndarray, skew: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(D, B), each (3, nf, nf): the symmetric diagonal blocks ``D[k] = Sbar[k, k]`` and ``B[k] = Sbar[a, b]``
    for the cyclic (k, a, b), each the mean of its pair (Sbar[b, a]^T and Sbar[a, b]); ``skew`` (3, nf, nf)
    replaces B when only its skew parts W3k count (a body may carry W3 without Sbar)."""
    D = np.stack([0.5 * (Sbar[k, k] + Sbar[k, k].T) for k in range(3)])
    B = np.stack([0.5 * (Sbar[(k + 1) % 3, (k + 2) % 3] + Sbar[(k + 2) % 3, (k + 1) % 3].T) for k in range(3)])
    return D, B if skew is None else skew


def compact_blocks(D: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(diag, off) of Model: the upper halves of D and the blocks B (``product_blocks``) in strips."""
    return np.stack([strips(d, upper=True) for d in D]), np.stack([strips(b, upper=False) for b in B])


def tall_max() -> int:
    """Modes up to which the kernels read ``tall``: TALL_MAX, or more where its 72 nf^2 bytes stay within
    TALL_L2_SHARE of the L2 cache (66 modes on 1 MiB, 93 on 2 MiB). Full right-hand side, tall against strips,
    both on 1 MiB L2: 0.60-0.82x from 32 to 64 modes, 0.75x at 72, 0.88x at 80, 0.83x at 100 on an Intel Xeon
    (2026-11-27); 0.63-0.78x from 16 to 64, 1.0x at 80, 1.13x at 100 on the AMD EPYC of the sessions before."""
    size = l2_bytes()
    return TALL_MAX if size is None else max(TALL_MAX, int(np.sqrt(TALL_L2_SHARE * size / 72)))


@functools.cache
def l2_bytes(root: Path = L2_SYSFS) -> int | None:
    """The L2 (data or unified) cache of processor 0 in bytes as Linux's sysfs gives it ("1024K"); None where
    it says nothing readable (another system)."""
    try:
        for index in sorted(root.glob("index*")):
            if (index / "level").read_text().strip() == "2" and (index / "type").read_text().strip() != "Instruction":
                text = (index / "size").read_text().strip().upper()
                return int(text.rstrip("KMG")) * {"K": 2**10, "M": 2**20, "G": 2**30}.get(text[-1:], 1)
    except (OSError, ValueError):
        pass
    return None


def tall_blocks(D: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``tall`` of Model, (nf, 9 nf): ``tall[t, (3 a + b) nf + r]`` = entry (r, t) of the block whose product
    with x is ``P[a, b] = Sbar[a, b] x``: D[k] at (k, k), B[k] at (a, b) and B[k]^T at (b, a) for the cyclic
    (k, a, b)."""
    nf = D.shape[1]
    full = np.zeros((3, 3, nf, nf))
    for k in range(3):
        a, b = (k + 1) % 3, (k + 2) % 3
        full[k, k], full[a, b], full[b, a] = D[k], B[k], B[k].T
    return np.ascontiguousarray(full.reshape(9 * nf, nf).T)


def strip_start(r: int, nf: int, upper: bool) -> int:
    """First stored column of the strip from row r: 0, or for an upper strip its diagonal r moved left until the
    width is a multiple of WIDTH_STEP (or 0); the entries left of the diagonal are stored as zeros."""
    return max(0, nf - WIDTH_STEP * -(-(nf - r) // WIDTH_STEP)) if upper else 0


def strips(B: np.ndarray, upper: bool) -> np.ndarray:
    """B (nf x nf) as strips of STRIP rows from their ``strip_start`` on, each row-major, rows past nf zero.
    ``upper``: B's upper half with its diagonal halved, U (B symmetric: B x = U x + U^T x)."""
    nf, parts = len(B), []
    for r in range(0, nf, STRIP):
        c = strip_start(r, nf, upper)
        strip = np.zeros((STRIP, nf - c))
        strip[:min(STRIP, nf - r)] = B[r:r + STRIP, c:]
        if upper:
            strip = np.triu(strip, r - c)
            rows = np.arange(min(STRIP, nf - r))
            strip[rows, r - c + rows] *= 0.5
        parts.append(strip.ravel())
    return np.concatenate(parts) if parts else np.zeros(0)



def initial_state(model: Model, omega0=(0.0, 0.0, 0.0), q0=(), qd0=()) -> np.ndarray:
    """``y0 = [1, 0, 0, 0, omega0, q0, qd0]``: body frame = inertial frame at t = 0; missing modes are zero
    (``model``: anything with the number of modes ``nf``, a FlexibleBody too)."""
    nf = model.nf
    y = np.zeros(N_ROT + 2 * nf)
    y[0] = 1.0
    for name, values, start, size in (("--omega0", omega0, 4, 3), ("--q0", q0, N_ROT, nf),
                                      ("--qd0", qd0, N_ROT + nf, nf)):
        values = np.asarray(values, float).ravel()
        if len(values) > size or not np.all(np.isfinite(values)):
            raise FFRFError(f"{name}: expected at most {size} finite numbers, got {len(values)}")
        y[start:start + len(values)] = values
    return y
