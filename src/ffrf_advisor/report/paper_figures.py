"""The guideline paper's figures for one body or a set (one series per body), a Campbell diagram, and the
mesh with its first modes at q_max. Each function takes analyses and returns a matplotlib Figure; it
computes nothing the advisor has not (theory sections 6, 7, 9), except the Campbell frequencies (sim).
"""
from __future__ import annotations

import re

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..analysis import Analysis  # noqa: E402
from ..situation import THRESHOLDS  # noqa: E402
from ..sim.linearise import campbell, campbell_speeds  # noqa: E402
from ..sim.model import build_model  # noqa: E402
from ..terms import FULL  # noqa: E402
from ..units import TIME  # noqa: E402
from .figures import modes_figure  # noqa: E402
from .verify_figures import campbell_chart  # noqa: E402

PAPER_MODES = 10  # the paper plots the first ten modes
CAMPBELL_POINTS = 41  # as in verify: about 5 ms a linearisation, 2 x 3 x 41 of them
MARKERS = "os^vDP*Xhp"
AXES = ("axis 1", "axis 2", "axis 3")


def label(text: str) -> str:
    """A body name as a figure label: printable characters a figure file cannot misread, 40 at most."""
    return re.sub(r"[^\w .,:()+=/\[\]-]", "?", str(text)).replace("--", "-")[:40]


def _modes(a: Analysis) -> np.ndarray:
    return np.arange(1, min(PAPER_MODES, a.body.nf) + 1)


def _per_mode(analyses: list[Analysis], values, ylabel: str, title: str, log: bool = True):
    fig, ax = plt.subplots(figsize=(7, 4))
    for i, a in enumerate(analyses):
        p = _modes(a)
        v = values(a)
        if v is not None:
            ax.plot(p, np.asarray(v)[:len(p)], marker=MARKERS[i % len(MARKERS)], lw=1, label=label(a.body.name))
    if log:
        ax.set_yscale("log")
    ax.set_xlabel("mode")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    if ax.lines:
        ax.legend(fontsize=7)
    else:
        ax.text(0.5, 0.5, "not carried by the body file", ha="center", transform=ax.transAxes)
    return fig


def frequencies(analyses: list[Analysis]):
    """Eigenfrequencies of the first ten modes (guideline paper Fig. 3)."""
    unit = analyses[0].body.units.frequency
    return _per_mode(analyses, lambda a: a.body.frequencies_hz, f"f [{unit}]", "Eigenfrequencies (paper Fig. 3)")


def stresses(analyses: list[Analysis]):
    """Largest von Mises stress of each mode at q = 1 (paper Fig. 5)."""
    unit = analyses[0].body.units.stress
    return _per_mode(analyses, lambda a: a.body.sigma_max, f"sigma_vM,max at q = 1 [{unit}]",
                     "Maximum von Mises stress per mode (paper Fig. 5)")


def q_max(analyses: list[Analysis]):
    """q_max per mode (paper Fig. 7), each point marked by the criterion that governs it (theory 6)."""
    fig, ax = plt.subplots(figsize=(7, 4))
    kinds = sorted({g for a in analyses for g in a.amplitudes.governs[:PAPER_MODES]})
    for i, a in enumerate(analyses):
        p = _modes(a)
        q = a.amplitudes.q_max[:len(p)]
        line, = ax.plot(p, q, lw=1, label=label(a.body.name))
        for k, kind in enumerate(kinds):
            mask = np.array([g == kind for g in a.amplitudes.governs[:len(p)]])
            ax.plot(p[mask], q[mask], MARKERS[k % len(MARKERS)], color=line.get_color(), ms=5,
                    label=f"governed by {kind}" if i == 0 else None)
    ax.set_yscale("log")
    ax.set_xlabel("mode")
    ax.set_ylabel(f"q_max [sqrt({analyses[0].body.units.mass}) {analyses[0].body.units.length}]")
    ax.set_title("Maximum modal coordinates (paper Fig. 7); marker: governing criterion")
    ax.legend(fontsize=7)
    return fig


def _axes_panel(ax, analyses, name: str, threshold: float | None) -> None:
    for i, a in enumerate(analyses):
        values = getattr(a.significance, name)
        if values is None:
            continue
        p = _modes(a)
        rows = [values] if values.ndim == 1 else values
        for k, row in enumerate(rows):
            ax.plot(p, np.maximum(row[:len(p)], 1e-16), marker=MARKERS[k], lw=0.8, ms=4, color=f"C{i}",
                    label=f"{label(a.body.name)}" + (f", {AXES[k]}" if values.ndim > 1 else ""))
    if threshold is not None:
        ax.axhline(threshold, color="r", ls="--", lw=1, label=f"threshold {threshold:g}")
    ax.set_yscale("log")
    ax.set_xlabel("mode")
    ax.set_ylabel(f"{name} [-]")
    if any(line.get_label() and not line.get_label().startswith("threshold") for line in ax.lines):
        ax.legend(fontsize=6, ncol=2)
    else:
        ax.text(0.5, 0.5, "not evaluable: invariants missing", ha="center", transform=ax.transAxes)


def _pair(analyses: list[Analysis], names: tuple[str, str], title: str):
    thresholds = {**THRESHOLDS, **analyses[0].options.situation.thresholds}
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for ax, name in zip(axes, names):
        _axes_panel(ax, analyses, name, thresholds.get(name))
    fig.suptitle(title)
    return fig


def inertia_change(analyses: list[Analysis]):
    """dI_L and dI_Q per mode and axis at q_max (paper Fig. 8, theory 7), with the rule III thresholds."""
    return _pair(analyses, ("dI_L", "dI_Q"), "Change of rotational inertia at q_max per mode and axis (paper Fig. 8)")


def coupling(analyses: list[Analysis]):
    """dI_fT per mode and axis and dI_Tf per mode (paper Fig. 10, theory 7)."""
    return _pair(analyses, ("dI_fT", "dI_Tf"), "Influence of inertia coupling at q_max (paper Fig. 10)")


def campbell_diagram(a: Analysis):
    """Flexible frequencies against spin about each principal axis (full FFRF set, and with geo_stiff when the
    body carries G; the latter is then the reference of verify), drawn by ``verify_figures.campbell_chart``:
    branches tracked by mode shape, gaps where the linearisation is singular or the set unstable, 1x and 2x per
    revolution, s_crit without and with stiffening and w_op marked (theory 9, 10)."""
    body, sig = a.body, a.significance
    per_s = float(TIME[body.units.time])
    w_op = (a.options.situation.w_op or 0.0) * per_s
    speeds = [campbell_speeds(k, w_op, (sig.s_crit, sig.s_crit_stiffened), CAMPBELL_POINTS, 1.25) for k in range(3)]
    sets = {"full FFRF": FULL}
    if body.geometric is not None:
        sets["full FFRF + geo_stiff"] = (*FULL, "geo_stiff")
    branches = {(name, k): campbell(build_model(body, terms), np.eye(3)[k], speeds[k])
                for name, terms in sets.items() for k in range(3)}
    camp = {"speeds": speeds, "s_crit": sig.s_crit, "s_crit_stiffened": sig.s_crit_stiffened,
            "speed": w_op, "w_op": w_op, "reference_label": list(sets)[-1],
            "by_axis": {k: {name: branches[name, k].frequencies for name in sets} for k in range(3)},
            "gaps": {k: {name: branches[name, k].gaps.tolist() for name in sets} for k in range(3)}}
    return campbell_chart(camp, body.units.frequency, body.units.time,
                          f"{label(body.name)}: Campbell diagram, frequencies against spin (theory 9)")


def mesh_and_modes(a: Analysis, modes: int = 3):
    """The mesh and the first modes deformed at q_max (figures.modes_figure)."""
    return modes_figure(a.body, a.amplitudes.q_max, modes, label(a.body.name))
