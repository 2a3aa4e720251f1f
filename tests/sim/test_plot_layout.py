"""The run picture is laid out for any course: on the long course and on random worlds every mark
label lies inside the plotting area, over no path, wall or mark and over no other label; the
colour bar and the legend sit outside the plotting area; tick labels do not run together; the
planned Bézier curves are drawn above the path."""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402

from marknav.missions.examples import EXAMPLES_DIR  # noqa: E402
from marknav.missions.schema import load_mission  # noqa: E402
from marknav.runs.evaluation.random_mission import random_mission  # noqa: E402
from marknav.sim.plot import PlotData, draw, plot_data  # noqa: E402
from marknav.sim.world import load_world  # noqa: E402


def _weave(marks: list[tuple[float, float]], sides: list[float],
           clearance: float) -> SimpleNamespace:
    """A path from the origin past each mark at ``clearance`` on its side (+1 right), 20 Hz."""
    stops = [(0.0, 0.0)] + [(x + s * clearance, y) for (x, y), s in zip(marks, sides,
                                                                         strict=True)]
    pts = [np.asarray(stops[0])]
    for a, b in itertools.pairwise(stops):
        n = max(2, int(math.dist(a, b) / 15.0))
        f = np.linspace(0.0, 1.0, n)[1:, None]
        pts.extend(np.asarray(a) + f * (np.asarray(b) - np.asarray(a)))
    xy = np.asarray(pts)
    t = np.arange(len(xy)) / 20.0
    heading = np.arctan2(*np.gradient(xy, axis=0).T[::-1])
    return SimpleNamespace(t=t, xy=xy, theta=heading, collisions=[])


def _plan(xy: np.ndarray, k: int) -> SimpleNamespace:
    """A recorded plan that starts at path sample ``k`` and runs beside it."""
    pts = xy[k:k + 60] + np.array([40.0, 0.0])
    start = SimpleNamespace(x=float(xy[k, 0]), y=float(xy[k, 1]), theta=math.pi / 2)
    return SimpleNamespace(t=k / 20.0, plan=SimpleNamespace(
        sample=lambda _step: pts, start_pose=start))


def _data(mission: Any, world: Any) -> PlotData:
    marks = [m.xy for m in world.marks]
    sides = [1.0 if i % 2 else -1.0 for i in range(len(marks))]
    truth = _weave(marks, sides, mission.navigation.clearance_mm)
    plans = [_plan(truth.xy, k) for k in range(40, len(truth.xy) - 60, 400)]
    report = SimpleNamespace(outcome="success", reason="every waypoint passed")
    return plot_data(mission, world, truth, plans, report,
                     waypoint_marks=list(range(len(mission.route))))


def long_course() -> PlotData:
    mission = load_mission(str(EXAMPLES_DIR / "long-course.yaml"))
    return _data(mission, load_world(EXAMPLES_DIR / "worlds" / "long-course-world.yaml"))


def random_course(seed: int) -> PlotData:
    rm = random_mission(seed)
    return _data(rm.mission, rm.world)


def _drawn(data: PlotData, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Any:
    kept: list[Any] = []
    monkeypatch.setattr(plt, "close", lambda fig=None: kept.append(fig))
    draw(data, tmp_path / "run.png")
    assert (tmp_path / "run.png").stat().st_size > 10_000
    (fig,) = kept
    fig.canvas.draw()
    return fig


def _inside(box: Any, pts: np.ndarray) -> int:
    return int(((pts[:, 0] > box.x0) & (pts[:, 0] < box.x1)
                & (pts[:, 1] > box.y0) & (pts[:, 1] < box.y1)).sum())


def _apart(a: Any, b: Any) -> bool:
    return a.x1 <= b.x0 or b.x1 <= a.x0 or a.y1 <= b.y0 or b.y1 <= a.y0


def _data_points(ax: Any, data: PlotData) -> np.ndarray:
    """The path, the plans, the walls (sampled every ~5 mm) and the mark centres, on screen."""
    pts = [data.xy, *data.plans, np.asarray([m.xy for m in data.marks])]
    for x1, y1, x2, y2 in data.walls:
        n = max(2, int(math.hypot(x2 - x1, y2 - y1) / 5.0))
        f = np.linspace(0.0, 1.0, n)[:, None]
        pts.append(np.array([x1, y1]) + f * np.array([x2 - x1, y2 - y1]))
    return np.asarray(ax.transData.transform(np.concatenate(pts)))


def check_layout(fig: Any, data: PlotData) -> None:
    renderer = fig.canvas.get_renderer()
    ax = next(a for a in fig.axes if getattr(a, "_colorbar", None) is None)
    frame = ax.get_window_extent(renderer)
    points = _data_points(ax, data)
    labels = [t for t in ax.texts if t.get_text()]
    assert len(labels) == len(data.marks)
    boxes = [t.get_window_extent(renderer) for t in labels]
    for text, box in zip(labels, boxes, strict=True):
        name = text.get_text().split("\n")[0]
        assert frame.x0 <= box.x0 and box.x1 <= frame.x1, (name, box, frame)  # clear of ticks
        assert frame.y0 <= box.y0 and box.y1 <= frame.y1, (name, box, frame)
        assert _inside(box, points) == 0, (name, "covers the course")
    for i, a in enumerate(boxes):
        for b in boxes[i + 1:]:
            assert _apart(a, b), (a, b)
    (cbar,) = [a for a in fig.axes if getattr(a, "_colorbar", None) is not None]
    cbox = cbar.get_tightbbox(renderer)
    assert _apart(cbox, frame) and all(_apart(cbox, b) for b in boxes)
    legend = ax.get_legend().get_window_extent(renderer)
    assert _apart(legend, frame) and _apart(legend, cbox)
    for axis in (ax.xaxis, ax.yaxis):
        ticks = [t.get_window_extent(renderer) for t in axis.get_ticklabels()
                 if t.get_text() and t.get_visible()]
        ticks = [t for t in ticks if frame.x0 - 60 <= t.x0 <= frame.x1 + 60
                 and frame.y0 - 60 <= t.y0 <= frame.y1 + 60]
        assert len(ticks) >= 2
        for a, b in itertools.pairwise(ticks):
            assert _apart(a, b), (axis.axis_name, a, b)
    path = next(c for c in ax.collections if isinstance(c, LineCollection))
    plans = [ln for ln in ax.lines if ln.get_color() == "tab:purple"]
    assert plans and all(ln.get_zorder() > path.get_zorder() for ln in plans)


def test_the_long_course_is_laid_out(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    data = long_course()
    assert len(data.marks) == 12
    check_layout(_drawn(data, tmp_path, monkeypatch), data)


@pytest.mark.parametrize("seed", [3, 11, 27])
def test_a_random_world_is_laid_out(seed: int, tmp_path: Path,
                                    monkeypatch: pytest.MonkeyPatch) -> None:
    data = random_course(seed)
    check_layout(_drawn(data, tmp_path, monkeypatch), data)


def test_the_check_catches_a_label_over_the_path(tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    data = long_course()
    fig = _drawn(data, tmp_path, monkeypatch)
    ax = fig.axes[0]
    label = next(t for t in ax.texts if t.get_text())
    label.set_position(tuple(data.xy[len(data.xy) // 2]))
    with pytest.raises(AssertionError, match="covers the course"):
        check_layout(fig, data)
