"""Checksums of the native format from version 4 on (docs/format.md, "Checksums").

Every dataset carries HDF5's Fletcher-32 checksum per chunk, which the HDF5
library verifies on every read. What it does not cover, the attributes, and
what ties the caches to the data they came from, are SHA-256 digests in the
attributes of ``/checksums``:

- ``nodal_sha256``: of the nodal data the caches are computed from
  (``NODAL``: mesh points, mass matrix, modes, rotary nodes), each dataset's
  values as float64 or int64 (``canonical``), compared wherever a reader
  reads those data anyway (never on the cached path, which would defeat the
  cache);
- ``attributes_sha256``, ``invariants_sha256``, ``nodal_summary_sha256``
  (``SECTIONS``): of the attributes every read uses (header, provenance,
  material, ``nodal_sha256``) and of each cache, compared on every read
  where the cache is present: a few kilobytes. A cache left out (by the
  writer or a tool) is computed from the nodal data, which ``nodal_sha256``
  guards.
"""
from __future__ import annotations

import hashlib

import numpy as np

GROUP = "checksums"
NODAL = ("mesh/points", "mass/", "modes/Phi", "rotary/")  # what the invariants and the nodal summary come from
# /checksums@KEY: the groups whose attributes it covers and the groups or datasets whose values it covers (a
# cache section is left out where its group is). The nodal groups' attributes (CSR shapes) are checked against the
# nodal data they describe. ``per_mode_sha256``: what every read takes besides the caches, each with no second
# copy on the cached path (eigenvalues rewritten through h5py keep a valid Fletcher-32).
SECTIONS = {"attributes_sha256": (("", "provenance", "material", GROUP), ()),
            "per_mode_sha256": ((), ("modes/eigenvalues", "stress/max", "static_centrifugal", "geometric_stiffness")),
            "invariants_sha256": (("invariants",), ("invariants",)),
            "nodal_summary_sha256": (("nodal_summary",), ("nodal_summary",))}
CACHES = ("invariants_sha256", "nodal_summary_sha256")  # sections a writer may leave out


def is_nodal(name: str) -> bool:
    """Whether the dataset ``name`` (without leading slash) is nodal data the caches come from."""
    return any(name == p or (p.endswith("/") and name.startswith(p)) for p in NODAL)


def canonical(block: np.ndarray) -> np.ndarray:
    """Values as the digests see them: float64 or int64, C order, little-endian."""
    kind = "<i8" if block.dtype.kind in "iu" else "<f8"
    return np.ascontiguousarray(block, dtype=kind)


class Dataset:
    """The SHA-256 of one dataset's values, fed in row order (whole, or in blocks that may overlap)."""

    def __init__(self, shape: tuple):
        self.h, self.rows, self.done = hashlib.sha256(repr(tuple(shape)).encode()), shape[0], 0

    def add(self, lo: int, block: np.ndarray) -> None:
        """Rows lo:lo + len(block); rows fed before are skipped, a gap is never filled (``complete`` is False)."""
        if lo <= self.done < lo + len(block):
            self.h.update(canonical(block[self.done - lo:]).data)
            self.done = lo + len(block)

    @property
    def complete(self) -> bool:
        return self.done == self.rows


class Nodal:
    """The digests of the nodal datasets a reading has read; ``hexdigest`` combines them by name."""

    def __init__(self):
        self.sets: dict[str, Dataset] = {}

    def whole(self, name: str, data: np.ndarray) -> None:
        self.stream(name, data.shape).add(0, data)

    def stream(self, name: str, shape: tuple) -> Dataset:
        self.sets[name] = Dataset(shape)
        return self.sets[name]

    def hexdigest(self) -> str | None:
        """None while a dataset was read only in part."""
        if not all(d.complete for d in self.sets.values()):
            return None
        return combine({name: d.h.hexdigest() for name, d in self.sets.items()})


def combine(digests: dict[str, str]) -> str:
    """One SHA-256 of named dataset digests, whatever the order they were computed in."""
    return hashlib.sha256("".join(f"{k}={digests[k]};" for k in sorted(digests)).encode()).hexdigest()


def nodal_digest(f, rows: int) -> str:
    """``nodal_sha256`` of an open file: its nodal datasets read back ``rows`` rows at a time."""
    digests = {}
    for name in datasets(f, is_nodal):
        ds, d = f[name], Dataset(f[name].shape)
        for a in range(0, d.rows, rows):
            d.add(a, ds[a:a + rows])
        digests[name] = d.h.hexdigest()
    return combine(digests)


def datasets(f, keep) -> list[str]:
    """The names of the datasets of ``f`` for which ``keep(name)`` holds, sorted."""
    import h5py
    names = []
    f.visititems(lambda name, obj: names.append(name) if isinstance(obj, h5py.Dataset) and keep(name) else None)
    return sorted(names)


def section_digests(f, read) -> dict[str, str]:
    """The SHA-256 of each section present (``SECTIONS``): the attributes of its groups (names sorted) and its
    datasets as ``read(dataset)`` gives them. Groups looked up by name: a visit of the whole file costs more
    than the read it guards (h5py makes an object per node)."""
    digests = {}
    for key, (groups, data) in SECTIONS.items():
        if key in CACHES and data[0] not in f:
            continue  # a cache left out: the reader computes it from the nodal data (``nodal_sha256``)
        h = hashlib.sha256()
        for name in groups:
            obj = f.get(name) if name else f
            for attr, value in sorted(obj.attrs.items()) if obj is not None else ():
                if name != GROUP or attr == "nodal_sha256":
                    h.update(f"{name}@{attr}=".encode() + _attribute_bytes(value) + b";")
        for name, obj in _datasets(f, data):
            array = np.asarray(read(obj))
            h.update(f"{name}{array.shape}=".encode() + canonical(array).data)
        digests[key] = h.hexdigest()
    return digests


def _datasets(f, paths):
    """(name, dataset) of each path present: a dataset, or every dataset of a group (names sorted)."""
    for path in paths:
        obj = f.get(path)
        if obj is None:
            continue
        yield from ((f"{path}/{n}", o) for n, o in sorted(obj.items())) if hasattr(obj, "items") else ((path, obj),)


def _attribute_bytes(value) -> bytes:
    if isinstance(value, (str, bytes)):
        return b"s" + (value.encode() if isinstance(value, str) else value)
    a = np.asarray(value)
    if a.dtype.kind in "OSU":
        return b"S" + repr(a.tolist()).encode()
    return f"n{a.dtype.str}{a.shape}".encode() + np.ascontiguousarray(a).tobytes()


def write(f, rows: int) -> None:
    """Both digests of a file just written (its datasets and attributes as the reader will see them)."""
    f.create_group(GROUP, track_order=True).attrs["nodal_sha256"] = nodal_digest(f, rows)
    stamp_cache(f)


def stamp_cache(f) -> None:
    """The sections' digests of the file as it is now (also what a test that edits a file on purpose calls)."""
    for key in SECTIONS:
        f[GROUP].attrs.pop(key, None)
    f[GROUP].attrs.update(section_digests(f, lambda ds: ds[()]))
