"""The linearisation's eigenproblem solved block by block where the Jacobian decouples (sim.linearise.eigen):
the same eigenvalues as one dense solve, eigenvectors that solve J v = mu v, and one dense solve wherever the
blocks are coupled by more than round-off."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ffrf_advisor.io import read_body
from ffrf_advisor.sim import linearise as lin
from ffrf_advisor.sim.model import build_model

DIR = Path(__file__).resolve().parent.parent / "sample_bodies"
SIZES = (5, 4, 4, 1, 7)  # two blocks of one size: one stacked solve


def _matched(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """|a_i - nearest b| / |a_i| per eigenvalue (the orders differ)."""
    return np.abs(a[:, None] - b[None, :]).min(axis=1) / np.abs(a)


def block_matrix(between: float, seed: int = 0) -> tuple[np.ndarray, list[np.ndarray]]:
    """A random matrix of SIZES blocks, rows and columns shuffled, ``between`` x its largest entry (times a
    random sign and size up to 1) in every place between blocks; the blocks' index sets."""
    rng = np.random.default_rng(seed)
    n = sum(SIZES)
    J = between * rng.uniform(-1, 1, (n, n))
    order, blocks, start = rng.permutation(n), [], 0
    for k in SIZES:
        idx = order[start:start + k]
        J[np.ix_(idx, idx)] = rng.standard_normal((k, k)) + 3 * np.eye(k)
        blocks.append(np.sort(idx))
        start += k
    return J, blocks


def test_components_of_a_directed_pattern_are_those_of_the_undirected_graph():
    linked = np.zeros((6, 6), dtype=bool)
    linked[0, 3] = linked[4, 1] = linked[1, 5] = True  # {0, 3}, {1, 4, 5}, {2}, one direction each
    assert lin._components(linked).tolist() == [0, 1, 2, 0, 1, 1]


def test_a_block_matrix_with_round_off_between_blocks_is_solved_block_by_block():
    """Eigenvalues as one dense solve's (to round-off of the largest: 1e-13 covers eig's backward error of
    about n eps on these unit-size blocks), eigenvectors of unit length, zero outside their block and solving
    J v = mu v, eigenvalues alone the same."""
    J, blocks = block_matrix(1e-17)
    found = lin._blocks(J, np.ones(len(J)))
    assert found is not None and sorted(tuple(idx) for idx, _ in found) == sorted(map(tuple, blocks))
    assert not any(half for _, half in found)  # not the Jacobian of (w, q, q'): no q row is q' exactly
    mu, V = lin.eigen(J, np.ones(len(J)))
    assert np.max(_matched(np.linalg.eigvals(J), mu)) < 1e-13
    assert np.allclose(np.linalg.norm(V, axis=0), 1.0, rtol=0, atol=1e-14)
    assert np.max(np.linalg.norm(J @ V - V * mu, axis=0)) < 1e-13 * np.abs(J).max()
    owner = np.zeros(len(J), dtype=int)
    for k, idx in enumerate(blocks):
        owner[idx] = k
    for v in V.T:
        assert len(set(owner[np.abs(v) > 0])) == 1
    assert np.array_equal(lin.eigen(J, np.ones(len(J)), vectors=False), mu)


@pytest.mark.parametrize("between", [1e-6, 0.9 * lin.SPLIT])
def test_blocks_coupled_beyond_round_off_are_solved_whole(between):
    """Couplings above SPLIT join the blocks; entries each below SPLIT but together above DROPPED (n^2 / 2 of
    0.9 SPLIT of the largest entry: a norm of 0.9e-12 x 148 = 1.3e-10 of it) are not dropped either: one dense
    solve, np.linalg.eig's own result."""
    n = 210
    J = np.diag(np.arange(1.0, n + 1))
    J[:n // 2, n // 2:] = J[n // 2:, :n // 2] = between * n
    assert lin._blocks(J, np.ones(n)) is None
    mu, V = lin.eigen(J, np.ones(n))
    mu0, V0 = np.linalg.eig(J)
    assert np.array_equal(mu, mu0) and np.array_equal(V, V0)


def test_the_balancing_finds_blocks_the_raw_entries_hide():
    """Entries small only in the balanced D^-1 J D (D: the difference steps) count as round-off: a 2 x 2
    block joined to another by an entry of 1e-6 whose columns' step is 1e-9 of the rows'."""
    J = np.array([[0.0, 1.0, 1e-6, 0.0], [-1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], [0.0, 0.0, -4.0, 0.0]])
    assert lin._blocks(J, np.ones(4)) is None
    assert len(lin._blocks(J, np.array([1.0, 1.0, 1e-9, 1e-9]))) == 2


@pytest.mark.parametrize("terms", [("gyro0",), ("gyro0", "cor_quad", "inertia_quad", "cf2")], ids=["I", "W2"])
def test_a_real_bodys_decoupled_linearisation_has_the_dense_solves_frequencies(terms, monkeypatch):
    """The shipped beam's level-I and W2 sets at 300 rad/s about each principal axis: their difference
    Jacobians split (the modes decouple), and the frequencies, growth and mode count of linearise are those of
    one dense solve to 1e-12 (eig's round-off on eigenvalues spread over 4 decades: about n eps x 10^4)."""
    model = build_model(read_body(DIR / "beam.ffrf.h5"), terms)
    split = {}
    for axis in np.eye(3):
        _, _, J, steps = lin.equilibrium(model, axis, 300.0)
        assert lin._blocks(J, steps) is not None
        split[tuple(axis)] = lin.linearise(model, axis, 300.0)
    monkeypatch.setattr(lin, "eigen", lambda J, steps, vectors=True: (np.linalg.eig if vectors else
                                                                      np.linalg.eigvals)(J))
    for axis in np.eye(3):
        dense, found = lin.linearise(model, axis, 300.0), split[tuple(axis)]
        assert len(found.frequencies) == len(dense.frequencies) and found.unstable == dense.unstable
        assert np.allclose(found.frequencies, dense.frequencies, rtol=1e-12, atol=0)
        assert np.allclose(found.rigid_frequencies, dense.rigid_frequencies, rtol=1e-12, atol=0)


def second_order_jacobian(velocity: float, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """A Jacobian of (w, q, q') with nf = 7 modes in shuffled order (``perm[j]``: the position of mode j): w with
    modes 0-1, modes 2-4 without velocity coupling (``velocity`` x its largest entry in J[q'', q'] there), modes
    5-6 gyroscopically coupled (J[q'', q'] of size 1); the positions of the modes of the middle block."""
    rng, nf = np.random.default_rng(seed), 7
    perm = rng.permutation(nf)
    n = 3 + 2 * nf
    J = np.zeros((n, n))
    q, qd = 3 + perm, 3 + nf + perm
    J[q, qd] = 1.0
    A = -np.diag(rng.uniform(1, 50, nf)) + 0.3 * rng.standard_normal((nf, nf))
    for modes in ([0, 1], [2, 3, 4], [5, 6]):
        J[np.ix_(qd[modes], q[modes])] = A[np.ix_(modes, modes)]
    J[np.ix_(np.r_[:3, qd[:2]], np.r_[:3])] += rng.standard_normal((5, 3))  # q rows stay q' exactly
    J[:3, np.r_[q[:2], qd[:2]]] += rng.standard_normal((3, 4))
    J[qd[5], qd[6]], J[qd[6], qd[5]] = 2.0, -2.0
    J[np.ix_(qd[2:5], qd[2:5])] = velocity * np.abs(J).max() * rng.uniform(-1, 1, (3, 3))
    return J, np.sort(perm[2:5])


def test_modes_without_velocity_coupling_are_solved_as_second_order():
    """The block of modes 2-4 (no velocity coupling) from the eigenproblem of A, half its size (mu = +-sqrt of
    its eigenvalues); the block with w and the gyroscopic one whole. Eigenvalues as one dense solve's (to 1e-13
    of the largest: eig's backward error on these matrices of entries up to 50), eigenvectors of unit length
    solving J v = mu v, eigenvalues alone the same."""
    J, middle = second_order_jacobian(0.0)
    steps = np.ones(len(J))
    found = lin._blocks(J, steps)
    halves = [idx for idx, half in found if half]
    assert len(halves) == 1 and np.array_equal(halves[0], 3 + middle)
    assert sorted(len(idx) for idx, half in found if not half) == [4, 7]  # w with modes 0-1; modes 5-6
    mu, V = lin.eigen(J, steps)
    top = np.abs(J).max()
    assert len(mu) == len(J) and np.max(_matched(np.linalg.eigvals(J), mu) * np.abs(np.linalg.eigvals(J))) < 1e-13 * top
    assert np.allclose(np.linalg.norm(V, axis=0), 1.0, rtol=0, atol=1e-14)
    assert np.max(np.linalg.norm(J @ V - V * mu, axis=0)) < 1e-13 * top
    assert np.array_equal(lin.eigen(J, steps, vectors=False), mu)


def test_velocity_coupling_beyond_round_off_keeps_the_block_whole():
    """J[q'', q'] of the middle block at 1e-9 of the largest entry (above DROPPED): solved as first order, its
    eigenvalues those of one dense solve; at 1e-12 (below) as second order, the eigenvalues within 1e-10 of
    the largest (Bauer-Fike: the dropped norm times the modal condition, about 1 here)."""
    J, _ = second_order_jacobian(1e-9)
    assert not any(half for _, half in lin._blocks(J, np.ones(len(J))))
    J, _ = second_order_jacobian(1e-12)
    assert any(half for _, half in lin._blocks(J, np.ones(len(J))))
    mu0 = np.linalg.eigvals(J)
    assert np.max(_matched(mu0, lin.eigen(J, np.ones(len(J)), vectors=False)) * np.abs(mu0)) < 1e-10 * np.abs(mu0).max()


@pytest.mark.parametrize("top", [30.0, 3000.0])
def test_a_wide_spread_of_frequencies_is_solved_whole_where_the_half_problem_would_lose_accuracy(top):
    """40 coupled modes without velocity coupling, frequencies from 1 to ``top`` like a beam's (p^2). The half
    problem moves the lowest by eps (top / 1)^2 relative (the eigensolver's backward error on A, whose
    eigenvalues span top^2): kept up to a spread of DROPPED / eps (top 30), solved whole beyond it (top 3000,
    where it would be 1e-10 off): the lowest frequency within 1e-12 of one dense solve's either way."""
    rng, nf = np.random.default_rng(3), 40
    om = np.linspace(1.0, np.sqrt(top), nf) ** 2
    A = -np.diag(om ** 2) + 1e-2 * om[:, None] * om[None, :] * rng.standard_normal((nf, nf))
    J = np.zeros((3 + 2 * nf, 3 + 2 * nf))
    J[3:3 + nf, 3 + nf:] = np.eye(nf)  # w: three blocks of one zero
    J[3 + nf:, 3:3 + nf] = A
    steps = np.ones(len(J))
    q = np.arange(3, 3 + nf)[None, :]
    kept = lin._second_order(A[None], q, nf, False)[3]
    assert kept.tolist() == [top < 100]
    low = lambda mu: np.min(mu.imag[mu.imag > 0])  # noqa: E731
    assert abs(low(lin.eigen(J, steps, vectors=False)) / low(np.linalg.eigvals(J)) - 1) < 1e-12


def test_a_q_row_that_is_not_q_dot_keeps_the_blocks_whole():
    """A q rate with a term of its own (J[q, q] = 0.5 for a mode of the middle block): no block is second
    order, and the eigenvalues are one dense solve's."""
    J, middle = second_order_jacobian(0.0)
    J[3 + middle[0], 3 + middle[0]] = 0.5
    assert not any(half for _, half in lin._blocks(J, np.ones(len(J))))
    mu0 = np.linalg.eigvals(J)
    assert np.max(_matched(mu0, lin.eigen(J, np.ones(len(J)), vectors=False)) * np.abs(mu0)) < 1e-13 * np.abs(J).max()


def test_a_jacobian_with_nan_between_blocks_is_not_split_but_refused_as_before():
    J, _ = block_matrix(0.0)
    J[0, -1] = J[-1, 0] = np.nan
    assert lin._blocks(J, np.ones(len(J))) is None
    with pytest.raises(np.linalg.LinAlgError):
        lin.eigen(J, np.ones(len(J)))
