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
    assert found is not None and sorted(map(tuple, found)) == sorted(map(tuple, blocks))
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


def test_a_jacobian_with_nan_between_blocks_is_not_split_but_refused_as_before():
    J, _ = block_matrix(0.0)
    J[0, -1] = J[-1, 0] = np.nan
    assert lin._blocks(J, np.ones(len(J))) is None
    with pytest.raises(np.linalg.LinAlgError):
        lin.eigen(J, np.ones(len(J)))
