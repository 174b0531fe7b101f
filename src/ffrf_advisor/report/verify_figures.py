"""Figures of a verification (PNG and SVG): trajectories, work-precision chart, drift, Campbell diagram.

They read results (verify.runner, verify.workprecision, sim.linearise); they compute nothing but what
they draw.
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker  # noqa: E402
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


ROUND_OFF = 1e-12  # a modal coordinate below this share of q_max,1 is round-off: said, not drawn


def trajectories(ref_run, runs: dict, sigma, units, title: str, q_scale: float):
    """Spin rate |w|, first modal coordinate and recovered stress of the reference and each set against time, in
    the body's ``units``; plain tick labels (no offset like "1e-5 + 1"); the modal panels say "below round-off"
    where every run's coordinates stay below ROUND_OFF x ``q_scale`` (q_max,1)."""
    time_unit, stress_unit = units.time, units.stress
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
    axes[1].set_ylabel(f"q1 [sqrt({units.mass}) {units.length}]")
    axes[2].set_ylabel("sum sigma_p |q_p|" + (f" [{stress_unit}]" if sigma is not None else
                                               f" [sqrt({units.mass}) {units.length}]"))
    for ax in axes:
        ax.ticklabel_format(axis="y", useOffset=False)
    largest = max((np.abs(r.y[:, N_ROT:N_ROT + nf]).max() for r in [ref_run, *runs.values()] if len(r.t)),
                  default=0.0)
    if largest < ROUND_OFF * q_scale:
        for ax in axes[1:]:
            ax.cla()
            ax.text(0.5, 0.5, f"modal coordinates below round-off: at most {largest:.1e}, under {ROUND_OFF:g} of "
                    f"q_max,1 = {q_scale:.3g}", transform=ax.transAxes, ha="center", va="center", fontsize=9)
            ax.set_yticks([])
    axes[2].set_xlabel(f"t [{time_unit}]")
    axes[0].set_title(title)
    axes[0].legend(fontsize=7, ncol=3)
    return fig


def work_precision_chart(points, front, title: str):
    """log error against log wall time, one line per (set, integrator): the set by colour, the integrator by
    marker, each explained once in a legend beside the axes; the Pareto front and failed runs (x, on the red
    line) marked."""
    from matplotlib.lines import Line2D
    fig, ax = plt.subplots(figsize=(9, 6))
    finite = [p.error for p in points if not p.failed and p.error > 0]
    top = 10 * max(finite) if finite else 1.0
    floor = 1e-16
    groups = {}
    for p in points:
        groups.setdefault((p.set, p.integrator), []).append(p)
    markers = {"dop853": "o", "rk4": "s", "midpoint": "^"}
    sets = list(dict.fromkeys(label for label, _ in groups))
    colour = {label: plt.cm.tab10(k % 10) for k, label in enumerate(sets)}
    for (label, integ), pts in groups.items():
        ok = sorted((p for p in pts if not p.failed), key=lambda p: p.wall_s)
        ax.plot([p.wall_s for p in ok], [max(p.error, floor) for p in ok], marker=markers.get(integ, "o"), ms=4,
                lw=1, color=colour[label])
        bad = [p for p in pts if p.failed]
        if bad:
            ax.plot([p.wall_s for p in bad], [top] * len(bad), "x", color=colour[label], ms=8)
    ax.plot([p.wall_s for p in front], [max(p.error, floor) for p in front], "-", color="k", lw=3, alpha=0.25)
    ax.axhline(top, color="r", lw=0.5, ls=":")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time [s] (one run; --repeat: the minimum, serial)")
    ax.set_ylabel("worst relative error against the reference [-]")
    ax.set_title(title)
    integrators = list(dict.fromkeys(integ for _, integ in groups))
    keys = ([Line2D([], [], color=colour[label], lw=2, label=label) for label in sets]
            + [Line2D([], [], color="k", marker=markers.get(i, "o"), ls="none", label=i) for i in integrators]
            + [Line2D([], [], color="k", lw=3, alpha=0.25, label="Pareto front (cheapest per error)"),
               Line2D([], [], color="r", marker="x", ls=":", lw=0.5, label="failed run (drawn on this line)")])
    ax.legend(handles=keys, fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), title="term set (colour), "
              "integrator (marker)", title_fontsize=8)
    fig.tight_layout()
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


PER_REVOLUTION = (1, 2)  # engine orders drawn: f = k s / (2 pi)
SHOWN_MODES = 6  # the frequency axis reaches the highest of the first six branches (or the 2x line)
STYLES = ("-", "--", "-.", ":")


def campbell_chart(camp: dict, freq_unit: str, speed_unit: str, title: str):
    """The Campbell diagram as rotordynamics engineers draw it, one panel per principal axis: each term set's
    branches (tracked by mode shape; one colour and dash per set, the reference broad and grey; sets with equal
    branches on every axis drawn once and named together), gaps where the linearisation is singular or the set
    unstable (the unstable speeds shaded, wide bands naming their sets), the 1x and 2x per-revolution lines
    f = k s / (2 pi), s_crit without and with geometric stiffening and the operating speed as vertical lines
    labelled along them, the legend below the panels. ``camp``: as ``verify.study.campbell_data`` (speeds and
    by_axis per axis; gaps, s_crit, s_crit_stiffened, speed, w_op, axis_of_error, reference_label optional);
    speeds in rad per ``speed_unit``, frequencies in ``freq_unit``."""
    fig, axes = plt.subplots(1, 3, figsize=(14, 5.4), sharey=True, layout="constrained")
    labels = list(camp["by_axis"][0])
    stacked = {label: np.concatenate([np.asarray(camp["by_axis"][k][label], float) for k in range(3)])
               for label in labels}
    groups = _equal_sets(stacked)
    nf = stacked[labels[0]].shape[1] if labels else 0
    low = np.concatenate([f[:, :SHOWN_MODES][np.isfinite(f[:, :SHOWN_MODES])] for f in stacked.values()] + [[0.0]])
    top = 1.05 * low.max() if low.max() > 0 else 1.0
    others = [g for g in groups if camp.get("reference_label") not in g]
    handles = {}
    for k, ax in enumerate(axes):
        speeds = np.asarray(camp["speeds"][k], float)
        for g in groups:
            if g in others:
                i = others.index(g)
                style = dict(color=f"C{i}", ls=STYLES[i % len(STYLES)], lw=1, marker=".", ms=2.5, zorder=3)
            else:  # the reference: broad and grey under the others, as in the trajectories
                style = dict(color="k", lw=2.6, alpha=0.4, zorder=2)
            line = ax.plot(speeds, np.asarray(camp["by_axis"][k][g[0]], float), **style)[0]
            handles.setdefault(" = ".join(g) + ("" if g in others else " (reference)"), line)
        _unstable_bands(ax, speeds, camp.get("gaps", {}).get(k, {}), groups)
        for order in PER_REVOLUTION:
            f = order * speeds / (2 * np.pi)
            ax.plot(speeds, f, color="0.45", lw=0.8, ls=(0, (4, 3)), zorder=1)
            j = np.flatnonzero(f <= top)[-1]
            ax.annotate(f"{order}x", (speeds[j], f[j]), textcoords="offset points", xytext=(-3, 3), ha="right",
                        va="bottom", fontsize=7, color="0.3")
        marks = []
        for c, colour, style, name in ((camp.get("s_crit"), "r", ":", "s_crit" if camp.get("s_crit_stiffened")
                                        is None else "s_crit without G"),
                                       (camp.get("s_crit_stiffened"), "darkred", "-.", "s_crit with G")):
            if c is not None and np.isfinite(c[k]) and c[k] <= speeds[-1]:
                marks.append((c[k], colour, style, f"{name} {c[k]:.4g}"))
        speed = camp.get("speed")
        if speed:
            w_op = camp.get("w_op")
            name = "w_op" if w_op and abs(w_op - speed) <= 1e-9 * speed else "spin of the scenes"
            marks.append((speed, "g", "-", f"{name} {speed:.4g} rad/{speed_unit}"))
        _verticals(ax, marks, speeds[-1])
        scene = " (the scenes' axis: errors)" if camp.get("axis_of_error") == k else ""
        ax.set_title(f"principal axis {k + 1}{scene}", fontsize=9)
        ax.set_xlabel(f"spin about principal axis {k + 1} [rad/{speed_unit}]")
        ax.set_xlim(0.0, speeds[-1])
    axes[0].set_ylim(0.0, top)
    axes[0].set_ylabel(f"frequency [{freq_unit}]")
    shown = f"; frequencies up to the top of branch {SHOWN_MODES} of {nf}" if nf > SHOWN_MODES else ""
    fig.legend(list(handles.values()), list(handles.keys()), loc="outside lower center", ncol=min(len(handles), 6),
               fontsize=8, title_fontsize=8, title="term sets: flexible frequencies in the spinning body, tracked by "
               f"mode shape; grey dashed: 1x, 2x per revolution; shaded: unstable{shown}")
    fig.suptitle(title)
    return fig


def _equal_sets(by_label: dict) -> list[list[str]]:
    """Labels grouped by equal branches (to 1e-6, NaN equal to NaN: level I and II have the same frequencies
    about a principal axis, cf1 only deflects), in order of first appearance."""
    groups: list[list[str]] = []
    for label, f in by_label.items():
        for g in groups:
            if np.allclose(by_label[g[0]], f, rtol=1e-6, atol=0.0, equal_nan=True):
                g.append(label)
                break
        else:
            groups.append([label])
    return groups


def _unstable_bands(ax, speeds: np.ndarray, gaps: dict, groups: list[list[str]]) -> None:
    """Shade the speeds where sets are unstable (between the neighbouring samples' midpoints), each run of
    samples with the same unstable sets one band; bands over a tenth of the range name their sets."""
    unstable = {g[0]: [x == "unstable" for x in gaps.get(g[0], [])] or [False] * len(speeds) for g in groups}
    names = [tuple(label for g in groups if unstable[g[0]][i] for label in g) for i in range(len(speeds))]
    edges = np.concatenate([[speeds[0]], 0.5 * (speeds[1:] + speeds[:-1]), [speeds[-1]]])
    i = 0
    while i < len(speeds):
        j = i
        while j + 1 < len(speeds) and names[j + 1] == names[i]:
            j += 1
        a, b = edges[i], edges[j + 1]
        if names[i]:
            ax.axvspan(a, b, color="0.5", alpha=0.12 + 0.06 * (len(names[i]) > 1), lw=0, zorder=0)
        if names[i] and b - a >= 0.1 * speeds[-1]:
            ax.text(0.5 * (a + b), 0.5, "unstable:\n" + ",\n".join(names[i]), ha="center", va="center",
                    fontsize=6.5, color="0.2", transform=ax.get_xaxis_transform(), zorder=5,
                    bbox=dict(boxstyle="round,pad=0.2", fc="white", ec="0.6", alpha=0.85))
        i = j + 1


def _verticals(ax, marks: list, width: float) -> None:
    """Vertical lines (x, colour, style, text), each labelled along it at the top of the panel, or at the foot
    where a label already stands within 5 % of the width."""
    placed: list[float] = []
    for x, colour, style, text in sorted(marks, key=lambda m: m[0]):
        ax.axvline(x, color=colour, ls=style, lw=1.2, zorder=4)
        foot = any(abs(x - p) < 0.05 * width for p in placed)
        if not foot:
            placed.append(x)
        ax.text(x, 0.02 if foot else 0.98, text, transform=ax.get_xaxis_transform(), rotation=90, ha="center",
                va="bottom" if foot else "top", fontsize=7, color=colour, zorder=6,
                bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.85))


def stability_chart(stab: dict, time_unit: str, title: str):
    """Left: energy drift against the RK4 step (full set and level II). Right: each stability number measured
    by simulation over its prediction (1 = theory confirmed)."""
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2), layout="constrained")
    for label, rows in stab["drift_against_step"].items():
        steps = [r["step"] for r in rows]
        left.plot(steps, [max(r["energy_drift"] or 0.0, 1e-17) for r in rows], marker="o", label=label)
    left.set_xscale("log")
    left.set_yscale("log")
    left.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())  # labels of minor ticks overlap
    left.set_xticks(steps, [f"{h:.2g}" for h in steps])
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


def write_figures(st, drift: dict | None, directory: Path, progress=None) -> tuple[str, ...]:
    """The figures of a verification (a ``verify.study.Study``) in ``directory``, each as PNG and SVG:
    trajectories_<scene>_axis<k>, and unless the studies were left out (quick) work_precision, drift (the
    curves of ``verify.study.drift_curves``), stability and campbell. ``progress(label, done, total)`` is told
    of each figure written."""
    from ..verify.workprecision import pareto
    a, ver, directory = st.analysis, st.verification, Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    unit, name, scene = a.body.units.time, a.body.name, ver.scenes[0]
    drawings = [(f"trajectories_{sc.name}_axis{sc.axis + 1}", lambda sc=sc: trajectories(
        ver.references[sc.label].run, {r.set.label: r.run for r in ver.results if r.scene == sc.label},
        a.body.sigma_max, a.body.units, f"{name}: {sc.label}", float(a.amplitudes.q_max[0]))) for sc in ver.scenes]
    if st.work_precision is not None:
        drawings += [
            ("work_precision", lambda: work_precision_chart(st.work_precision, pareto(st.work_precision),
                                                            f"{name}: {scene.label}, work-precision (serial)")),
            ("drift", lambda: drift_chart(drift, unit, f"{name}: {scene.label}, energy drift")),
            ("stability", lambda: stability_chart(st.stability, unit, f"{name}: stability where methods fail")),
            ("campbell", lambda: campbell_chart(st.campbell, a.body.units.frequency, unit,
                                                f"{name}: Campbell diagram"))]
    paths = []
    for k, (stem, draw) in enumerate(drawings):
        paths += save(draw(), directory, stem)
        if progress is not None:
            progress(f"figure {stem}", k + 1, len(drawings))
    return tuple(str(p) for p in paths)
