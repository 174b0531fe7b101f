"""Adams-style invariants files ``.ffinv.json`` and ``.ffinv.h5`` (docs/format.md, adams_invariants.md section 5).

Both carry the same keys: JSON as nested lists, HDF5 as datasets (arrays),
root attributes (scalars and strings) and groups with attributes (the
dictionaries units, frame, conventions, provenance).
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import replace

import numpy as np

from .. import __version__
from ..adams import SIGNS, from_adams, to_adams, w3_from_I9
from ..body import MASS_KINDS, FlexibleBody, Provenance
from ..errors import BodyFileError
from ..units import LENGTH, MASS, TIME, Units, UnitsError
from ..values import is_number
from .atomic import atomic_path
from . import guard
from .limits import Budget, check_file_size, check_hdf5_references

h5py = guard.lazy_module("h5py")  # loaded at first use: in the children, in the tool only meanwhile (guard)

FORMAT_NAME = "ffrf_advisor.invariants"
VERSION = 1
DICTS = ("units", "frame", "conventions", "provenance")
TOL = {"symmetry": 1e-8, "I6": 1e-3, "I9": 1e-8, "W3": 1e-6, "frequency": 1e-9}
STRESS_ALIASES = {"MPa": "N/mm^2", "N/mm2": "N/mm^2", "Pa": "N/m^2", "N/m2": "N/m^2"}


def _shapes(nf: int) -> dict[str, tuple]:
    return {"I1": (), "I2": (3,), "I3": (3, nf), "I4": (3, nf), "I5": (nf, 3, nf), "I6": (nf, nf),
            "I7": (3, 3), "I8": (nf, 3, 3), "I9": (nf, nf, 3, 3), "nodal_rotary_inertia_sum": (3, 3),
            "rotary_I4": (3, nf), "rotary_I6": (nf, nf),
            "eigenvalues": (nf,), "frequencies_hz": (nf,), "generalized_stiffness": (nf, nf),
            "max_von_mises": (nf,), "max_von_mises_node": (nf,), "mode_ids": (nf,)}


REQUIRED = ("format", "version", "units", "frame", "conventions", "n_modes", "I1", "I2", "I7", "I8")


# ---------------------------------------------------------------- writing
def document(body: FlexibleBody, I8_sign: str = "adams") -> dict:
    """The invariants file content of ``body`` (its CoM principal frame, Adams conventions)."""
    u = body.units
    doc = {
        "format": FORMAT_NAME, "version": VERSION,
        "units": {"length": u.length, "mass": u.mass, "time": u.time, "force": u.force,
                  "stress": u.stress, "angle": "rad"},
        "frame": {"origin": "cm", "axes": "principal"},
        "conventions": {"skew": "a~b=axb", "I8_sign": I8_sign, "I9_order": "I9[j][k]=sum m Phi~_j Phi~_k",
                        "mode_normalisation": "mass"},
        "name": body.name,
        "n_modes": body.nf,
        **to_adams(body.integrals, I8_sign),
        "eigenvalues": body.eigenvalues,
        "frequencies_hz": body.frequencies_hz,
        "provenance": {"source": body.provenance.source, "tool": f"ffrf_advisor {__version__}",
                       "fe_mass": body.provenance.mass_matrix, "notes": "\n".join(body.provenance.notes),
                       **({} if body.provenance.digits is None else {"digits": body.provenance.digits})},
    }
    if body.sigma_max is not None:
        doc["max_von_mises"] = body.sigma_max
    return doc


def _jsonable(x):
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, np.ndarray):
        return x.tolist()
    return x


def write_json(body: FlexibleBody, path, overwrite: bool = False, I8_sign: str = "adams") -> None:
    with atomic_path(path, overwrite) as tmp:
        tmp.write_text(json.dumps(_jsonable(document(body, I8_sign)), indent=1) + "\n")


def write_h5(body: FlexibleBody, path, overwrite: bool = False, I8_sign: str = "adams") -> None:
    """The HDF5 library writes in a child (``guard.run_writer``: a failed write makes it crash on cleanup)."""
    with atomic_path(path, overwrite) as tmp:
        guard.run_writer(path, _write_h5_file, document(body, I8_sign), tmp)


def _write_h5_file(doc: dict, tmp) -> None:
    with h5py.File(tmp, "w", libver=("earliest", "v110")) as f:
        for key, value in doc.items():
            if key in DICTS:
                g = f.create_group(key)
                for k, v in value.items():
                    g.attrs[k] = v
            elif isinstance(value, np.ndarray) and value.ndim:
                f.create_dataset(key, data=value, track_times=False)
            else:
                f.attrs[key] = value


# ---------------------------------------------------------------- reading
class DuplicateKey(ValueError):
    pass


def _unique_keys(pairs: list) -> dict:
    """A JSON object whose keys are unique (json would keep the last of two silently)."""
    keys = [k for k, _ in pairs]
    seen = set()
    for k in keys:
        if k in seen:
            raise DuplicateKey(f"duplicate key {k!r}")
        seen.add(k)
    return dict(pairs)


JSON_FACTOR = 4  # bytes of parsed lists and arrays per byte of JSON text (floats of ~20 characters)


def _load_json(path) -> dict:
    check_file_size(path, JSON_FACTOR)
    try:
        with open(path, encoding="utf-8") as fh:
            doc = json.load(fh, parse_constant=lambda c: math.nan, object_pairs_hook=_unique_keys)
    except DuplicateKey as e:
        raise BodyFileError(path, "file", "a JSON object with unique keys", str(e)) from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, RecursionError) as e:
        raise BodyFileError(path, "file", "a readable JSON invariants file", type(e).__name__ + f": {e}") from None
    if not isinstance(doc, dict):
        raise BodyFileError(path, "file", "a JSON object at the top level", type(doc).__name__)
    return doc


def _load_h5(path) -> dict:
    def plain(v):
        return v.decode() if isinstance(v, bytes) else (v.item() if isinstance(v, np.generic) else v)
    budget = Budget(path)
    try:
        with h5py.File(path, "r") as f:
            check_hdf5_references(path, f)
            doc = {k: plain(v) for k, v in f.attrs.items()}
            for key, obj in f.items():
                if isinstance(obj, h5py.Group):
                    doc[key] = {k: plain(v) for k, v in obj.attrs.items()}
                else:
                    budget.take(key, 2.0 * obj.size * max(obj.dtype.itemsize, 8))
                    doc[key] = obj[()]
    except (OSError, KeyError, ValueError, TypeError) as e:
        raise BodyFileError(path, "file", "a readable HDF5 invariants file", f"{type(e).__name__}: {e}") from None
    return doc


class _Doc:
    """Validated access to one parsed file; every failure names the key."""

    def __init__(self, path, doc: dict):
        self.path, self.doc = path, doc

    def fail(self, key: str, expected: str, got: str | None = None):
        raise BodyFileError(self.path, key, expected, got)

    def text(self, group: str, key: str, allowed=None) -> str:
        d = self.doc.get(group)
        if not isinstance(d, dict) or key not in d:
            self.fail(f"{group}.{key}", "a string" + (f" out of {', '.join(allowed)}" if allowed else ""), "missing")
        value = d[key]
        if not isinstance(value, str) or (allowed and value not in allowed):
            self.fail(f"{group}.{key}", f"one of {', '.join(allowed)}" if allowed else "a string", repr(value))
        return value

    def array(self, key: str, shape: tuple) -> np.ndarray:
        """Numbers (values.is_number: a bool, string or object is none) of ``shape``, finite."""
        try:
            if not _numbers(self.doc[key]):
                raise TypeError
            a = np.asarray(self.doc[key], dtype=float)
        except (ValueError, TypeError):
            self.fail(key, f"numbers of shape {shape}", "non-numeric or ragged data (a bool, text or object)")
        if a.shape != shape:
            self.fail(key, f"shape {shape}", str(a.shape))
        if not np.all(np.isfinite(a)):
            self.fail(key, "finite numbers", "NaN or inf")
        return a


def _numbers(value) -> bool:
    """A number, a list of them (nested) or a numeric array (an HDF5 dataset); NaN and inf pass here."""
    if isinstance(value, np.ndarray):
        return value.dtype.kind in "fiu"
    if isinstance(value, list):
        return all(_numbers(v) for v in value)
    return isinstance(value, float) or is_number(value)


def _units(d: _Doc) -> Units:
    mass = d.text("units", "mass", tuple(MASS))
    length = d.text("units", "length", tuple(LENGTH))
    time = d.text("units", "time", tuple(TIME))
    units = Units(mass, length, time)
    try:
        stress_unit = units.stress
    except UnitsError as e:
        d.fail("units", "a consistent unit system with a named force unit", str(e))
    stress = d.doc["units"].get("stress")
    if stress is not None and STRESS_ALIASES.get(stress, stress) != stress_unit:
        d.fail("units.stress", f"{stress_unit} (consistent with {mass}, {length}, {time})", repr(stress))
    return units


def _check_header(d: _Doc) -> int:
    for key in REQUIRED:
        if key not in d.doc:
            d.fail(key, "a value (required key)", "missing")
    if d.doc["format"] != FORMAT_NAME:
        d.fail("format", repr(FORMAT_NAME), repr(d.doc["format"]))
    if not is_number(d.doc["version"], integer=True) or d.doc["version"] != VERSION:
        d.fail("version", str(VERSION), repr(d.doc["version"]))
    nf = d.doc["n_modes"]
    if not is_number(nf, integer=True) or not 0 < nf <= 10000:
        d.fail("n_modes", "a positive integer (at most 10000)", repr(nf))
    return int(nf)


def _eigenvalues(d: _Doc, nf: int) -> np.ndarray:
    lam = d.array("eigenvalues", (nf,)) if "eigenvalues" in d.doc else None
    if lam is not None and np.any(lam <= 0):
        d.fail("eigenvalues", "positive flexible eigenvalues (rigid modes removed)")
    if "frequencies_hz" in d.doc:
        from_f = (2 * np.pi * d.array("frequencies_hz", (nf,))) ** 2
        if lam is None:
            lam = from_f
        elif np.abs(from_f - lam).max() > TOL["frequency"] * np.abs(lam).max():
            d.fail("frequencies_hz", "(2 pi f)^2 equal to eigenvalues within 1e-9")
    if lam is None:
        d.fail("eigenvalues", "eigenvalues or frequencies_hz (required)", "missing")
    if np.any(lam <= 0):
        d.fail("frequencies_hz", "positive flexible frequencies (rigid modes removed)")
    return lam


def _invariants(d: _Doc, nf: int) -> dict[str, np.ndarray]:
    shapes = _shapes(nf)
    inv = {k: d.array(k, shapes[k]) for k in ("I1", "I2", "I3", "I4", "I5", "I6", "I7", "I8", "I9",
                                              "nodal_rotary_inertia_sum", "rotary_I4", "rotary_I6") if k in d.doc}
    if ("rotary_I4" in inv or "rotary_I6" in inv) and "nodal_rotary_inertia_sum" not in inv:
        d.fail("nodal_rotary_inertia_sum", "present with rotary_I4 and rotary_I6 (theory 3b)", "missing")
    if inv["I1"] <= 0:
        d.fail("I1", "a positive mass", str(float(inv["I1"])))
    scale = np.abs(inv["I7"]).max()
    if np.abs(inv["I7"] - inv["I7"].T).max() > TOL["symmetry"] * scale:
        d.fail("I7", "a symmetric 3x3 inertia tensor")
    if "I6" in inv and np.abs(inv["I6"] - np.eye(nf)).max() > TOL["I6"]:
        d.fail("I6", f"the identity within {TOL['I6']:g} (mass-normalised modes)",
               f"max |I6 - I| = {np.abs(inv['I6'] - np.eye(nf)).max():.3g}")
    if "I9" in inv:
        I9 = inv["I9"]
        if np.abs(I9 - np.swapaxes(np.swapaxes(I9, 0, 1), 2, 3)).max() > TOL["I9"] * max(np.abs(I9).max(), 1):
            d.fail("I9", "I9[j][k] equal to I9[k][j] transposed (Adams order)")
        modal_mass = -0.5 * np.einsum("ijkk->ij", I9) + inv.get("rotary_I6", 0.0)
        if np.abs(modal_mass - inv.get("I6", np.eye(nf))).max() > TOL["I6"]:
            d.fail("I9", "-1/2 trace I9[i][j] (+ rotary_I6) equal to I6 (else a wrong I9 order or sign, or rotary "
                         "inertia not given apart)")
        if "I5" in inv and np.abs(w3_from_I9(I9) - np.einsum("jai->aji", inv["I5"])).max() > \
                TOL["W3"] * max(np.abs(inv["I5"]).max(), 1):
            d.fail("I5", "W3 from I5 equal to W3 from I9 (else an I5 index swap)")
    return inv



def _provenance(d: _Doc, path, inv: dict) -> Provenance:
    """The file's provenance block (optional), plus which of I5 and I9 it carries."""
    prov = d.doc.get("provenance") if isinstance(d.doc.get("provenance"), dict) else {}
    fe_mass = prov.get("fe_mass", "unknown")
    if fe_mass not in MASS_KINDS:
        d.fail("provenance.fe_mass", f"one of {', '.join(MASS_KINDS)}", repr(fe_mass))
    notes = [n for n in str(prov.get("notes", "")).split("\n") if n]
    if "I9" not in inv:
        notes.append("no I9 in the file: W2 (quadratic inertia change, centrifugal softening) not evaluable"
                     + ("" if "I5" in inv else "; no I5 either: W3 (coupling, Coriolis ratio) not evaluable"))
    carried = ", ".join(k for k in ("I5", "I9") if k in inv) or "without I5, I9"
    digits = prov.get("digits")
    if digits is not None:
        if not is_number(digits, integer=True) or not 1 <= digits <= 17:
            d.fail("provenance.digits", "a whole number of significant digits from 1 to 17", repr(digits))
        digits = int(digits)
    return Provenance(source=str(prov.get("source") or path), mass_matrix=fe_mass,
                      method=f"Adams-style invariants I1..I9 ({carried})", notes=tuple(notes), digits=digits)


def body_from_document(path, doc: dict) -> FlexibleBody:
    d = _Doc(path, doc)
    nf = _check_header(d)
    units = _units(d)
    origin = d.text("frame", "origin", ("cm", "lbrf"))
    axes = d.text("frame", "axes", ("principal", "lbrf"))
    sign = d.text("conventions", "I8_sign", SIGNS)
    d.text("conventions", "mode_normalisation", ("mass",))
    inv = _invariants(d, nf)
    sigma = d.array("max_von_mises", (nf,)) if "max_von_mises" in doc else None
    if sigma is not None and np.any(sigma < 0):
        d.fail("max_von_mises", "non-negative stresses")
    name = doc.get("name", os.path.basename(str(path)).split(".")[0])
    if not isinstance(name, str) or not name.strip():
        d.fail("name", "a non-empty text (the body's name)", repr(name)[:80])
    body = FlexibleBody(name=name, integrals=from_adams(inv, nf, sign),
                        eigenvalues=_eigenvalues(d, nf), units=units, sigma_max=sigma,
                        provenance=_provenance(d, path, inv))
    if (origin, axes) != ("cm", "principal"):
        body = body.moved_to_principal_frame()
    return body


def read_json(path, load_fe: bool = False) -> FlexibleBody:
    return body_from_document(path, _load_json(path))


def read_h5(path, load_fe: bool = False) -> FlexibleBody:
    return body_from_document(path, guard.run(path, "the HDF5 library", _load_h5, path))
