"""The thread and process maps of pool.py: results in order, and Ctrl-C seen at once while they wait; one BLAS
thread where asked."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from ffrf_advisor.pool import mapper, one_blas_thread, threads


def _square(x: int) -> int:
    return x * x


def _fails(x: int) -> int:
    if x == 3:
        raise ValueError("three")
    return x


@pytest.mark.parametrize("make", [lambda: threads(2), lambda: mapper(2, chunksize=2)], ids=["threads", "processes"])
def test_the_maps_give_every_result_in_order_and_raise_a_task_s_error(make):
    with make() as map_:
        assert list(map_(_square, range(7))) == [x * x for x in range(7)]
    with make() as map_, pytest.raises(ValueError, match="three"):
        list(map_(_fails, range(7)))


def test_a_sigint_to_another_thread_ends_a_process_map_at_once():
    """The kernel may hand a SIGINT to any thread of the tool (the pool's manager thread, an OpenBLAS thread);
    the main thread, waiting for a worker's 60 s chunk, sees it within a slice (it slept on before)."""
    script = """
import os, signal, threading, time
signal.signal(signal.SIGINT, signal.default_int_handler)  # as on a terminal (CI's background jobs ignore it)
from ffrf_advisor.pool import mapper
def kill_soon():
    time.sleep(1.0)
    signal.pthread_kill(threading.get_ident(), signal.SIGINT)
threading.Thread(target=kill_soon).start()
with mapper(2) as map_:
    list(map_(time.sleep, [10**6, 10**6]))  # tasks that never end: only an interrupted map lets the process end
"""
    try:  # the timeout guards against the hang under test; it measures nothing
        done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    except subprocess.TimeoutExpired:
        pytest.fail("the map slept on through the SIGINT")
    assert done.returncode != 0 and "KeyboardInterrupt" in done.stderr, done.stderr


@pytest.mark.parametrize("bodies, jobs", [(1, 300), (3, 300), (5, 1)])
def test_gate_forks_at_most_one_worker_per_hand_out_and_processor(monkeypatch, tmp_path, bodies, jobs):
    """gate ONE_BODY --jobs 300 forked 300 workers (1.1 GB): now min(jobs, hand-outs of gate.CHUNK, processors),
    and no pool where that is one. Counted by the pools made, as the CLI runs."""
    from typer.testing import CliRunner

    from ffrf_advisor import pool
    from ffrf_advisor.cli import app
    from ffrf_advisor.gate import CHUNK
    made = []
    original = pool.local_pool
    monkeypatch.setattr(pool, "local_pool", lambda n: made.append(n) or original(n))
    beam = Path(__file__).resolve().parent.parent / "sample_bodies" / "beam.ffrf.h5"
    paths = []
    for i in range(bodies):
        paths.append(tmp_path / f"b{i}.ffrf.h5")
        paths[-1].write_bytes(beam.read_bytes())
    result = CliRunner().invoke(app, ["gate", *map(str, paths), "--speed", "30", "--max-level", "IV",
                                      "--jobs", str(jobs)])
    assert result.exit_code == 0, result.output
    expected = min(jobs, -(-bodies // CHUNK), pool.cpus())
    assert made == ([] if expected == 1 else [expected])
    assert pool.workers(300, 1) == 1 and pool.workers(300, 100, 2) == pool.cpus() and pool.workers(3) <= 3


def test_one_blas_thread_within_and_the_previous_count_after():
    """numpy's BLAS (the linearisations' eigensolver) runs one thread within ``one_blas_thread``, every time (the
    controller is made once), and as many as before after it."""
    import numpy  # noqa: F401 - its BLAS loaded
    from threadpoolctl import threadpool_info

    def counts():
        return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
    before = counts()
    for _ in range(2):
        with one_blas_thread():
            assert counts() and set(counts()) == {1}
        assert counts() == before

