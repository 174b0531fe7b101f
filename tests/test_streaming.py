"""Streamed invariants (issue 24, item 4): one pass over blocks of nodes equals the in-memory nodal sums, from
memory and from a file's chunks, and a body above the memory limit is analysed, not refused."""
from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest
import scipy.sparse as sp

from ffrf_advisor.errors import BodyFileError
from ffrf_advisor.invariants import SPAN, nodal_pass, shape_integrals
from ffrf_advisor.io import ffrf_h5, limits, read_body, write_body

SAMPLES = sorted((Path(__file__).resolve().parent.parent / "sample_bodies").glob("*.ffrf.h5"))

ROUND_OFF = 1e-12  # sums of at most a few thousand products in another order (theory 3: the same nodal sums)
FIELDS = ("first_moment", "I", "Ibar", "Sbar", "mode_sum")


def _scales(J, length: float) -> dict:
    """The natural size of each integral (modes mass-normalised: |S| ~ 1 / sqrt(m)), so that a quantity that is
    zero by the frame's choice (first moment at the CoM, mode sums of free modes) is compared at its scale."""
    m = J.mass
    return {"first_moment": m * length, "I": m * length ** 2, "Ibar": np.sqrt(m) * length, "Sbar": 1.0,
            "mode_sum": np.sqrt(m)}


def assert_same_integrals(A, B, length: float) -> None:
    assert abs(A.mass - B.mass) <= ROUND_OFF * A.mass
    for name, scale in _scales(A, length).items():
        a, b = np.asarray(getattr(A, name)), np.asarray(getattr(B, name))
        assert np.abs(a - b).max() <= ROUND_OFF * max(scale, np.abs(a).max()), name


@pytest.fixture(scope="module")
def fe_samples():
    """The three smallest shipped bodies with nodal data (beam, plate, conrod: lumped and consistent masses)."""
    bodies = [read_body(p, load_fe=True) for p in SAMPLES if p.stat().st_size < 3 * 2**20]
    return [b for b in bodies if b.fe is not None]


@pytest.mark.parametrize("rows", [64, 1000])
def test_blocks_of_any_size_give_the_in_memory_integrals(fe_samples, rows):
    for body in fe_samples:
        fe = body.fe
        Ms = sp.csr_array(fe.Ms)
        streamed = nodal_pass(fe.mesh.points, lambda a, b: Ms[a:b], lambda a, b: fe.Phi[a:b], body.nf, rows=rows)
        assert_same_integrals(streamed.integrals, fe.integrals(), fe.mesh.largest_dimension())
        assert np.allclose(streamed.max_deflection, fe.max_deflection(), rtol=ROUND_OFF, atol=0)


def test_a_mass_matrix_that_reaches_across_the_body_is_taken_block_by_block(fe_samples):
    """Nodes numbered at random: each block of Ms rows reaches far beyond SPAN blocks, so its columns are
    taken one block at a time; the integrals are those of the body as numbered."""
    body = min((b for b in fe_samples if sp.csr_array(b.fe.Ms).nnz > b.fe.mesh.n_nodes),  # a consistent mass
               key=lambda b: b.fe.mesh.n_nodes)
    fe, rows = body.fe, 16
    perm = np.random.default_rng(1).permutation(fe.mesh.n_nodes)
    Ms = sp.csr_array(fe.Ms)[perm][:, perm]
    reach = [np.ptp(Ms[a:a + rows].indices) for a in range(0, fe.mesh.n_nodes, rows)]
    assert max(reach) > SPAN * rows  # the wide path is taken
    streamed = nodal_pass(fe.mesh.points[perm], lambda a, b: Ms[a:b], lambda a, b: fe.Phi[perm[a:b]], body.nf,
                          rows=rows)
    assert_same_integrals(streamed.integrals, fe.integrals(), fe.mesh.largest_dimension())


def _uncached(body, path, chunk_rows: int, monkeypatch) -> None:
    """``body`` written with small chunks and without its invariants and nodal summary (an old file)."""
    monkeypatch.setattr(ffrf_h5, "NODE_CHUNK", chunk_rows)
    write_body(body, path, overwrite=True)
    with h5py.File(path, "r+") as f:
        del f["invariants"], f["nodal_summary"]
        assert f["modes/Phi"].chunks[0] == chunk_rows


def _limit_for_blocks(path, rows: int) -> int:
    """A memory limit that holds the file's arrays except the modes and nodal stresses as the streamed read
    charges them (kept in the reading child; what it sends back, with a margin), and of the modes only blocks
    of about ``rows`` nodes."""
    with h5py.File(path, "r") as f:
        sizes = []
        f.visititems(lambda name, obj: sizes.append(obj.size * 8.0) if isinstance(obj, h5py.Dataset) and
                     not name.startswith(("modes/Phi", "stress/nodal", "stiffness")) else None)
        nf = f["modes/eigenvalues"].shape[0]
    kept = ffrf_h5.CHILD_COPIES * sum(sizes) + limits.TREE_BYTES_PER_BYTE * (12 * 8 * nf * nf + 2**16)
    return int(kept + 2 * 8 * 3 * nf * rows * ffrf_h5.BLOCKS_HELD)


def test_a_file_without_its_caches_is_streamed_chunk_by_chunk(fe_samples, tmp_path, monkeypatch):
    """The analysis's read (load_fe="summary") of an uncached file whose modes do not fit the memory limit
    streams them over blocks of a few chunks and gives the in-memory invariants and summary; reading the
    modes whole under the same limit is refused."""
    path = tmp_path / "body.ffrf.h5"
    for body in fe_samples:
        _uncached(body, path, 32, monkeypatch)
        whole = read_body(path, load_fe=True)
        limits.set_max_bytes(_limit_for_blocks(path, 64))
        try:
            streamed = read_body(path, load_fe="summary")
            with pytest.raises(BodyFileError, match="expected data that fit the memory limit"):
                read_body(path, load_fe=True)
        finally:
            limits.set_max_bytes(None)
        assert streamed.fe is None and streamed.nodal.n_nodes == whole.fe.mesh.n_nodes
        assert_same_integrals(streamed.integrals, whole.integrals, whole.fe.mesh.largest_dimension())
        assert np.allclose(streamed.nodal.max_deflection, whole.fe.max_deflection(), rtol=ROUND_OFF, atol=0)
        assert streamed.nodal.stiffness == (whole.fe.K is not None)


def test_a_damaged_block_far_into_the_modes_is_one_line_naming_them(fe_samples, tmp_path, monkeypatch, request):
    path = tmp_path / "body.ffrf.h5"
    body = max(fe_samples, key=lambda b: b.fe.mesh.n_nodes)
    _uncached(body, path, 16, monkeypatch)
    limits.set_max_bytes(_limit_for_blocks(path, 64))
    request.addfinalizer(lambda: limits.set_max_bytes(None))
    with h5py.File(path, "r+") as f:
        f["modes/Phi"][-1, 2, -1] = np.nan
        f["stress/nodal"][-1, 0] = np.inf if "stress/nodal" in f else 0.0
    with pytest.raises(BodyFileError, match="modes/Phi: expected finite numbers, got NaN or inf"):
        read_body(path, load_fe="summary")
    with h5py.File(path, "r+") as f:
        f["modes/Phi"][-1, 2, -1] = 0.0
    if "stress/nodal" in h5py.File(path, "r"):
        with pytest.raises(BodyFileError, match="stress/nodal: expected finite numbers"):
            read_body(path, load_fe="summary")


@pytest.mark.slow
def test_a_body_above_the_memory_limit_is_analysed_within_it(tmp_path):
    """Issue 24, item 4: modes that declare more than the limit are streamed, not refused; the process tree's
    peak above a tiny body's run stays within --max-memory."""
    from .tree_memory import synthetic_body, tree_rss

    tiny, body = tmp_path / "tiny.ffrf.h5", tmp_path / "bar.ffrf.h5"
    synthetic_body(tiny, 10, 10)
    declared = synthetic_body(body, 1400, 20)  # 93 MiB of arrays, 78 MiB of them modes
    for path in (tiny, body):
        with h5py.File(path, "r+") as f:
            del f["invariants"], f["nodal_summary"]
    limit = int(0.6 * declared)  # below the modes' 78 MiB; the mesh and the mass are read whole (3 x 15 MiB)
    code_tiny, _, base = tree_rss(["analyze", str(tiny), "--speed", "10rad/s"])
    code, out, rss = tree_rss(["--max-memory", str(limit), "analyze", str(body), "--speed", "10rad/s"])
    assert code_tiny == code == 0, out
    extra = (rss["parent"] - base["parent"] + rss["child"] - base["child"]) * 2**20
    assert extra <= limit, (rss, base, limit)
