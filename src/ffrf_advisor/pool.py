"""Local worker processes for the commands that run many independent jobs (gate, verify, the sweep)."""
from __future__ import annotations

import functools
import os
from contextlib import contextmanager
from typing import TYPE_CHECKING

from . import collector
from .io.atomic import WAKE_S
from .io.guard import die_with_parent

if TYPE_CHECKING:
    from concurrent.futures import ProcessPoolExecutor


def local_pool(jobs: int) -> ProcessPoolExecutor:
    """``jobs`` forked workers that reuse their process for every task, die with the tool and use one BLAS
    thread each: the workers share the cores, and BLAS threads on top of them made gate --jobs 2 slower than
    --jobs 1 (20 s against 12 s for 60 sample bodies). Forked, so a worker sees what the tool set up before
    (``mapper``'s ``shared``) without pickling it per task. multiprocessing and concurrent.futures are imported
    here, by the runs that use more than one job (about 20 ms of gate's and verify's start-up)."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor
    collector.resume()  # the workers inherit it on, with start-up's objects frozen out of their collections
    return ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("fork"), initializer=_worker,
                               initargs=(os.getpid(),))


def _worker(parent: int) -> None:
    from threadpoolctl import threadpool_limits

    die_with_parent(parent)
    threadpool_limits(1)


def one_blas_thread():
    """Within: the BLAS libraries this process had loaded when first asked use one thread each (threadpoolctl;
    its controller, which reads the process's libraries in about 10 ms, is made once: ``threadpool_limits``
    read them again on every call)."""
    return _blas().limit(limits=1)


@functools.cache
def _blas():
    from threadpoolctl import ThreadpoolController
    return ThreadpoolController()


def cpus() -> int:
    """The processors this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


@contextmanager
def threads(n: int):
    """An ordered ``map(fn, items)`` over ``n`` threads (the builtin ``map`` for one), for work that releases the
    GIL: LAPACK's eigensolvers, the compiled integrators (their kernels are ``nogil``). Daemon threads, as
    ``beside``'s: an interrupted run (Ctrl-C) ends at once instead of waiting at exit for the tasks running (a
    compiled kernel sees no signal), and no task starts after the caller has left the block."""
    if n <= 1:
        yield map
        return
    import threading
    left = threading.Event()
    try:
        yield lambda fn, items: _daemon_map(n, fn, list(items), left)
    finally:
        left.set()


def _daemon_map(n: int, fn, items: list, left):
    """Start ``n`` daemon threads taking ``items`` in turn until none is left or ``left`` is set; return the
    results in order as they arrive (an exception raised again in the caller's thread)."""
    import threading
    results, ready = [None] * len(items), [threading.Event() for _ in items]
    order, lock = iter(range(len(items))), threading.Lock()

    def work() -> None:
        while not left.is_set():
            with lock:
                i = next(order, None)
            if i is None:
                return
            try:
                results[i] = (True, fn(items[i]))
            except BaseException as e:  # noqa: BLE001 - raised again in the caller's thread
                results[i] = (False, e)
            ready[i].set()

    for _ in range(min(n, len(items))):
        threading.Thread(target=work, name="threads", daemon=True).start()

    def arrive():
        for i, event in enumerate(ready):
            awake(event.wait)
            ok, value = results[i]
            if not ok:
                raise value
            yield value
    return arrive()


def awake(wait) -> None:
    """``wait(timeout)`` until it returns true, waking every WAKE_S: the kernel may deliver a signal to any
    thread (a worker, an OpenBLAS thread), and the main thread, which runs Python's handlers, sees it only when
    it wakes (a wait without timeout slept on through Ctrl-C until the running tasks ended)."""
    while not wait(WAKE_S):
        pass


def ended(process) -> None:
    """Wait for ``process`` (a Popen) to end, in WAKE_S slices (``awake``)."""
    import subprocess

    def within(timeout: float) -> bool:
        try:
            process.wait(timeout)
        except subprocess.TimeoutExpired:
            return False
        return True
    awake(within)


def beside(fn):
    """``fn()`` started on a thread beside the caller's (work that times nothing); returns ``wait()``, which gives
    its result or raises its exception. The thread is a daemon: an interrupted run (Ctrl-C) ends at once instead
    of waiting at exit for work nobody will read."""
    import threading
    box: dict = {}

    def run() -> None:
        try:
            box["result"] = fn()
        except BaseException as e:  # noqa: BLE001 - raised again by wait() in the caller's thread
            box["error"] = e

    thread = threading.Thread(target=run, name="beside", daemon=True)
    thread.start()

    def wait():
        awake(lambda timeout: thread.join(timeout) or not thread.is_alive())
        if "error" in box:
            raise box["error"]
        return box["result"]
    return wait


def workers(jobs: int, tasks: int | None = None, chunksize: int = 1) -> int:
    """The processes ``--jobs`` asks for, at most one per hand-out of ``chunksize`` of ``tasks`` and one per
    processor: a pool forks all its workers at its start (gate of one body with --jobs 300 forked 300)."""
    hand_outs = jobs if tasks is None else -(-tasks // chunksize)
    return max(1, min(jobs, hand_outs, cpus()))


@contextmanager
def mapper(jobs: int, chunksize: int = 1, tasks: int | None = None):
    """An ordered ``map`` over ``workers(jobs, tasks, chunksize)`` local processes (the builtin ``map`` for
    one), ``chunksize`` items a hand-out, as the pool's own map, each result waited for in WAKE_S slices
    (``awake``: a SIGINT the kernel hands to the pool's manager thread is seen at once, not when the next chunk
    ends); interrupted, it ends without waiting for the running tasks (``_stop``)."""
    jobs = workers(jobs, tasks, chunksize)
    if jobs <= 1:
        yield map
        return
    pool = local_pool(jobs)
    try:
        yield lambda fn, *items: _chunked(pool, fn, list(zip(*items)), chunksize)
    except BaseException:
        _stop(pool)
        raise
    pool.shutdown()


def _stop(pool) -> None:
    """End an interrupted pool at once: its workers terminated (the results of their tasks nobody reads) and the
    pool shut down without waiting, which would wait for the tasks running."""
    import multiprocessing
    for worker in multiprocessing.active_children():  # the pool's: the tool starts no other multiprocessing child
        worker.terminate()
    pool.shutdown(wait=False, cancel_futures=True)


def _chunked(pool, fn, args: list, chunksize: int):
    """Submit ``fn(*a)`` for every ``a`` of ``args``, ``chunksize`` at a time; return the results in order as
    they arrive (the chunks not started are cancelled when the caller stops reading)."""
    from concurrent.futures import wait
    chunks = [pool.submit(_calls, fn, args[i:i + chunksize]) for i in range(0, len(args), chunksize)]

    def arrive():
        try:
            for chunk in chunks:
                awake(lambda timeout, chunk=chunk: bool(wait([chunk], timeout).done))
                yield from chunk.result()
        finally:
            for chunk in chunks:
                chunk.cancel()
    return arrive()


def _calls(fn, args: list) -> list:
    """``fn(*a)`` for each ``a`` of a chunk, in a worker."""
    return [fn(*a) for a in args]
