"""Body file formats, reached through one registry by file suffix (meshio's layout)."""
from __future__ import annotations

import hashlib
import importlib
import os
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from ..body import FlexibleBody
from ..errors import BodyFileError, FFRFError
from .atomic import note_input


@dataclass(frozen=True)
class Format:
    """A body file format: its name, suffixes, and the module of this package that reads (and writes) it,
    imported on first use (a command imports only the readers it needs)."""

    name: str
    suffixes: tuple[str, ...]
    module: str
    reader: str = "read"
    writer: str | None = None  # the module's writer function; None: read only

    @property
    def read(self) -> Callable[..., FlexibleBody]:
        return self._function(self.reader)

    @property
    def write(self) -> Callable[..., None] | None:
        return None if self.writer is None else self._function(self.writer)

    def _function(self, name: str) -> Callable:
        return getattr(importlib.import_module(f"{__name__}.{self.module}"), name)


_FORMATS = {f.name: f for f in (
    Format("ansys", (".rst",), "ansys"),
    Format("calculix", (".frd",), "calculix"),
    Format("ffinv-json", (".ffinv.json",), "ffinv", "read_json", "write_json"),
    Format("ffinv-h5", (".ffinv.h5",), "ffinv", "read_h5", "write_h5"),
    Format("ffrf-h5", (".ffrf.h5",), "ffrf_h5", "read", "write"),
    Format("mbdyn", (".fem",), "mbdyn", "read", "write"),
    Format("meshio", (".vtk", ".xdmf", ".xmf", ".med", ".msh"), "meshio_modes"),
    Format("vtu", (".vtu",), "meshio_modes", "read", "write"),  # meshio's VTU, which it also writes
    Format("nastran", (".op2",), "nastran"),
)}


def formats() -> list[Format]:
    return list(_FORMATS.values())


def format_of(path: str | os.PathLike, name: str | None = None) -> Format:
    """The format named ``name``, or the one whose suffix ends the file name (longest match)."""
    if name is not None:
        if name not in _FORMATS:
            raise FFRFError(f"unknown format {name!r}; known: {', '.join(_FORMATS)}")
        return _FORMATS[name]
    fname = os.fspath(path).lower()
    matches = [(len(s), f) for f in _FORMATS.values() for s in f.suffixes if fname.endswith(s)]
    if not matches:
        known = ", ".join(s for f in _FORMATS.values() for s in f.suffixes)
        raise FFRFError(f"{path}: unknown file type; known suffixes: {known}")
    return max(matches, key=lambda m: m[0])[1]


# What a reader may raise on input it did not foresee (corrupt, truncated or hostile files).
UNFORESEEN = (OSError, ValueError, KeyError, IndexError, TypeError, RuntimeError, EOFError, OverflowError,
              ArithmeticError, AttributeError, LookupError, RecursionError)  # not MemoryError: a bug to find


MESH, ANSYS = ("meshio", "vtu"), ("ansys",)
READER_OPTIONS = {"eigenvalues": MESH, "density": MESH, "young": MESH, "poisson": MESH, "units": ANSYS}
WHERE = {MESH: "meshio meshes", ANSYS: "ANSYS results (.rst)"}


def check_reader_options(path, options: dict, fmt: str | None = None) -> None:
    """Reader options apply to their formats only (--eigenvalues, --density, --young, --poisson to meshio
    meshes, --units to ANSYS results): one line otherwise."""
    name = format_of(path, fmt).name
    wrong = [o for o in options if name not in READER_OPTIONS[o]]
    if wrong:
        raise FFRFError(f"{path}: --{'/--'.join(wrong)} apply to {WHERE[READER_OPTIONS[wrong[0]]]} only")


CHECKS_ITSELF = ("calculix", "meshio", "vtu")  # readers that call consistency.checked with what only they see


def read_body(path: str | os.PathLike, fmt: str | None = None, **options) -> FlexibleBody:
    """Read a body from any registered format.

    Readers name the field of every failure they foresee; anything else a
    damaged file provokes still ends as the project's one-line error.
    """
    f = format_of(path, fmt)
    note_input(path)
    if not os.path.isfile(path):
        kind = ("a directory" if os.path.isdir(path) else "a special file (device, FIFO or socket)"
                if os.path.exists(path) else "not found")
        raise BodyFileError(path, "file", "an existing regular file", kind)
    try:
        body = f.read(path, **options)
    except FFRFError:
        raise
    except MemoryError as e:  # the reading child's address-space limit (io.guard)
        raise BodyFileError(path, "memory", f"a body that fits the memory limit of "
                            f"{limits.human(limits.max_bytes())} (--max-memory or {limits.ENV})",
                            str(e) or "more") from None
    except UNFORESEEN as e:
        raise BodyFileError(path, "file", f"a readable {f.name} file",
                            f"{type(e).__name__}: {str(e)[:160]}") from None
    body = flexible_modes_in_order(physically_possible(in_range(body, path), path), path)
    if body.fe is not None and f.name not in CHECKS_ITSELF:
        from ..consistency import checked
        checked(body, path, assemble=f.name != "ffrf-h5")
    return body


LARGEST = 1e150  # |value| above which products of two numbers (inertia, energies) overflow


def in_range(body: FlexibleBody, path) -> FlexibleBody:
    """Every number of the body finite and below LARGEST in magnitude, I0 too: the analysis multiplies
    them (theory sections 3, 7), so 1e300 in a file would turn into NaN far from the file."""
    J = body.integrals
    fields = {"invariants mass": J.mass, "invariants first_moment": J.first_moment, "invariants I": J.I,
              "invariants Ibar": J.Ibar, "invariants Sbar": J.Sbar, "invariants mode_sum": J.mode_sum,
              "invariants spin": J.spin, "eigenvalues": body.eigenvalues, "stress max": body.sigma_max,
              "geometric stiffness": body.geometric}
    if body.static_centrifugal is not None:
        fields.update({"static_centrifugal compliance": body.static_centrifugal.compliance,
                       "static_centrifugal sigma": body.static_centrifugal.sigma})
    for name, value in fields.items():
        if value is not None and not np.all(np.abs(value) < LARGEST):
            raise BodyFileError(path, name, f"finite numbers below {LARGEST:.0e} in magnitude")
    if not np.all(np.abs(body.I0) < LARGEST):
        raise BodyFileError(path, "invariants I", "an inertia tensor I0 about the CoM that is finite",
                            "overflow (from the first moment and I)")
    return body


RIGID_SHARE = 1e-10  # of the largest eigenvalue: below it a mode is rigid (as the Nastran reader separates them)
TRIANGLE = 1e-6  # of trace I0: a thin plate has I3 = I1 + I2 up to its file's rounding


def physically_possible(body: FlexibleBody, path) -> FlexibleBody:
    """A body that can exist, whatever a file cached (theory 2-4): positive mass, and I0 about the CoM positive
    definite with each principal moment at most the sum of the other two (so the rigid-body mass matrix is
    positive definite); an indefinite nodal mass shows in them."""
    if not body.mass > 0:
        raise BodyFileError(path, "invariants mass", "a positive mass", f"{body.mass:.6g}")
    moments = np.linalg.eigvalsh(0.5 * (body.I0 + body.I0.T))
    if moments[0] <= 0 or moments[2] > moments[0] + moments[1] + TRIANGLE * moments.sum():
        raise BodyFileError(path, "invariants I", "an inertia tensor I0 about the CoM that is positive definite "
                            "with each principal moment at most the sum of the other two",
                            "principal moments " + ", ".join(f"{x:.6g}" for x in moments))
    return body


def flexible_modes_in_order(body: FlexibleBody, path) -> FlexibleBody:
    """At least one mode, eigenvalues finite and positive (flexible modes only, theory section 1); unsorted
    modes are sorted by eigenvalue, with every per-mode quantity, and the provenance says so."""
    lam = np.asarray(body.eigenvalues)
    if body.nf == 0:
        raise BodyFileError(path, "eigenvalues", "at least one flexible mode", "none")
    bad = np.flatnonzero(~np.isfinite(lam) | (lam < 1 / LARGEST))
    if bad.size:
        raise BodyFileError(path, "eigenvalues", f"finite positive values from {1 / LARGEST:.0e} (flexible modes only)",
                            f"{lam[bad[0]]:.6g} for mode {bad[0] + 1}")
    soft = np.flatnonzero(lam < RIGID_SHARE * lam.max())
    if soft.size:
        p = soft[0]
        raise BodyFileError(path, "eigenvalues", f"flexible modes above {RIGID_SHARE:g} of the largest eigenvalue",
                            f"{lam[p]:.6g} for mode {p + 1} ({np.sqrt(lam[p]) / (2 * np.pi):.3g} cycles per time "
                            "unit): a nearly rigid mode; leave rigid modes out of the file")
    order = np.argsort(lam, kind="stable")
    if np.any(order != np.arange(body.nf)):
        body = body.with_modes(order)
        body = replace(body, provenance=body.provenance.with_note(
            "modes sorted by eigenvalue on reading (the file's order was " + " ".join(str(i + 1) for i in order) + ")"))
    return body


def sha256(path: str | os.PathLike) -> str:
    """The SHA-256 of a file, read in 1 MiB pieces (reports and trajectories name the body file by it)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def write_body(body: FlexibleBody, path: str | os.PathLike, fmt: str | None = None,
               overwrite: bool = False, **options) -> None:
    """Write a body atomically to any registered format that has a writer."""
    f = format_of(path, fmt)
    if f.write is None:
        raise FFRFError(f"{path}: format {f.name} can be read but not written")
    f.write(body, path, overwrite=overwrite, **options)


from . import limits  # noqa: E402

__all__ = ["Format", "formats", "format_of", "check_reader_options", "read_body", "write_body", "limits"]
