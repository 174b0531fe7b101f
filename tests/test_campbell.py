"""Campbell diagrams as rotordynamics engineers draw them (issue 25): branches tracked by mode shape across
crossings, gaps (not spikes) where the linearisation is singular or the set unstable, Hz against rad/s with
w_op, s_crit and the 1x, 2x per-revolution lines marked, and the errors against the scenes' reference."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from rich.console import Console

from ffrf_advisor.analysis import Options, analyze
from ffrf_advisor.guidelines import Situation
from ffrf_advisor.io import read_body
from ffrf_advisor.report.console import campbell_line
from ffrf_advisor.report.verify_figures import campbell_chart
from ffrf_advisor.sim.linearise import campbell, linearise, unstable
from ffrf_advisor.sim.model import build_model
from ffrf_advisor.significance import softening_speeds
from ffrf_advisor.terms import FULL
from ffrf_advisor.verify.runner import frequency_error, stiffened
from ffrf_advisor.verify.scenes import make_scenes
from ffrf_advisor.verify.study import CAMPBELL_SETS, campbell_data

DIR = Path(__file__).resolve().parent.parent / "sample_bodies"

# A branch may change between neighbouring speeds s_i and s_i + ds (i >= 1) by at most the fraction
# STEP_MARGIN x ds / s_i of itself. Why ds / s_i: the spin enters the modal equations as s (gyroscopic) and s^2
# (centrifugal, geometric), and for a branch f = f0 + g s or f^2 = f0^2 + c s^2 with g, c >= 0,
# |ln f(s + ds) - ln f(s)| <= ln(1 + ds / s) <= ds / s exactly; for falling ones (g, c < 0) the same holds while
# the branch stays above 1/sqrt(2) of its frequency at rest (f^2 = f0^2 - c s^2: the step is (ds / s) c s^2 / f^2).
# On the 41-point grid of verify this is 1/i of the branch at sample i (5 % halfway); the beam's branches reach
# 0.93 of it, hence the margin 1.25. A branch that hops onto another mode moves by the spacing of the modes
# (the beam's lowest three: 100 % and 38 %), far beyond. Left out: falling branches below 0.7 of their rest
# frequency (the softening towards s_crit, infinitely steep at it), and steps where another branch lies within
# the fraction (a crossing, where a hop cannot be told from a move).
STEP_MARGIN = 1.25
SOFTENED = 0.7


def jumps(f: np.ndarray, speeds: np.ndarray) -> list[tuple[int, int]]:
    """(sample, branch) of the steps i -> i + 1 where a branch changes by more than STEP_MARGIN ds / s_i of itself,
    away from s_crit and from crossings (see above)."""
    ds, out = speeds[1] - speeds[0], []
    for i in range(1, len(speeds) - 1):
        frac, a, b = STEP_MARGIN * ds / speeds[i], f[i], f[i + 1]
        for p in np.flatnonzero(np.isfinite(a) & np.isfinite(b)):
            if abs(np.log(b[p] / a[p])) <= frac or min(a[p], b[p]) < SOFTENED * f[0, p]:
                continue
            near = [np.abs(np.log(np.delete(x, p) / x[p])) <= frac for x in (a, b)]
            if not np.any(near[0] | near[1]):
                out.append((i, int(p)))
    return out


@pytest.fixture(scope="module")
def beam():
    return analyze(read_body(DIR / "beam.ffrf.h5"), Options(situation=Situation(w_op=300.0)))


@pytest.fixture(scope="module")
def scene(beam):
    return make_scenes(["free-spin"], beam)[0]  # the first scene of verify: about the deformation axis


@pytest.fixture(scope="module")
def camp(beam, scene):
    return campbell_data(beam, scene.speed, scene.axis)


def test_no_branch_jumps_by_more_than_the_grid_steps_share_of_the_speed(camp):
    """Every set verify draws (level II among them), about every axis: no jump away from s_crit and crossings;
    and the criterion does catch one: two branches swapped from mid-range on."""
    assert set(camp["sets"]) == set(CAMPBELL_SETS)
    for k in range(3):
        speeds = camp["speeds"][k]
        assert np.allclose(np.diff(speeds), speeds[1])
        for label, f in camp["by_axis"][k].items():
            assert f.shape == (len(speeds), 16)
            assert jumps(f, speeds) == [], (k, label)
    f = camp["by_axis"][0]["IV (full)"].copy()
    f[20:, [0, 1]] = f[20:, [1, 0]]
    assert (19, 0) in jumps(f, camp["speeds"][0])


def test_branches_follow_their_mode_shapes_through_a_crossing(beam):
    """About the beam's long axis (3) mode 2 stiffens and mode 3 softens; they cross near 560 rad/s. Tracked by
    shape each goes on through the other (sorted frequencies would turn back at the crossing), and the branches
    on a grid four times finer are the same at the common speeds."""
    model = build_model(beam.body, stiffened(beam, FULL))
    speeds = np.linspace(0.0, 640.0, 17)
    f, gaps = campbell(model, np.eye(3)[2], speeds)
    assert not any(gaps) and np.isfinite(f).all()
    assert np.all(np.diff(f[:, 1]) > 0) and np.all(np.diff(f[:, 2]) < 0)
    assert f[0, 1] < f[0, 2] and f[-1, 1] > f[-1, 2]  # they crossed
    fine = campbell(model, np.eye(3)[2], np.linspace(0.0, 640.0, 65)).frequencies
    assert np.allclose(fine[::4], f, rtol=1e-9)


def test_no_point_where_the_linearisation_is_singular_or_the_set_unstable(beam):
    """The full set without geo_stiff about axis 2, on the report's former grid, whose sample 20 falls on s_crit
    (1329 rad/s; there the raw linearisation gave 2,700 Hz on a CalculiX beam): a gap there, the set unstable past
    it, every point before it drawn, no jump; within 1e-5 of s_crit also a gap."""
    s_crit = beam.significance.s_crit[1]
    speeds = np.linspace(0.0, 1.25 * s_crit, 26)
    assert speeds[20] == pytest.approx(s_crit, rel=1e-12)
    model = build_model(beam.body, FULL)
    f, gaps = campbell(model, np.eye(3)[1], speeds)
    assert gaps[20] == "singular" and set(gaps[21:]) == {"unstable"} and not any(gaps[:20])
    assert np.isnan(f[20:]).all() and np.isfinite(f[:20]).all()
    assert jumps(f, speeds) == []
    assert np.nanmax(f) <= np.max(beam.body.frequencies_hz) * 1.01  # no spike above the modes
    near = campbell(model, np.eye(3)[1], s_crit * np.array([1 - 1e-5, 1 + 1e-5]))
    assert list(near.gaps) == ["singular", "singular"] and np.isnan(near.frequencies).all()


def test_the_conrod_flutters_where_mode_1_meets_the_wobble_and_has_a_gap_there_not_a_jump():
    """About the conrod's minor axis 2 its wobble meets mode 1 near 660 Hz; the full set flutters between about
    4,750 and 5,025 rad/s (growth 2.9 % of the rate). On the grid up to 0.6 s_crit: every point before drawn, the
    last three (4,743 to 4,999 rad/s) a gap "unstable", no jump anywhere."""
    body = read_body(DIR / "conrod.ffrf.h5")
    speeds = np.linspace(0.0, 0.6 * softening_speeds(body)[1], 40)
    f, gaps = campbell(build_model(body, FULL), np.eye(3)[1], speeds)
    assert not any(gaps[:37]) and list(gaps[37:]) == ["unstable"] * 3
    assert np.isfinite(f[:37]).all() and np.isnan(f[37:]).all()
    assert jumps(f, speeds) == []
    assert np.abs(np.diff(f[:37], axis=0)).max() < 0.02 * np.nanmax(f)  # a branch swap jumps by a mode's spacing


def test_stability_from_the_eigenvalues_alone_is_the_linearisations():
    """``unstable`` (eigenvalues only, for the mode-set advice) against ``linearise(...).unstable`` across the
    conrod's flutter band and past its softening limit: the same verdicts, both kinds present."""
    body = read_body(DIR / "conrod.ffrf.h5")
    s_crit = softening_speeds(body)[1]
    model = build_model(body, FULL)
    speeds = [0.5 * s_crit, *np.linspace(0.6 * s_crit * 34 / 39, 0.6 * s_crit, 6), 1.05 * s_crit]
    verdicts = [linearise(model, np.eye(3)[1], s).unstable for s in speeds]
    assert [unstable(model, np.eye(3)[1], s) for s in speeds] == verdicts
    assert verdicts[0] is False and verdicts[-1] is True and True in verdicts[1:-1] and False in verdicts[1:-1]


def test_the_errors_compare_with_the_scenes_reference_about_their_axis_at_their_speed(beam, scene, camp):
    """The reference is the scenes' (runner: the full set with geo_stiff, the beam carries G); each set's error
    is the first scene's frequency error; the text names the reference, the axis and the speed."""
    assert beam.body.geometric is not None
    assert "geo_stiff" in camp["reference_terms"] and tuple(camp["reference_terms"]) == stiffened(beam, FULL)
    assert camp["reference"] == "full set with geo_stiff" and camp["reference_label"] == "IV (full)"
    assert camp["axis_of_error"] == scene.axis == 2 and camp["speed"] == scene.speed == pytest.approx(300.0)
    for label, terms in camp["sets"].items():
        assert camp["frequency_error"][label] == pytest.approx(frequency_error(beam, terms, scene), rel=1e-12,
                                                               abs=0.0), label
    assert camp["frequency_error"]["IV (full)"] == 0.0 and camp["frequency_error"]["I"] > 0.1
    text = campbell_line({**camp, "axis_of_error": camp["axis_of_error"] + 1}, "s")
    assert text.startswith("Campbell, largest frequency error against the reference (full set with geo_stiff) "
                           "about principal axis 3 at 300 rad/s: advised 0.0e+00, I ")
    console = Console(record=True, width=200)
    console.print(text)
    assert "II " in console.export_text()


def test_the_chart_has_hz_against_rad_s_w_op_s_crit_and_per_revolution_lines_and_the_legend_below(beam, camp):
    fig = campbell_chart(camp, beam.body.units.frequency, beam.body.units.time, "beam: Campbell diagram")
    fig.canvas.draw()  # lays the figure out
    axes = fig.axes
    assert axes[0].get_ylabel() == "frequency [Hz]"
    assert all(ax.get_xlabel() == f"spin about principal axis {k + 1} [rad/s]" for k, ax in enumerate(axes))
    texts = [[t.get_text() for t in ax.texts] for ax in axes]
    for k in range(3):
        assert "w_op 300 rad/s" in texts[k] and "1x" in texts[k] and "2x" in texts[k]
        assert axes[k].get_legend() is None  # nothing inside the panels hides a label
    assert any(t.startswith("s_crit without G 667.3") for t in texts[0])
    assert "s_crit without G 667.8" in texts[2] and "s_crit with G 668.4" in texts[2]  # one at the top, one below
    assert any(t.startswith("unstable:") and "IV (full)" in t for t in texts[2])
    (legend,) = fig.legends
    names = [t.get_text() for t in legend.get_texts()]
    assert "I = II" in names and "advised = IV (full) (reference)" in names and "III" in names
    assert legend.get_window_extent().y1 <= min(ax.get_window_extent().y0 for ax in axes)  # below the panels
