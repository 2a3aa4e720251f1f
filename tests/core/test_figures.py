"""Every ``--plot`` picture: each axis labelled with its unit, and no legend over the data.

Each plot is drawn (matplotlib's Agg backend) by the function its command calls; the figure is
kept when the code closes it, then checked in display coordinates: the legend's bounding box
against every plotted point, every line sampled each 2 px, every patch's outline and every
filled area's boundary.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.collections import PathCollection  # noqa: E402
from matplotlib.quiver import Quiver  # noqa: E402

from marknav.cli.main import main  # noqa: E402

DATA = Path(__file__).resolve().parents[1] / "data"
LEFT = sorted(str(p) for p in (DATA / "opencv-left").glob("left*.jpg"))


@pytest.fixture
def figures(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[Any]]:
    """The figures the code under test closes, kept open for the checks."""
    kept: list[Any] = []
    real_close = plt.close

    def keep(fig: Any = None) -> None:
        if fig is not None and not isinstance(fig, str):
            kept.append(fig)

    monkeypatch.setattr(plt, "close", keep)
    yield kept
    for fig in kept:
        real_close(fig)


def _densify(points: np.ndarray, step_px: float = 2.0) -> np.ndarray:
    """A polyline (display px) sampled every ``step_px``; NaN vertices break it."""
    out = []
    for a, b in itertools.pairwise(points):
        if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
            continue
        n = max(1, math.ceil(float(np.hypot(*(b - a))) / step_px))
        out.append(a + (b - a) * np.linspace(0.0, 1.0, n + 1)[:, None])
    if not out:
        return points[np.all(np.isfinite(points), axis=1)]
    return np.concatenate(out)


def _data_points(ax: Any) -> np.ndarray:
    """Everything ``ax`` plots, as display-coordinate points."""
    pts: list[np.ndarray] = []
    for line in ax.lines:
        xy = line.get_transform().transform(np.asarray(line.get_xydata(), float))
        pts.append(xy if line.get_linestyle() in ("None", "") else _densify(xy))
    for coll in ax.collections:
        if isinstance(coll, Quiver):
            tails = np.column_stack([coll.X, coll.Y])
            tips = tails + np.column_stack([coll.U, coll.V])
            pts.append(ax.transData.transform(np.concatenate([tails, tips])))
        elif isinstance(coll, PathCollection):  # scatter: the markers' centres
            offsets = np.asarray(coll.get_offsets(), float)
            if len(offsets):
                pts.append(coll.get_offset_transform().transform(offsets))
        else:  # lines, filled areas: their paths in data coordinates
            for path in coll.get_paths():
                pts.append(_densify(coll.get_transform().transform(path.vertices)))
    for patch in ax.patches:
        pts.append(_densify(patch.get_transform().transform(patch.get_path().vertices)))
    return np.concatenate(pts) if pts else np.zeros((0, 2))


def _is_colorbar(ax: Any) -> bool:
    return getattr(ax, "_colorbar", None) is not None


def check_figure(fig: Any, name: str) -> None:
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    plotted = [ax for ax in fig.axes if not _is_colorbar(ax)]
    points = np.concatenate([_data_points(ax) for ax in plotted])
    assert len(points) > 10, f"{name}: nothing plotted?"
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    legends += list(fig.legends)
    assert legends, f"{name}: no legend"
    for legend in legends:
        box = legend.get_window_extent(renderer)
        inside = ((points[:, 0] > box.x0 + 1) & (points[:, 0] < box.x1 - 1)
                  & (points[:, 1] > box.y0 + 1) & (points[:, 1] < box.y1 - 1))
        assert not inside.any(), (f"{name}: the legend ({box}) covers {int(inside.sum())} "
                                  f"plotted points, e.g. {points[inside][:3].tolist()}")
    for ax in fig.axes:
        axes = [ax.yaxis] if _is_colorbar(ax) else [ax.xaxis, ax.yaxis]
        for axis in axes:
            if not axis.get_visible():
                continue  # a twin's hidden x axis: the other axes carries the label
            label = axis.get_label().get_text()
            if _is_colorbar(ax) and not label:
                label = ax.xaxis.get_label().get_text()
            assert label.strip(), f"{name}: an axis without a label"
            assert "[" in label and "]" in label, f"{name}: no unit in the label {label!r}"


def _one(figures: list[Any], name: str, draw: Callable[[], Any]) -> None:
    figures.clear()
    draw()
    assert len(figures) == 1, f"{name}: {len(figures)} figures"
    check_figure(figures[0], name)


def test_calibrate_plot(figures: list[Any], tmp_path: Path) -> None:
    out = tmp_path / "calibrate.png"
    _one(figures, "calibrate --plot",
         lambda: main(["calibrate", str(DATA / "paper_table1.csv"), "--plot", str(out)]))
    assert out.stat().st_size > 10_000


def test_calibrate_camera_plot(figures: list[Any], tmp_path: Path) -> None:
    out = tmp_path / "calibrate-camera.png"
    _one(figures, "calibrate-camera --plot",
         lambda: main(["calibrate-camera", *LEFT[:4], "--board", "9x6", "--square-mm", "25",
                       "--plot", str(out)]))
    assert out.stat().st_size > 10_000


def test_run_and_replay_plot(figures: list[Any], tmp_path: Path) -> None:
    from marknav.sim.plot import PlotData, PlotMark, draw

    t = np.linspace(0.0, 40.0, 400)
    xy = np.column_stack([350.0 * np.sin(t / 40.0 * 4 * math.pi), t / 40.0 * 6500.0])
    data = PlotData(
        title="slalom: success", clearance_mm=300.0, t=t, xy=xy,
        marks=[PlotMark((x, y), 100.0, rgb, f"#{i + 1} {c}") for i, (x, y, c, rgb) in enumerate(
            [(-200, 1500, "red", (1, 0, 0)), (200, 3100, "green", (0, 1, 0)),
             (-200, 4700, "red", (1, 0, 0)), (200, 6300, "blue", (0, 0, 1))])],
        walls=[[-1600.0, -500.0, -1600.0, 7500.0], [1600.0, -500.0, 1600.0, 7500.0],
               [-1600.0, 7500.0, 1600.0, 7500.0], [-1600.0, -500.0, 1600.0, -500.0]],
        plans=[xy[40:90] + np.array([30.0, 0.0]), xy[140:190] - np.array([30.0, 0.0])],
        bumps=[(150.0, 5000.0)])
    out = tmp_path / "run.png"
    _one(figures, "run --plot", lambda: draw(data, out))
    assert out.stat().st_size > 10_000


def test_evaluate_accuracy_plot(figures: list[Any], tmp_path: Path) -> None:
    from marknav.runs.evaluation.evaluate import AccuracyResult, plot_accuracy
    from marknav.runs.metrics.position_accuracy import AccuracyRow, AccuracyTable

    rows = tuple(AccuracyRow(y_mm=y, points=9, skipped=0, frames=45, missed=0,
                             median_mm=0.004 * y * y / 1000.0, p95_mm=0.008 * y * y / 1000.0,
                             max_mm=0.012 * y * y / 1000.0)
                 for y in (500.0, 1000.0, 1500.0, 2000.0, 2500.0, 3000.0))
    result = AccuracyResult(AccuracyTable(rows, "power law", 5), "default camera", "3x6",
                            590.0, 100.0)
    out = tmp_path / "accuracy.png"
    _one(figures, "evaluate --accuracy --plot", lambda: plot_accuracy(result, out))
    assert out.stat().st_size > 10_000


def test_tune_plot(figures: list[Any], tmp_path: Path) -> None:
    from marknav.runs.evaluation.tune import Param, TrialSummary, TuneResult, plot_trials

    rng = np.random.default_rng(3)
    trials = []
    for n in range(20):
        rate = float(rng.choice([0.0, 0.5, 1.0]))
        trials.append(TrialSummary(
            number=n, params={"navigation.clearance_mm": float(rng.uniform(280, 450)),
                              "navigation.bypass_distance_mm": float(rng.choice(
                                  np.arange(600, 1001, 50)))},
            value=(1 - rate) * 300 + 36 + n % 3, success_rate=rate, successes=int(2 * rate),
            runs=2, median_time_s=36.0 + n % 3))
    best = min(trials, key=lambda t: t.value)
    result = TuneResult("missions/slalom.yaml", "memory", "tune-slalom", trials, best, 20)
    params = [Param("navigation.clearance_mm", 280, 450),
              Param("navigation.bypass_distance_mm", 600, 1000, 50)]
    out = tmp_path / "tune.png"
    _one(figures, "tune --plot", lambda: plot_trials(result, params, out))
    fig = figures[0]
    assert fig._suptitle.get_text() == "marknav tune missions/slalom.yaml: 20 trials"
    numbers = [t.number for t in trials]
    rates = [100 * t.success_rate for t in trials]
    times = [t.median_time_s for t in trials]
    lines = {ln.get_label(): ln for ax in fig.axes for ln in ax.lines}
    # left: each trial's success rate and median time, and the best value's time so far
    assert list(lines["success %"].get_xdata()) == numbers
    assert list(lines["success %"].get_ydata()) == rates
    assert list(lines["median time"].get_ydata()) == times
    best_so_far = [min(trials[: k + 1], key=lambda t: t.value).median_time_s
                   for k in range(len(trials))]
    assert list(lines["median time of the best so far"].get_ydata()) == best_so_far
    # right: every trial at its two parameters, coloured by its success rate; the best starred
    (right,) = [ax for ax in fig.axes if ax.get_xlabel().startswith("navigation.clearance_mm")]
    assert right.get_ylabel().startswith("navigation.bypass_distance_mm")
    trials_dots, star = right.collections
    assert np.asarray(trials_dots.get_offsets()).tolist() == [
        [t.params["navigation.clearance_mm"], t.params["navigation.bypass_distance_mm"]]
        for t in trials]
    assert list(trials_dots.get_array()) == rates
    assert trials_dots.get_clim() == (0, 100)
    assert np.asarray(star.get_offsets()).tolist() == [
        [best.params["navigation.clearance_mm"], best.params["navigation.bypass_distance_mm"]]]
    assert star.get_label() == f"best (trial {best.number})"
    # and the file has them drawn: the success dots' green and the time's blue are in it
    image = plt.imread(out)[..., :3]
    assert min(image.shape[:2]) > 300
    for colour in ("tab:green", "tab:blue"):
        rgb = np.asarray(matplotlib.colors.to_rgb(colour))
        assert int((np.abs(image - rgb).max(axis=2) < 0.05).sum()) > 50, colour


def test_the_check_catches_a_legend_over_data(figures: list[Any]) -> None:
    fig, ax = plt.subplots()
    x = np.linspace(0, 10, 50)
    ax.plot(x, np.ones_like(x), label="flat line across the middle")
    ax.set_ylim(0.9, 1.1)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(loc="center")
    with pytest.raises(AssertionError, match="covers"):
        check_figure(fig, "bad")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.15))
    check_figure(fig, "good")
    ax.set_ylabel("y")
    with pytest.raises(AssertionError, match="no unit"):
        check_figure(fig, "no unit")
    plt.close(fig)
