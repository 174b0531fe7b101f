"""Figures of a verification (PNG and SVG): trajectories, work-precision chart, drift, Campbell diagram.

They read results (verify.runner, verify.workprecision, sim.linearise); they compute nothing but what
they draw.
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..io.atomic import atomic_path  # noqa: E402
from ..sim.model import N_ROT  # noqa: E402

FORMATS = ("png", "svg")


def save(fig, directory: Path, stem: str) -> list[Path]:
    """Write ``stem.png`` and ``stem.svg`` into ``directory`` atomically; returns the paths."""
    paths = []
    for fmt in FORMATS:
        path = Path(directory) / f"{stem}.{fmt}"
        with atomic_path(path, overwrite=True) as tmp:
            fig.savefig(tmp, dpi=110, format=fmt, bbox_inches="tight")
        paths.append(path)
    plt.close(fig)
    return paths


def trajectories(ref_run, runs: dict, sigma, time_unit: str, stress_unit: str, title: str):
    """Spin rate |w|, first modal coordinate and recovered stress of the reference and each set against time."""
    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    nf = (ref_run.y.shape[1] - N_ROT) // 2
    weights = np.ones(nf) if sigma is None else np.asarray(sigma)
    for label, run, style in [("reference", ref_run, dict(color="k", lw=2.5, alpha=0.5))] + [
            (k, r, dict(lw=1)) for k, r in runs.items()]:
        if len(run.t) == 0:
            continue
        y = run.y
        axes[0].plot(run.t, np.linalg.norm(y[:, 4:7], axis=1), label=label, **style)
        axes[1].plot(run.t, y[:, N_ROT], label=label, **style)
        axes[2].plot(run.t, np.abs(y[:, N_ROT:N_ROT + nf]) @ weights, label=label, **style)
    axes[0].set_ylabel(f"|w| [rad/{time_unit}]")
    axes[1].set_ylabel("q1 [body units]")
    axes[2].set_ylabel("sum sigma_p |q_p|" + (f" [{stress_unit}]" if sigma is not None else " [body units]"))
    axes[2].set_xlabel(f"t [{time_unit}]")
    axes[0].set_title(title)
    axes[0].legend(fontsize=7, ncol=3)
    return fig


def work_precision_chart(points, front, title: str):
    """log error against log wall time, one line per (set, integrator); Pareto front and failed runs marked."""
    fig, ax = plt.subplots(figsize=(8, 6))
    finite = [p.error for p in points if not p.failed and p.error > 0]
    top = 10 * max(finite) if finite else 1.0
    floor = 1e-16
    groups = {}
    for p in points:
        groups.setdefault((p.set, p.integrator), []).append(p)
    markers = {"dop853": "o", "rk4": "s", "midpoint": "^"}
    for (label, integ), pts in groups.items():
        ok = sorted((p for p in pts if not p.failed), key=lambda p: p.wall_s)
        line, = ax.plot([p.wall_s for p in ok], [max(p.error, floor) for p in ok], marker=markers.get(integ, "o"),
                        ms=4, lw=1, label=f"{label}, {integ}")
        bad = [p for p in pts if p.failed]
        if bad:
            ax.plot([p.wall_s for p in bad], [top] * len(bad), "x", color=line.get_color(), ms=8)
    ax.plot([p.wall_s for p in front], [max(p.error, floor) for p in front], "-", color="k", lw=3, alpha=0.25,
            label="Pareto front")
    ax.axhline(top, color="r", lw=0.5, ls=":")
    ax.text(ax.get_xlim()[0] if points else 0, top, " failed (x)", color="r", va="bottom", fontsize=7)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time [s] (minimum over repeats, serial)")
    ax.set_ylabel("worst relative error against the reference [-]")
    ax.set_title(title)
    ax.legend(fontsize=6, ncol=2)
    return fig


def drift_chart(curves: dict, time_unit: str, title: str):
    """Relative energy drift |E(t) - E0| / |E0| of each set against time (log scale)."""
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for label, (t, drift) in curves.items():
        ax.plot(t, np.maximum(drift, 1e-17), label=label, lw=1)
    ax.set_yscale("log")
    ax.set_xlabel(f"t [{time_unit}]")
    ax.set_ylabel("|E - E0| / |E0| [-]")
    ax.set_title(title)
    ax.legend(fontsize=7)
    return fig


def campbell_chart(speeds, by_axis: dict, s_crit, freq_unit: str, speed_unit: str):
    """Flexible frequencies against spin about each principal axis, one colour per term set; s_crit marked."""
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.5), sharey=True)
    for k, ax in enumerate(axes):
        for i, (label, freqs) in enumerate(by_axis[k].items()):
            ax.plot(speeds[k], freqs, color=f"C{i}", lw=1, label=label)
        if s_crit is not None and np.isfinite(s_crit[k]):
            ax.axvline(s_crit[k], color="r", ls="--", lw=1)
            ax.text(s_crit[k], ax.get_ylim()[1] * 0.95, " s_crit", color="r", fontsize=7, va="top")
        ax.set_xlabel(f"spin about axis {k + 1} [rad/{speed_unit}]")
        ax.set_title(f"axis {k + 1}")
    axes[0].set_ylabel(f"frequency [1/{freq_unit}]")
    handles, labels = axes[0].get_legend_handles_labels()
    unique = dict(zip(labels, handles))
    axes[0].legend(unique.values(), unique.keys(), fontsize=7)
    return fig


def stability_chart(stab: dict, time_unit: str, title: str):
    """Left: energy drift against the RK4 step (full set and level II). Right: each stability number measured
    by simulation over its prediction (1 = theory confirmed)."""
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2), layout="constrained")
    for label, rows in stab["drift_against_step"].items():
        steps = [r["step"] for r in rows]
        left.plot(steps, [max(r["energy_drift"] or 0.0, 1e-17) for r in rows], marker="o", label=label)
    left.set_xscale("log")
    left.set_yscale("log")
    left.set_xlabel(f"RK4 step [{time_unit}]")
    left.set_ylabel("energy drift |E - E0| / |E0| [-]")
    left.legend(fontsize=7)
    names, ratios = [], []
    for key, label in (("rk4_limit_rest", "RK4 limit at rest"), ("rk4_limit_spin", "RK4 limit spinning"),
                       ("euler_growth", "Euler growth / step")):
        names.append(label)
        ratios.append(stab[key].measured / stab[key].predicted)
    onset = stab["divergence_onset"]
    if onset is not None:
        names.append("divergence speed / s_crit")
        ratios.append(onset.measured / onset.s_crit)
    imp = stab["implicit"]
    if np.isfinite(imp.phase_error) and imp.predicted > 0:
        names.append("midpoint phase error")
        ratios.append(imp.phase_error / imp.predicted)
    right.barh(names, ratios, color="C0")
    right.axvline(1.0, color="k", lw=1)
    right.set_xlabel("measured / predicted [-]")
    fig.suptitle(title)
    return fig
