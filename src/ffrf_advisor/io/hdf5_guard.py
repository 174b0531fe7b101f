"""Probe an HDF5 file in a forked child before reading it.

The HDF5 C library can crash (segfault) or loop forever on files with
damaged metadata; neither can be caught in Python. The child opens the
file, visits every object and attribute and reads the small datasets; if
it dies by a signal or overruns the time limit, the file is reported as
corrupt with the project's one-line error instead of taking the process
down. Python-level errors in the child are left to the real reader, which
names the field.
"""
from __future__ import annotations

import os
import signal
import time

import h5py

from ..errors import BodyFileError

PROBE_SECONDS = 15.0
SMALL = 16 * 2**20  # datasets up to this many bytes are read in full by the probe


def _visit(path) -> None:
    with h5py.File(path, "r") as f:
        dict(f.attrs)

        def touch(_, obj):
            dict(obj.attrs)
            if isinstance(obj, h5py.Dataset) and obj.size * obj.dtype.itemsize <= SMALL:
                obj[()]

        f.visititems(touch)


def probe(path) -> None:
    """Raise BodyFileError when the HDF5 library crashes or hangs on ``path``; return otherwise."""
    if not hasattr(os, "fork"):
        return
    pid = os.fork()
    if pid == 0:  # child: never returns into the caller's code
        code = 0
        try:
            _visit(path)
        except BaseException:  # noqa: BLE001 - a Python error is the real reader's to report
            code = 1
        os._exit(code)
    deadline = time.monotonic() + PROBE_SECONDS
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        if time.monotonic() > deadline:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            raise BodyFileError(path, "file", "an HDF5 file the HDF5 library can parse",
                                f"the library did not finish within {PROBE_SECONDS:g} s (damaged metadata)")
        time.sleep(0.002)
    if os.WIFSIGNALED(status):
        raise BodyFileError(path, "file", "an HDF5 file the HDF5 library can parse",
                            f"the library crashed on it (signal {os.WTERMSIG(status)}; damaged metadata)")
