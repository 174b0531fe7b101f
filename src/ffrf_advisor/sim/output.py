"""What a simulation run reports: the trajectory table (CSV or HDF5) and the JSON summary (docs/simulate.md)."""
from __future__ import annotations

import csv
from pathlib import Path

import h5py
import numpy as np

from ..errors import FFRFError
from ..units import Units
from ..io.atomic import atomic_path, check_target
from ..io.guard import run_writer
from .equations import angular_momentum, energy
from .integrate import Run
from .model import N_ROT, Model

SUMMARY_SCHEMA_VERSION = 1


def columns(nf: int, units: Units) -> list[str]:
    """``t, wx, wy, wz, p0..p3, q1..qn, qd1..qdn, energy, H``, each with its unit in the body's units: the
    modal coordinates of mass-normalised modes in sqrt(mass) length."""
    t, q = units.time, f"sqrt({units.mass}) {units.length}"
    return ([f"t [{t}]"] + [f"w{c} [rad/{t}]" for c in "xyz"] + [f"p{i} [-]" for i in range(4)]
            + [f"q{i + 1} [{q}]" for i in range(nf)] + [f"qd{i + 1} [{q}/{t}]" for i in range(nf)]
            + [f"energy [{units.force} {units.length}]", f"H [{units.mass} {units.length}^2/{t}]"])


def table(model: Model, run: Run) -> np.ndarray:
    """One row per sample in the order of ``columns``."""
    y = run.y
    E, H = energy(model, np.asarray(y)), angular_momentum(model, np.asarray(y))
    return np.column_stack([run.t, y[:, 4:7], y[:, :4], y[:, N_ROT:], E, H])


def check_output(path: Path, force: bool = False) -> None:
    """Fail early: a .csv or .h5 name that may be written (io.atomic.check_target)."""
    if Path(path).suffix.lower() not in (".csv", ".h5"):
        raise FFRFError(f"{path}: output: expected a .csv or .h5 file")
    check_target(path, force)


def write_trajectory(path: Path, model: Model, run: Run, units: Units, about: dict, force: bool = False) -> None:
    """``.csv`` (header row with units) or ``.h5`` (dataset ``trajectory`` with attribute ``columns``; file
    attributes: ``about`` (the body's name, file and SHA-256), units, terms, integrator, step and the initial
    state, the first row), atomically."""
    check_output(path, force)
    suffix = Path(path).suffix.lower()
    data, names = table(model, run), columns(model.nf, units)
    with atomic_path(path, overwrite=force) as tmp:
        if suffix == ".csv":
            with open(tmp, "w", newline="") as fh:
                writer = csv.writer(fh)
                writer.writerow(names)
                writer.writerows([[repr(float(x)) for x in row] for row in data])
        else:  # the HDF5 library in a child: a failed write makes it crash on cleanup (guard.run_writer)
            attrs = {**about, "units": str(units), "terms": ",".join(model.terms), "integrator": run.method,
                     "step": np.nan if run.step is None else float(run.step)}
            run_writer(path, _write_h5, tmp, data, names, attrs)


def _write_h5(tmp: Path, data: np.ndarray, names: list[str], attrs: dict) -> None:
    with h5py.File(tmp, "w") as fh:
        ds = fh.create_dataset("trajectory", data=data)
        ds.attrs["columns"] = ",".join(names)
        fh.attrs.update(attrs)
        if len(data):
            fh.attrs["initial_state"] = data[0]


def _drift(values: np.ndarray) -> float | None:
    """Largest |x - x0| / |x0| over the samples (None when x0 vanishes)."""
    if len(values) == 0 or values[0] == 0:
        return None
    return float(np.abs(values - values[0]).max() / abs(values[0]))


def summary(model: Model, run: Run, units: str) -> dict:
    """The JSON summary of ``simulate --json`` (docs/simulate.md)."""
    E, H = energy(model, run.y), angular_momentum(model, run.y)
    p_norm = np.linalg.norm(run.y[:, :4], axis=1) if len(run.y) else np.ones(1)
    return {
        "schema_version": SUMMARY_SCHEMA_VERSION,
        "units": units,
        "terms": list(model.terms),
        "lagrangian": model.lagrangian,
        "integrator": run.method,
        "step": None if run.step is None else float(run.step),
        "t_end": float(run.t[-1]) if len(run.t) else 0.0,
        "samples": len(run.t),
        "steps": int(run.steps),
        "rhs_evaluations": int(run.nfev),
        "wall_s": run.wall_s,
        "energy_drift": _drift(E),
        "H_drift": _drift(H),
        "quaternion_norm_drift": float(np.abs(p_norm - 1).max()),
        "failed": run.failed,
        "t_fail": run.t_fail,
        "reason": run.reason,
    }
