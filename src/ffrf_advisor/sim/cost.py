"""The simulator's cost model: multiply-adds of one compiled right-hand side (sim.kernels) per term set.

It counts the loops of ``kernels.rhs_into``. In the strips (above
sim.model.TALL_MAX modes) the W2 terms share the products of the symmetric
diagonal blocks ``Sbar_kk q`` (3 nf^2: each stored entry of their upper
halves serves a row and a column); the W2 and W3 terms share the
off-diagonal pair products ``Sbar_ab q`` and ``Sbar_ab^T q`` (6 nf^2), from
which C(q) follows in O(nf); ``cor_coupling`` needs the same pair products
of q' (6 nf^2 more). In the tall storage (up to TALL_MAX modes) any W2 or
W3 term takes all nine block products of q (9 nf^2), ``cor_coupling``
those of q' too (9 nf^2 more). Everything else is O(nf), plus a fixed cost
per call. The count takes the storage every processor uses (tall up to
TALL_MAX modes), so that the advice, which compares sets by it, is the same
on every machine; where the L2 cache holds more, the kernels read tall
further (sim.model.tall_max) and run faster than counted there.
benchmarks/bench_sim.py prints the measured ratios beside it (within a
factor of 3 from nf = 10 to 200; the vectorised products run faster than
their count).
"""
from __future__ import annotations

from .model import TALL_MAX

CALL = 900  # fixed cost of one evaluation in multiply-add equivalents (0.3 us measured at ~3e9 per s)


def rhs_cost(terms, nf: int, tall_up_to: int = TALL_MAX) -> float:
    """Multiply-adds of one right-hand side with ``terms`` and ``nf`` modes, the blocks stored tall up to
    ``tall_up_to`` modes (default: as on every processor; this one's: sim.model.tall_max())."""
    t = set(terms)
    w2 = bool(t & {"inertia_quad", "cf2", "cor_quad"})
    w3 = bool(t & {"coupling", "cor_coupling"})
    cost = 6 * nf + CALL  # stiffness, damping, kinematics, gyroscopic term, 3 x 3 solve, the call itself
    cost += 9 * nf * ("inertia_lin" in t) + (9 * nf + 9) * ("cor1" in t) + 10 * nf * ("cf1" in t)
    cost += 18 * nf * ("inertia_quad" in t) + (18 * nf + 9) * ("cor_quad" in t) + 10 * nf * ("cf2" in t)
    cost += _block_products(w2, w3, "cor_coupling" in t, nf, tall_up_to) + 6 * nf * w3
    cost += 12 * nf * ("cor_coupling" in t) + 12 * nf * ("coupling" in t)
    cost += 6 * nf * nf * ("geo_stiff" in t)
    return float(cost)


def _block_products(w2: bool, w3: bool, of_qd: bool, nf: int, tall_up_to: int) -> int:
    """Multiply-adds of the Sbar block products, tall up to ``tall_up_to`` modes, else in strips (module
    docstring)."""
    if nf <= tall_up_to:
        return 9 * nf * nf * ((w2 or w3) + of_qd)
    return 3 * nf * nf * w2 + 6 * nf * nf * ((w2 or w3) + of_qd)


def cost_ratio(superset, terms, nf: int) -> float:
    """Right-hand-side cost of ``superset`` over that of ``terms``."""
    return rhs_cost(superset, nf) / rhs_cost(terms, nf)
