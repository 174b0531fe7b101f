"""Atomic output: write to a temporary file beside the target, then rename."""
from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from ..errors import FFRFError


@contextmanager
def atomic_path(target: str | os.PathLike, overwrite: bool = False) -> Iterator[Path]:
    """Yield a temporary path; on success it replaces ``target``, on failure it is removed."""
    target = Path(target)
    if target.is_symlink() or (target.exists() and not target.is_file()):
        kind = "symbolic link" if target.is_symlink() else "directory" if target.is_dir() else "special file"
        raise FFRFError(f"{target}: expected a regular file to write, got a {kind}")
    if target.exists() and not overwrite:
        raise FFRFError(f"{target}: exists; refusing to overwrite (use --force)")
    if not target.parent.is_dir():
        raise FFRFError(f"{target}: directory {target.parent} does not exist")
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    tmp = Path(tmp)
    os.chmod(tmp, _mode(target))
    try:
        yield tmp
        os.replace(tmp, target)
    finally:
        tmp.unlink(missing_ok=True)


def _mode(target: Path) -> int:
    """The permissions of the file being replaced, else those of a new file under the umask."""
    if target.exists():
        return target.stat().st_mode & 0o777
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask
