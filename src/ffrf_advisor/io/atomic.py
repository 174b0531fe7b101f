"""Atomic output: write to a temporary file (or folder) beside the target, fsync, then rename.

The temporary file ``.NAME.PID.*.tmp`` is removed on any failure and on
SIGTERM (in the main thread: the process then ends at once with 143, after
killing and reaping its children, ``forked_child``: a writer child must not
create the temporary again after it was removed); one left by a killed
process (SIGKILL, power loss) is swept by the next write to the same target
once its process is gone.
"""
from __future__ import annotations

import ctypes
import errno
import os
import secrets
import shutil
import signal
import threading
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path
from typing import Iterator

from .. import collector
from ..errors import FFRFError


WAKE_S = 0.1  # how often a waiting main thread wakes to run a signal's handler (below)
_RUN_INPUTS: ContextVar[list[Path] | None] = ContextVar("run_inputs", default=None)
_TEMPORARIES: set[Path] = set()  # this process's temporaries being written
_CHILDREN: set[int] = set()  # this process's forked children (io.guard), killed before the temporaries go


@contextmanager
def one_run() -> Iterator[None]:
    """Within it, every file read as an input (``note_input``) is refused as a target by ``atomic_path``,
    whatever ``--force`` says: a command never writes over what it reads; SIGTERM ends it with 143."""
    token = _RUN_INPUTS.set([])
    try:
        with terminate_cleanly():
            yield
    finally:
        _RUN_INPUTS.reset(token)


def note_input(path) -> None:
    """Record ``path`` as an input of the running command (no effect outside ``one_run``)."""
    inputs = _RUN_INPUTS.get()
    if inputs is not None:
        inputs.append(Path(path))


def not_an_input(target) -> None:
    """FFRFError when ``target`` is a file the running command read (``one_run``)."""
    refuse_inputs(target, _RUN_INPUTS.get() or (), "is an input of this run; refusing to write over it "
                                                   "(with or without --force)")


def refuse_inputs(target, inputs, message: str) -> None:
    """FFRFError ``TARGET: message`` when ``target`` is one of ``inputs`` (the same file, links included)."""
    target = Path(target)
    if any(target.exists() and Path(i).exists() and target.samefile(i) for i in inputs):
        raise FFRFError(f"{target}: {message}")


def check_target(target: str | os.PathLike, overwrite: bool = False) -> None:
    """FFRFError unless ``target`` may be written: no input of this run, a regular file or none (no link,
    directory or device), absent unless ``overwrite``, in an existing directory. Commands that work long before
    they write call it first."""
    target = Path(target)
    not_an_input(target)
    if target.is_symlink() or (target.exists() and not target.is_file()):
        kind = "symbolic link" if target.is_symlink() else "directory" if target.is_dir() else "special file"
        raise FFRFError(f"{target}: expected a regular file to write, got a {kind}")
    if target.exists() and not overwrite:
        raise FFRFError(f"{target}: exists; refusing to overwrite (use --force)")
    if not target.parent.is_dir():
        raise FFRFError(f"{target}: directory {target.parent} does not exist")
    writable_folder(target)


def writable_folder(target: Path) -> None:
    """The folder of ``target`` one this user may write in (checked before the work, not after it)."""
    if not os.access(target.parent, os.W_OK | os.X_OK):
        raise FFRFError(f"{target}: write: expected a folder this user may write in, got {target.parent} "
                        "without write permission")


@contextmanager
def atomic_path(target: str | os.PathLike, overwrite: bool = False) -> Iterator[Path]:
    """Yield a temporary path; on success it replaces ``target``, on failure it is removed."""
    target = Path(target)
    check_target(target, overwrite)
    _sweep_stale(target)
    tmp = _new_temporary(target)
    try:
        os.chmod(tmp, _mode(target))
        with terminate_cleanly():
            try:
                yield tmp
                _fsync(tmp)
                os.replace(tmp, target)
                _fsync(target.parent)
            except OSError as e:  # a full disk, a quota, the file-size limit
                raise FFRFError(f"{target}: write: expected to write the file, got {e.strerror or e}") from None
    finally:
        tmp.unlink(missing_ok=True)
        _TEMPORARIES.discard(tmp)


@contextmanager
def atomic_directory(target: str | os.PathLike, names: tuple[str, ...], overwrite: bool = False) -> Iterator[Path]:
    """Yield a new temporary folder beside ``target``; on success it takes ``target``'s place whole (``_swap``),
    on failure or SIGTERM it is removed: ``target`` is the old folder or the complete new one, never a mix. An
    existing ``target`` may hold only ``names`` (replaced only with ``overwrite``): anything else would leave
    with the old folder."""
    target = Path(target)
    _check_folder(target, names, overwrite)
    target.parent.mkdir(parents=True, exist_ok=True)
    writable_folder(target)
    _sweep_stale(target)
    tmp = _new_temporary(target, folder=True)
    try:
        with terminate_cleanly():
            try:
                yield tmp
                for path in tmp.iterdir():
                    _fsync(path)
                _swap(tmp, target)
                _fsync(target.parent)
            except OSError as e:  # a full disk, a quota, the file-size limit
                raise FFRFError(f"{target}: write: expected to write the folder, got {e.strerror or e}") from None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)  # after the swap: the old folder
        _TEMPORARIES.discard(tmp)


def _check_folder(target: Path, names: tuple[str, ...], overwrite: bool) -> None:
    """``target`` a folder to replace whole: absent, or a directory of ``names`` only (present: ``overwrite``)."""
    not_an_input(target)
    if target.is_symlink() or (target.exists() and not target.is_dir()):
        raise FFRFError(f"{target}: expected a directory to write {', '.join(names)} into, got a "
                        f"{'symbolic link' if target.is_symlink() else 'file'}")
    present = sorted(p.name for p in target.iterdir()) if target.exists() else []
    if other := [n for n in present if n not in names]:
        raise FFRFError(f"{target}: expected a new folder or one holding only {', '.join(names)} (it is replaced "
                        f"whole), got {other[0]!r} in it too")
    if present and not overwrite:
        raise FFRFError(f"{target}: holds {', '.join(present)}; refusing to replace them (use --force)")


RENAME_EXCHANGE, AT_FDCWD = 2, -100  # linux/fs.h, fcntl.h


def _swap(new: Path, target: Path) -> None:
    """``new`` becomes ``target`` and the old ``target`` (if any) ``new``: one atomic exchange (Linux
    renameat2), else two renames with SIGTERM held between them (its handler then finds ``target`` complete)."""
    if not target.exists():
        os.rename(new, target)
        return
    if _exchange(new, target):
        return
    old = new.with_name(new.name + ".old")
    held = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})
    try:
        os.rename(target, old)
        os.rename(new, target)
        os.rename(old, new)
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, held)


def _exchange(a: Path, b: Path) -> bool:
    """renameat2(a, b, RENAME_EXCHANGE); False where the C library or the file system lacks it."""
    try:
        renameat2 = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):
        return False
    if renameat2(AT_FDCWD, os.fsencode(a), AT_FDCWD, os.fsencode(b), RENAME_EXCHANGE) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP):
        return False
    raise OSError(code, os.strerror(code), str(b))


def _new_temporary(target: Path, folder: bool = False) -> Path:
    """Create ``.NAME.PID.RANDOM.tmp`` beside ``target``, noted as this process's before it exists: a SIGTERM
    handled at any moment (Python runs its handler between any two bytecodes) removes it or finds none."""
    while True:
        tmp = target.parent / f".{target.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp"
        _TEMPORARIES.add(tmp)
        try:
            if folder:
                os.mkdir(tmp, 0o777)  # under the umask
            else:
                os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
            return tmp
        except BaseException as e:
            _TEMPORARIES.discard(tmp)
            if isinstance(e, OSError) and not isinstance(e, FileExistsError):  # named by the folder, not the tmp
                raise FFRFError(f"{target}: write: expected a folder this user may write in, got "
                                f"{e.strerror or e} in {target.parent}") from None
            if not isinstance(e, FileExistsError):
                raise


def _sweep_stale(target: Path) -> None:
    """Remove temporaries of ``target`` whose writing process no longer exists."""
    for old in target.parent.glob(f".{target.name}.*.tmp"):
        pid = old.name[len(target.name) + 2:].split(".", 1)[0]
        if pid.isdigit() and not _alive(int(pid)):
            _remove(old)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _fsync(path: Path) -> None:
    """Flush a file (or a directory entry) to the disk before relying on it."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


@contextmanager
def terminate_cleanly():
    """Within it (main thread only), SIGTERM removes this process's temporaries and ends the process at once
    with 128 + 15. An exception raised from the handler instead could land in a C or weakref callback, be
    printed as ignored, and let the run finish as if nothing happened. Python runs the handler in the main
    thread between bytecodes; a signal that arrives just before a blocking call (or in another thread) is seen
    when the call returns, so the main thread waits in slices of WAKE_S (``pool.awake``, ``guard._readable``)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _on_terminate)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


@contextmanager
def forked_child() -> Iterator[int]:
    """``pid = os.fork()`` (in the child: 0) with SIGTERM held until the pid is noted, so the handler of
    ``terminate_cleanly`` kills and reaps it before it removes the temporaries; the pid is forgotten on the
    way out (the caller reaps the child before, ``kill_and_reap``). Where the tool's start-up holds the cyclic
    garbage collector off (ffrf_advisor.collector), what exists is frozen before the fork; the child collects,
    and the parent again on the way out."""
    collector.before_fork()
    held = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})
    pid = os.fork()
    if pid == 0:
        collector.resume()
        signal.pthread_sigmask(signal.SIG_SETMASK, held)
        yield pid
        return
    _CHILDREN.add(pid)
    signal.pthread_sigmask(signal.SIG_SETMASK, held)
    try:
        yield pid
    finally:
        _CHILDREN.discard(pid)
        collector.resume()


def kill_and_reap(pid: int) -> None:
    """SIGKILL a child of this process and wait for it (nothing when it is already gone)."""
    try:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
    except OSError:  # ProcessLookupError, ChildProcessError
        pass


def _on_terminate(signum, frame) -> None:  # noqa: ARG001
    for pid in list(_CHILDREN):
        kill_and_reap(pid)
    for tmp in list(_TEMPORARIES):
        _remove(tmp)
    os._exit(128 + signum)


def _remove(tmp: Path) -> None:
    """A temporary file or folder, if it is there."""
    if tmp.is_dir() and not tmp.is_symlink():
        shutil.rmtree(tmp, ignore_errors=True)
    else:
        try:
            os.unlink(tmp)
        except OSError:
            pass


def _mode(target: Path) -> int:
    """The permissions of the file being replaced, else those of a new file under the umask."""
    if target.exists():
        return target.stat().st_mode & 0o777
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask
