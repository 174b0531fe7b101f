"""The thread and process maps of pool.py: results in order, and Ctrl-C seen at once while they wait; one BLAS
thread where asked."""
from __future__ import annotations

import subprocess
import sys
import time

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
    list(map_(time.sleep, [60, 60]))
"""
    start = time.perf_counter()
    try:
        done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=30)
    except subprocess.TimeoutExpired:
        pytest.fail("the map slept on through the SIGINT")
    assert done.returncode != 0 and "KeyboardInterrupt" in done.stderr, done.stderr
    assert time.perf_counter() - start < 15


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

