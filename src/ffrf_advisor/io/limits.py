"""What a body file may make the tool allocate: one documented, settable limit (docs/format.md, "Limits").

Readers check every size a file declares (array shapes, block counts, the
size of a text file) against the limit *before* allocating, and count what
they have allocated so far, so a file that declares 10^9 nodes ends in the
one-line error instead of a MemoryError after the machine has swapped.
The limit is ``--max-memory`` of the CLI, else the environment variable
``FFRF_ADVISOR_MAX_MEMORY`` (``8G``, ``500M``, bytes), else 8 GiB. It bounds
what the body costs the whole process tree beyond the interpreters: every
declared byte is charged ``TREE_BYTES_PER_BYTE`` times (the reading child
holds what it read, sends the arrays from where they lie, and the parent
receives them once; benchmarks/bench_memory.py measures the ratio).
"""
from __future__ import annotations

import os
import re

from ..errors import BodyFileError, FFRFError
from ..names import MAX_MEMORY_ENV as ENV

DEFAULT = 8 * 2**30
TREE_BYTES_PER_BYTE = 3.0  # measured 2.3-2.9 (benchmarks/bench_memory.py, 27-185 MiB declared): the child's
# read with its finite-check masks and blocks of the nodal sums, the parent's body and blocks of the analysis
_UNITS = {"": 1, "K": 2**10, "M": 2**20, "G": 2**30, "T": 2**40}
_set: int | None = None


def parse_size(text: str, where: str) -> int:
    """``8G``, ``512M``, ``1e9`` (bytes) -> bytes; one-line error naming ``where`` otherwise."""
    m = re.fullmatch(r"\s*([0-9.eE+]+)\s*([KMGT]?)(i?B)?\s*", str(text), re.IGNORECASE)
    try:
        value = float(m.group(1)) * _UNITS[m.group(2).upper()] if m else -1.0
    except ValueError:
        value = -1.0
    if not value >= 2**10 or value > 2**60:
        raise FFRFError(f"{where}: expected a memory size of at least 1K like 8G or 512M, got {text!r}")
    return int(value)


def set_max_bytes(n: int | None) -> None:
    """Set the limit for this process (None: back to the environment or the default)."""
    global _set
    _set = n


def max_bytes() -> int:
    if _set is not None:
        return _set
    text = os.environ.get(ENV)
    return DEFAULT if not text else parse_size(text, ENV)


def human(n: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if n < 1024 or unit == "TiB":
            return f"{n:.3g} {unit}"
        n /= 1024
    return ""


class Budget:
    """The bytes one reading of one file has allocated; ``take`` refuses what would pass the limit."""

    def __init__(self, path):
        self.path, self.used, self.limit = path, 0, max_bytes()

    @property
    def remaining(self) -> int:
        return max(0, self.limit - self.used)

    def take(self, field: str, nbytes: float, copies: float = TREE_BYTES_PER_BYTE) -> None:
        """Charge ``nbytes`` read by the child, ``copies`` times: ``TREE_BYTES_PER_BYTE`` for what the parent
        receives too, 1 for a working set the child alone holds (blocks of a streamed pass)."""
        tree = nbytes * copies
        declare_work(nbytes)
        if self.used + tree > self.limit:
            raise BodyFileError(self.path, field, f"data that fit the memory limit of {human(self.limit)} "
                                f"(--max-memory or {ENV})", f"{human(nbytes)} declared, "
                                f"{human(self.used + tree)} for the process tree with what was read before")
        self.used += int(tree)


_work_hooks: list = []  # set in a guarded reading child (io.guard): its processor time grows with the work


def on_declared_work(hook) -> None:
    """``hook(nbytes)`` for every size declared from now on (this process only: a reading child)."""
    _work_hooks[:] = [hook]


def declare_work(nbytes: float) -> None:
    """A size the reading is about to process (read, inflate, sum over): the guard's bound on the child's
    processor time grows with it, not with the file's (compressed) size or the clock."""
    for hook in _work_hooks:
        hook(nbytes)


def check_file_size(path, factor: float = 1.0) -> None:
    """A file read whole (JSON, mesh formats) whose parsed form takes ``factor`` times its size."""
    Budget(path).take("file", os.path.getsize(path) * factor)


# ---------------------------------------------------------------- references to other files
_outside = False


def follow_outside(flag: bool) -> None:
    """``--follow-outside``: references may leave the body file's folder (still to regular files only)."""
    global _outside
    _outside = flag


def check_reference(path, field: str, target: str) -> None:
    """A file that ``path`` refers to (HDF5 external link or storage, XDMF heavy data): a regular file in
    ``path``'s folder (or anywhere with --follow-outside); never a FIFO, device, directory or missing file."""
    folder = os.path.dirname(os.path.realpath(path))
    resolved = os.path.realpath(os.path.join(folder, target))
    if not _outside and os.path.commonpath([folder, resolved]) != folder:
        raise BodyFileError(path, field, "references to files in the body file's folder (--follow-outside to "
                            "allow others)", repr(target[:200]))
    if not os.path.isfile(resolved):
        raise BodyFileError(path, field, "a reference to an existing regular file", repr(target[:200]))


def check_hdf5_references(path, f) -> None:
    """Every external link, external storage and virtual dataset source of an open HDF5 file."""
    import h5py

    names: list[str] = []
    f.visit_links(names.append)  # names only, collected first: an exception inside h5py's visit (making a link
    for name in names:           # object of a damaged file, as visititems_links would) ends as a SystemError
        link = f.get(name, getlink=True)
        if isinstance(link, h5py.ExternalLink):
            check_reference(path, name, link.filename)
        elif isinstance(link, h5py.HardLink) and isinstance(obj := f.get(name), h5py.Dataset):
            _check_dataset_sources(path, name, obj)


def _check_dataset_sources(path, name: str, ds) -> None:
    for source in ds.external or ():
        check_reference(path, name, os.fsdecode(source[0]))
    if ds.is_virtual:
        for source in ds.virtual_sources():
            if source.file_name != ".":
                check_reference(path, name, source.file_name)
