"""Validating access to one open HDF5 body file (io.ffrf_h5): every failure names the field; from format
version 4 on every dataset must carry its Fletcher-32 checksum (io.h5_checksums), a chunk that fails it is
an error naming the dataset, and the nodal data read are digested for the caches' ``nodal_sha256``."""
from __future__ import annotations

from contextlib import contextmanager

import numpy as np

from ..errors import BodyFileError
from ..values import is_number
from . import guard, h5_checksums
from .limits import TREE_BYTES_PER_BYTE, Budget

h5py = guard.lazy_module("h5py")

CHILD_COPIES = 2.0  # bytes of the process tree per byte read and kept in the reading child (``kept_in_child``)
CHECKSUMS_FROM = 4  # the format version from which datasets carry checksums


class Reader:
    """Validating access to one open file; every failure names the field."""

    def __init__(self, path, f: h5py.File):
        self.path, self.f, self.budget = path, f, Budget(path)
        self.copies = TREE_BYTES_PER_BYTE  # what each byte read costs the process tree (limits.Budget.take)
        self.version, self.nodal = 0, None

    def set_version(self, version: int) -> None:
        """From CHECKSUMS_FROM on, checksums are required and the nodal data read are digested."""
        self.version = version
        self.nodal = h5_checksums.Nodal() if version >= CHECKSUMS_FROM else None

    @contextmanager
    def kept_in_child(self):
        """Arrays read inside are used by the reading child alone, never sent back: each byte costs the read
        and one temporary (a finite-check mask, an index conversion), not the parent's copy too."""
        self.copies = CHILD_COPIES
        try:
            yield
        finally:
            self.copies = TREE_BYTES_PER_BYTE

    def fail(self, field: str, expected: str, got: str | None = None):
        raise BodyFileError(self.path, field, expected, got)

    def node(self, name: str, group: bool = False):
        """The dataset (the group with ``group``) ``name``."""
        kind, what = (h5py.Group, "a group") if group else (h5py.Dataset, "a dataset")
        if name not in self.f:
            self.fail(name, what, "missing")
        obj = self.f[name]
        if not isinstance(obj, kind):
            self.fail(name, what, type(obj).__name__)
        return obj

    def read(self, ds: h5py.Dataset, selection=()) -> np.ndarray:
        """``ds[selection]``; a dataset without its checksum (format 4) or a chunk that fails it (or fails to
        inflate: HDF5 says only "filter returned failure") is an error naming the dataset."""
        if self.version >= CHECKSUMS_FROM and ds.size and not ds.fletcher32:
            self.fail(ds.name.lstrip("/"), f"a Fletcher-32 checksum on every dataset (format {self.version})",
                      "a dataset without one")
        try:
            return ds[selection]
        except OSError as e:
            if not ds.fletcher32 and "filter" not in str(e):
                raise
            self.fail(ds.name.lstrip("/"), "chunks that pass their Fletcher-32 checksum",
                      "a damaged chunk (the checksum or decompression failed)")

    def array(self, name: str, shape: tuple, what: str = "finite numbers", integer: bool = False) -> np.ndarray:
        ds = self.node(name)
        if len(ds.shape) != len(shape) or any(s is not None and s != d for s, d in zip(shape, ds.shape)):
            want = "(" + ", ".join("*" if s is None else str(s) for s in shape) + ")"
            self.fail(name, f"shape {want}", str(tuple(ds.shape)))
        kind = ds.dtype.kind
        if kind not in ("iu" if integer else "fiu"):
            self.fail(name, "integers" if integer else "numbers", f"dtype {ds.dtype}")
        self.budget.take(name, ds.size * 8.0, self.copies)
        data = self.read(ds)
        data = data.astype(np.int64 if integer else float, copy=False)
        if not integer and not np.all(np.isfinite(data)):
            self.fail(name, what, "NaN or inf")
        if self.nodal is not None and h5_checksums.is_nodal(name):
            self.nodal.whole(name, data)
        data.flags.writeable = False  # body data as read (invariants.frozen_array takes it without a copy)
        return data

    def attr(self, name: str, obj=None) -> str:
        obj = self.f if obj is None else obj
        if name not in obj.attrs:
            self.fail(f"{obj.name.rstrip('/')}@{name}", "an attribute", "missing")
        value = obj.attrs[name]
        return value.decode() if isinstance(value, bytes) else value

    def number(self, name: str, obj, expected: str, ok=lambda v: True, integer: bool = False):
        """The attribute ``name`` of ``obj``: a number (values.is_number: never a bool, string or array) for
        which ``ok`` holds, else one line with ``expected``."""
        value = obj.attrs.get(name)
        if not is_number(value, integer) or not ok(value):
            self.fail(f"{obj.name.rstrip('/')}@{name}", expected, repr(value))
        return value

    def csr(self, name: str, shape: tuple[int, int]):
        g = self.node(name, group=True)
        raw = np.asarray(g.attrs.get("shape", ()))
        got = tuple(int(s) for s in raw.ravel()) if raw.dtype.kind in "iu" else repr(raw.tolist())
        if got != shape:
            self.fail(f"{name}@shape", f"{shape}", str(got))
        data = self.array(f"{name}/data", (None,))
        indices = self.array(f"{name}/indices", (len(data),), integer=True)
        indptr = self.array(f"{name}/indptr", (shape[0] + 1,), integer=True)
        if (indptr[0] != 0 or indptr[-1] != len(data) or np.any(np.diff(indptr) < 0)
                or (len(indices) and (indices.min() < 0 or indices.max() >= shape[1]))):
            self.fail(name, "a valid CSR matrix (monotone indptr, indices in range)")
        import scipy.sparse as sp
        return sp.csr_array((data, indices, indptr), shape=shape)
