"""Run a parser in a forked child: crashes, hangs and huge allocations of a library end as one line.

The HDF5 C library can crash (segfault) or loop forever on files with
damaged metadata, and meshio allocates what a file declares; none of this
can be caught in Python. ``run`` forks a child that parses the file and
sends the result (or the exception it raised) back through a pipe, so the
file is read once. The parent unpickles it with an allow-list (``_Unpickler``):
only the classes of the body model and the arrays, matrices and exceptions
they are made of, so a child subverted by a hostile file cannot make the
parent run anything. The child is bounded on its own: it dies with its
parent (PR_SET_PDEATHSIG), past its processor time (RLIMIT_CPU: the work,
not the clock, so a child slow because the machine is loaded is never taken
for a loop; ``BASE_SECONDS`` plus 1 s per 2 MiB of the file and of every
size the reading declares before it reads it, ``limits.declare_work``: an
HDF5 file's uncompressed datasets), and its address
space is limited to what it had plus the memory limit (``limits``). The
parent kills and reaps it on every path out (error, Ctrl-C, SIGTERM).
The file libraries (h5py, the HDF5 library) are loaded where they are
used, in the children (``lazy_module``); while a child parses, the parent
imports what its command needs after the read (``importing_meanwhile``),
else those libraries, for the children that follow.
"""
from __future__ import annotations

import builtins
import copyreg
import ctypes
import faulthandler
import importlib
import importlib.util
import io
import math
import os
import pickle
import resource
import select
import signal
import struct
import sys
import time
from contextlib import contextmanager

from .. import collector
from ..errors import BodyFileError, FFRFError
from .atomic import WAKE_S, forked_child, kill_and_reap
from . import limits
from .limits import ENV, human, max_bytes

BASE_SECONDS = 30.0  # processor seconds: a valid file reads in well under this ...
SECONDS_PER_BYTE = 1 / (2 * 2**20)  # ... plus 1 s per 2 MiB read or declared (meshio parses text at tens of MiB/s)
SECONDS_ENV = "FFRF_ADVISOR_READ_SECONDS"  # raises BASE_SECONDS
SLACK = 512 * 2**20  # address space for pickling the result and the libraries' own buffers
FORK = hasattr(os, "fork")  # tests that spy on the parser in-process set this False
PR_SET_PDEATHSIG = 1


def base_seconds() -> float:
    """BASE_SECONDS, or the processor seconds of SECONDS_ENV (one line when it is not a positive number)."""
    text = os.environ.get(SECONDS_ENV)
    try:
        value = BASE_SECONDS if text is None else float(text)
    except ValueError:
        value = math.nan
    if not 0 < value < math.inf:
        raise FFRFError(f"{SECONDS_ENV}: expected a positive number of processor seconds, got {text!r}")
    return value


def cpu_seconds(path, extra_bytes: int = 0) -> float:
    """The reading child's processor time before it declares anything: the base plus the files' sizes."""
    return base_seconds() + (os.path.getsize(path) + extra_bytes) * SECONDS_PER_BYTE


def run(path, what: str, fn, *args, extra_bytes: int = 0):
    """``fn(*args)`` parsed in a child; its result, or its exception re-raised here.

    ``what`` names the library for the messages ("the HDF5 library", "meshio"); ``extra_bytes``, the size
    of other files the child reads, extends its processor time.
    """
    if not FORK:
        collector.resume()  # the tool's start-up is over (ffrf_advisor.collector)
        return fn(*args)
    seconds, limit = cpu_seconds(path, extra_bytes), max_bytes()  # a bad limit is the parent's one-line error
    try:  # no deadline: the child's processor time bounds it, and it dies with the tool (Ctrl-C, SIGTERM)
        data, status = _forked(lambda fd: _child(fd, seconds, limit, fn, args), math.inf,
                               lambda fd, deadline: _imported_then_received(fd, deadline, limit + SLACK))
    except _Oversize as e:
        raise BodyFileError(path, "file", f"a body that fits the memory limit of {human(limit)} (--max-memory or "
                            f"{ENV})", f"{human(e.args[0])} sent back by the reading child") from None
    if not data:
        raise BodyFileError(path, "file", f"a file {what} can read", f"{what} {_failure(status)}")
    header, buffers = data
    try:
        ok, value = _Unpickler(io.BytesIO(header), buffers=buffers).load()
    except (pickle.UnpicklingError, ValueError, TypeError, EOFError) as e:
        raise BodyFileError(path, "file", f"a file {what} can read",
                            f"the reading child sent back something outside the body model ({e})") from None
    if ok:
        return value
    raise value


def lazy_module(name: str):
    """The module ``name``, loaded at the first use of one of its attributes (importlib.util.LazyLoader): a
    reader's file library is loaded where it is used, in the reading and writing children, and by the tool
    itself only while a child parses and the command has nothing else to import then (``_meanwhile``): h5py
    and the HDF5 library cost about 25 ms of start-up, which analyze and info, reading one body, never pay."""
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.find_spec(name)
    spec.loader = importlib.util.LazyLoader(spec.loader)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    _LAZY.append(name)
    return module


_LAZY: list[str] = []  # the libraries of lazy_module
_MEANWHILE: list[str] = []  # modules the parent imports while the next reading child parses


@contextmanager
def importing_meanwhile(*modules: str):
    """Within: the parent imports ``modules`` (by name: what its command needs after the read) while the next
    reading child parses the file, instead of before or after it, and not the file libraries (``_meanwhile``).
    On two processors the two overlap (the beam's summary takes the child about 45 ms with its h5py import,
    analyze imports about 45 ms meanwhile); on one they take what they took. A read that does not fork
    (``FORK`` False) leaves them to the command's own imports."""
    _MEANWHILE[:] = modules
    try:
        yield
    finally:
        _MEANWHILE.clear()


def _meanwhile() -> None:
    """While a reading child parses: the modules of ``importing_meanwhile`` (once), else the file libraries of
    ``lazy_module``, so that later children (a command reading several bodies, writing one) inherit them
    loaded instead of each loading them anew."""
    modules, _MEANWHILE[:] = tuple(_MEANWHILE) or tuple(_LAZY), []
    for name in modules:
        getattr(importlib.import_module(name), "__name__")  # an attribute: loads a lazy module


def _imported_then_received(fd: int, deadline: float, most: int):
    """``_receive`` after ``_meanwhile``."""
    _meanwhile()
    return _receive(fd, deadline, most)


def run_writer(target, fn, *args) -> None:
    """``fn(*args)`` (a writer) in a child that ends with ``os._exit``: a library that fails to write (a full
    disk, the file-size limit) and then crashes while cleaning up ends as one line naming ``target``. The child
    sends back only the text of its exception; it has no deadline (a large body takes what it takes) and dies
    with its parent."""
    if not FORK:
        return fn(*args)
    data, status = _forked(lambda fd: _writer_child(fd, fn, args), float("inf"))
    if os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0:
        return None
    got = (data.decode("utf-8", "replace") if data else
           _crash(status, "writing it") + "; a full disk or the file-size limit makes the HDF5 library crash")
    raise FFRFError(f"{target}: write: expected to write the file, got {' '.join(got.split())[:200]}")


def _forked(child, deadline: float, receive=None) -> tuple[object, int | None]:
    """Run ``child(fd)`` in a forked process (it must end with ``os._exit``); what it wrote to ``fd``, as
    ``receive(fd, deadline)`` reads it (default ``_collect``; None past the ``deadline``, time.monotonic), and
    its wait status (None when killed here). The child is killed and reaped on every path out."""
    read_end, write_end = os.pipe()
    with forked_child() as pid:  # a SIGTERM here kills and reaps the child first (io.atomic)
        if pid == 0:  # child: never returns into the caller's code
            os.close(read_end)
            child(write_end)
        os.close(write_end)
        status = None
        try:
            data = (receive or _collect)(read_end, deadline)
            if data is not None:
                status, pid = os.waitpid(pid, 0)[1], 0
        finally:
            os.close(read_end)
            if pid:
                kill_and_reap(pid)
    return data, status


def _send(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view):]


def _writer_child(fd: int, fn, args) -> None:
    code, message = 0, b""
    try:
        _plain_child()
        devnull = os.open(os.devnull, os.O_WRONLY)  # the libraries' own complaints: the parent says it in one line
        os.dup2(devnull, 2)
        fn(*args)
    except BaseException as e:  # noqa: BLE001 - the parent reports it in one line
        code, message = 1, f"{type(e).__name__}: {e}".encode("utf-8", "replace")
    try:
        _send(fd, message)
    finally:
        os._exit(code)  # no cleanup: a library's destructor may crash after a failed write


# What the parent accepts from the child: classes of these packages (no functions) ...
TRUSTED_PACKAGES = ("ffrf_advisor", "meshio", "scipy.sparse", "numpy.dtypes")
# ... and these names: how numpy arrays, dtypes and scalars, fractions and objects are rebuilt.
TRUSTED_NAMES = {(m, n) for m in ("numpy._core.multiarray", "numpy.core.multiarray")
                 for n in ("_reconstruct", "scalar")} | \
    {(m, "_frombuffer") for m in ("numpy._core.numeric", "numpy.core.numeric")} | \
    {("numpy", "dtype"), ("numpy", "ndarray"), ("fractions", "Fraction"), ("collections", "OrderedDict"),
     ("copyreg", "_reconstructor"), ("copyreg", "__newobj__")}
SAFE_BUILTINS = {"object", "dict", "list", "tuple", "set", "frozenset", "int", "float", "complex", "str", "bytes",
                 "bytearray", "bool", "slice", "range"}


class _Unpickler(pickle.Unpickler):
    """Unpickles only the allow-list above and the exceptions of builtins and of this package."""

    def find_class(self, module: str, name: str):
        if (module, name) in TRUSTED_NAMES:
            return super().find_class(module, name)
        if module == "builtins":
            obj = getattr(builtins, name, None)
            if isinstance(obj, type) and (name in SAFE_BUILTINS or issubclass(obj, BaseException)):
                return obj
        elif module.split(".")[0] in ("ffrf_advisor", "meshio") or module.startswith(TRUSTED_PACKAGES):
            obj = super().find_class(module, name)
            if isinstance(obj, type):
                return obj
        raise pickle.UnpicklingError(f"{module}.{name} is not a type of the body model")


def _transportable(e: BaseException) -> BaseException:
    """The exception itself when the parent accepts its class (builtins, this package), else its text."""
    module = type(e).__module__
    return e if module == "builtins" or module.startswith("ffrf_advisor") else RuntimeError(f"{type(e).__name__}: {e}")


def _child(fd: int, seconds: float, limit: int, fn, args) -> None:
    code = 0
    try:
        _bound_self(seconds, limit)
        try:
            message = (True, fn(*args))
        except MemoryError:
            message = (False, MemoryError(f"needed more than the memory limit of {human(limit)}"))
        except BaseException as e:  # noqa: BLE001 - the parent re-raises it
            message = (False, _transportable(e))
        try:
            data = _dumps(message)
        except MemoryError:  # the body was read, but pickling it passes the limit
            data = _dumps((False, MemoryError(f"needed more than the memory limit of {human(limit)} to send the "
                                              "body read to the parent")))
        except Exception as e:  # noqa: BLE001 - an exception that does not pickle travels as its text
            data = _dumps((False, RuntimeError(f"{type(message[1]).__name__}: {e}")))
        _send_message(fd, *data)
    except BaseException:  # noqa: BLE001 - nothing may return into the parent's code
        code = 1
    os._exit(code)


def _dumps(message) -> tuple[bytes, list[memoryview]]:
    """The child's message pickled with the standard reductions of exceptions (a package that registered its
    own, as tblib does when Dask distributed is imported, would send functions the parent's allow-list
    refuses), and the arrays' memory apart (pickle protocol 5's out-of-band buffers): sent from where they
    are, so the child holds no copy of the body."""
    buffer, buffers = io.BytesIO(), []
    pickler = pickle.Pickler(buffer, protocol=5, buffer_callback=buffers.append)
    pickler.dispatch_table = {t: f for t, f in copyreg.dispatch_table.items() if not issubclass(t, BaseException)}
    pickler.dump(message)
    return buffer.getvalue(), [b.raw() for b in buffers]


_LENGTH = struct.Struct("<Q")


def _send_message(fd: int, header: bytes, buffers: list[memoryview]) -> None:
    """The number of buffers, every length, the pickle, then the buffers, each as it lies in memory."""
    lengths = [len(header)] + [b.nbytes for b in buffers]
    _send(fd, _LENGTH.pack(len(buffers)) + b"".join(_LENGTH.pack(n) for n in lengths))
    for part in (header, *buffers):
        _send(fd, part)


class _Oversize(Exception):
    """The child announced more bytes than its memory limit allows (the bytes in args[0])."""


def _receive(fd: int, deadline: float, most: int) -> tuple[bytes, list[memoryview]] | tuple[()] | None:
    """``_send_message``'s pickle and buffers (each read straight into its own memory, at most
    ``most`` bytes in all); () when the child ended before sending it all, None past the deadline."""
    try:
        count = _LENGTH.unpack(_read_exact(fd, _LENGTH.size, deadline, most))[0]
        table = _read_exact(fd, _LENGTH.size * (count + 1), deadline, most)
        lengths = [_LENGTH.unpack_from(table, i * _LENGTH.size)[0] for i in range(count + 1)]
        if sum(lengths) > most:
            raise _Oversize(sum(lengths))
        parts = [_read_exact(fd, n, deadline, most) for n in lengths]
    except _Ended:
        return ()
    except _Late:
        return None
    return bytes(parts[0]), parts[1:]


class _Ended(Exception):
    """The child closed the pipe before sending all it announced."""


class _Late(Exception):
    """The deadline passed."""


def _read_exact(fd: int, size: int, deadline: float, most: int) -> bytearray:
    """``size`` bytes from ``fd``, read into one new buffer (``_Oversize`` above ``most``)."""
    if size > most:
        raise _Oversize(size)
    buffer = bytearray(size)
    view, done = memoryview(buffer), 0
    while done < size:
        if not _readable(fd, deadline):
            raise _Late
        got = os.readv(fd, [view[done:]])
        if not got:
            raise _Ended
        done += got
    return buffer


def die_with_parent(parent: int | None = None) -> None:
    """Have the kernel kill this process when its parent ends (Linux; elsewhere a no-op), and end now when the
    parent ``parent`` is already gone: no child of the tool outlives it (a pool's initializer)."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    except (OSError, AttributeError):  # not Linux: the parent's deadline still holds
        pass
    if parent is not None and os.getppid() != parent:
        os._exit(1)


def _plain_child() -> None:
    """A child of the tool: its crash is reported by the parent in one line, it dies with the parent, and
    signals take their default actions (not the parent's handlers)."""
    faulthandler.disable()
    die_with_parent()
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGALRM):
        signal.signal(sig, signal.SIG_DFL)


def _bound_self(seconds: float, limit: int) -> None:
    """Die with the parent, past ``seconds`` of processor time (extended by each size the reading declares,
    ``limits.declare_work``) and before allocating more than the memory limit; no core file."""
    _plain_child()
    resource.setrlimit(resource.RLIMIT_CORE, (0, resource.getrlimit(resource.RLIMIT_CORE)[1]))
    _cpu_limit(seconds)
    limits.on_declared_work(lambda nbytes: _cpu_limit(nbytes * SECONDS_PER_BYTE, more=True))
    size = _address_space()
    if size:
        soft, hard = size + limit + SLACK, resource.getrlimit(resource.RLIMIT_AS)[1]
        resource.setrlimit(resource.RLIMIT_AS, (soft if hard == resource.RLIM_INFINITY else min(soft, hard), hard))


_GRANTED = [0.0]  # the reading child's processor seconds so far (the limit takes whole seconds)


def _cpu_limit(seconds: float, more: bool = False) -> None:
    """The soft limit of processor time at ``seconds`` (``more``: that many more); SIGXCPU past it."""
    _GRANTED[0] = seconds + (_GRANTED[0] if more else 0.0)
    total, hard = max(1, round(_GRANTED[0])), resource.getrlimit(resource.RLIMIT_CPU)[1]
    resource.setrlimit(resource.RLIMIT_CPU, (total if hard == resource.RLIM_INFINITY else min(total, hard), hard))


def _address_space() -> int:
    try:
        with open("/proc/self/statm") as fh:
            return int(fh.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


def _readable(fd: int, deadline: float) -> bool:
    """Wait until ``fd`` has data (or its end); False past the ``deadline`` (time.monotonic). In slices of
    WAKE_S: a SIGTERM or Ctrl-C handled just before the wait ends the run at once, not when the child ends."""
    while (left := deadline - time.monotonic()) > 0:
        if select.select([fd], [], [], min(left, WAKE_S))[0]:
            return True
    return False


def _collect(fd: int, deadline: float) -> bytes | None:
    """Everything the child writes until it closes the pipe; None past the deadline."""
    chunks = []
    while True:
        if not _readable(fd, deadline):
            return None
        chunk = os.read(fd, 1 << 20)
        if not chunk:
            return b"".join(chunks)
        chunks.append(chunk)


def _failure(status: int | None) -> str:
    """What happened to a child that sent no result, in words."""
    if status is not None and os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGXCPU:
        return (f"used up its processor time reading it ({base_seconds():g} s plus 1 s per 2 MiB of the file and "
                f"of the data it declares) and was stopped: damaged metadata can make it loop; for a valid body "
                f"raise {SECONDS_ENV} (now {base_seconds():g} s)")
    return _crash(status, "reading it") if status is not None else "stopped without a result"


def _crash(status: int, doing: str) -> str:
    """A child's end without a result, in words."""
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        name = signal.Signals(sig).name if sig in signal.Signals._value2member_map_ else "unknown"
        return f"crashed {doing} (signal {sig}, {name})"
    return f"stopped without a result (exit status {os.WEXITSTATUS(status)})"
