"""Top-down picture of a run: marks (numbered by waypoint) with their colours, clearance circles
and pass sides, the planned Bézier curves, the driven path coloured by time with arrows for its
direction, start and end, and where bumps happened, with axes in millimetres.

Drawn from the objects of a finished simulator run (:func:`plot_run`) or from a run log alone
(:func:`plot_log`, ``marknav replay RUN --plot``): both build the same :class:`PlotData`.
Needs matplotlib (the ``plot`` extra).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import numpy as np

from marknav.core.errors import InputError


@dataclass
class PlotMark:
    xy: tuple[float, float]
    radius_mm: float
    rgb: tuple[float, float, float]
    label: str


@dataclass
class PlotData:
    """Everything the picture shows, in world millimetres."""

    title: str
    clearance_mm: float
    walls: list[list[float]] = field(default_factory=list)  # [x1, y1, x2, y2]
    boxes: list[list[list[float]]] = field(default_factory=list)  # corners
    marks: list[PlotMark] = field(default_factory=list)
    t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    xy: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    path_label: str = "driven path (ground truth)"
    plans: list[np.ndarray] = field(default_factory=list)
    plan_label: str = "planned Bézier bypass (placed from the true pose)"
    bumps: list[tuple[float, float]] = field(default_factory=list)


def _rgb(bgr: Any) -> tuple[float, float, float]:
    b, g, r = (float(v) for v in np.asarray(bgr).reshape(-1)[:3])
    return (r / 255.0, g / 255.0, b / 255.0)


def believed_to_true(pts: np.ndarray, start: tuple[float, float, float], ts: np.ndarray,
                     txy: np.ndarray, ttheta: np.ndarray, t: float) -> np.ndarray:
    """Move a plan made in the odometry frame to where the robot really was when it planned.

    Odometry drifts (wheel mismatch and slip are invisible to encoders), so a plan drawn in the
    believed frame would float away from the driven path; this draws it as the robot meant it.
    """
    if len(ts) == 0:
        return pts
    k = int(np.clip(np.searchsorted(ts, t), 0, len(ts) - 1))
    tx, ty = txy[k]
    dth = ttheta[k] - start[2]
    c, s = np.cos(dth), np.sin(dth)
    rel = pts - np.array([start[0], start[1]])
    return np.column_stack([tx + c * rel[:, 0] - s * rel[:, 1], ty + s * rel[:, 0] + c * rel[:, 1]])


def mark_labels(colours: Sequence[str], sides: dict[str, str], route: Sequence[str],
                waypoint_marks: Sequence[int | None]) -> list[str]:
    """``#1, #5 red — pass on its left`` for marks matched to waypoints, ``red (off course)``
    for the others (numbers are waypoint numbers, 1-based)."""
    by_mark: dict[int, list[int]] = {}
    for w, idx in enumerate(waypoint_marks):
        if idx is not None:
            by_mark.setdefault(int(idx), []).append(w + 1)
    out = []
    for i, colour in enumerate(colours):
        nums = by_mark.get(i)
        if nums:
            side = sides.get(colour, "?")
            out.append(f"{', '.join(f'#{n}' for n in nums)} {colour}\npass on its {side}")
        else:
            out.append(f"{colour} (off course)")
    return out


def plot_run(mission: Any, world: Any, truth: Any, plans: Sequence[Any], report: Any,
             path: str | Path, *, waypoint_marks: Sequence[int | None] | None = None) -> None:
    """Write the picture of a finished simulator run to ``path`` (PNG, or any format matplotlib
    knows by the suffix)."""
    draw(plot_data(mission, world, truth, plans, report, waypoint_marks=waypoint_marks), path)


def plot_data(mission: Any, world: Any, truth: Any, plans: Sequence[Any], report: Any, *,
              waypoint_marks: Sequence[int | None] | None = None) -> PlotData:
    """What the picture of a finished simulator run shows: the mission, its world, the true
    path (``truth``: ``t``, ``xy``, ``theta``, ``collisions``), the plans (``t``, ``plan``) and
    the report's outcome."""
    from marknav.sim.builtin_camera import mark_bgr

    palette = {c.name: c for c in mission.palette()}
    route = list(mission.route)
    sides = {c: mission.side_of(c) for c in palette}
    marks = list(world.marks)
    labels = mark_labels([m.colour for m in marks], sides, route,
                         list(waypoint_marks) if waypoint_marks is not None else [])
    ts = np.asarray(truth.t, dtype=float)
    txy = np.asarray(truth.xy, dtype=float).reshape(-1, 2)
    tth = np.asarray(truth.theta, dtype=float)
    data = PlotData(
        title=f"{mission.name}: {report.outcome} ({report.reason})",
        clearance_mm=mission.navigation.clearance_mm,
        walls=[[*w.segment()[0], *w.segment()[1]] for w in world.walls],
        boxes=[[list(c) for c in b.corners()] for b in world.boxes],
        marks=[PlotMark(m.xy, m.radius(mission.marks.radius_mm),
                        _rgb(mark_bgr(palette[m.colour])) if m.colour in palette
                        else (0.5, 0.5, 0.5), label) for m, label in zip(marks, labels,
                                                                         strict=True)],
        t=ts - (ts[0] if len(ts) else 0.0), xy=txy,
        plans=[believed_to_true(rec.plan.sample(20.0), (rec.plan.start_pose.x,
                                rec.plan.start_pose.y, rec.plan.start_pose.theta),
                                ts, txy, tth, rec.t) for rec in plans],
        bumps=[(c["x_mm"], c["y_mm"]) for c in truth.collisions],
    )
    return data


def plot_log(records: Sequence[dict[str, Any]], path: str | Path) -> None:
    """The same picture from a run log alone (``marknav replay RUN --plot FILE``)."""
    draw(plot_data_from_log(records), path)


def plot_data_from_log(records: Sequence[dict[str, Any]]) -> PlotData:
    """What the picture shows, from a run log's records (see :mod:`marknav.runs.records.runlog`)."""
    tree = next((r for r in records if r["kind"] == "tree"), None)
    if tree is None:
        raise InputError("the run log has no tree record: nothing to draw")
    mission = tree.get("mission", {})
    world = tree.get("world")
    ticks = [r for r in records if r["kind"] == "tick"]
    report: dict[str, Any] = next((r for r in reversed(records) if r["kind"] == "report"), {})
    end: dict[str, Any] = next((r for r in reversed(records) if r["kind"] == "end"), {})
    use_truth = bool(ticks) and "truth" in ticks[0]
    key = "truth" if use_truth else "pose"
    ts = np.asarray([r["t"] for r in ticks if key in r], dtype=float)
    poses = np.asarray([r[key] for r in ticks if key in r], dtype=float).reshape(-1, 3)
    colours = {k: tuple(c / 255.0 for c in reversed(v[:3]))
               for k, v in mission.get("colours", {}).items()}
    sides = dict(zip(mission.get("route", []), mission.get("sides", []), strict=False))
    data = PlotData(
        title=(f"{mission.get('name', '?')}: {end.get('outcome', 'unfinished')} "
               f"({end.get('reason', 'the log ends early')})"),
        clearance_mm=float(mission.get("clearance_mm", 0.0)),
        t=ts, xy=poses[:, :2],
        path_label="driven path (ground truth)" if use_truth else "driven path (odometry)",
        plan_label=("planned Bézier bypass (placed from the true pose)" if use_truth
                    else "planned Bézier bypass"),
        bumps=[(c["x_mm"], c["y_mm"]) for c in report.get("collision_points", [])],
    )
    if world is not None:
        labels = mark_labels([m["colour"] for m in world["marks"]], sides,
                             mission.get("route", []), report.get("waypoint_marks", []))
        data.walls = world.get("walls", [])
        data.boxes = world.get("boxes", [])
        data.marks = [PlotMark(tuple(m["xy"]), float(m["radius_mm"]),
                               colours.get(m["colour"], (0.5, 0.5, 0.5)), label)
                      for m, label in zip(world["marks"], labels, strict=True)]
    for r in ticks:
        for rec in r.get("bb", {}).get("/marknav/plans", []):
            plan = rec.get("plan", {})
            pts = np.asarray(plan.get("points", []), dtype=float).reshape(-1, 2)
            if not len(pts):
                continue
            if use_truth:
                s = plan["start"]
                pts = believed_to_true(pts, (s["x"], s["y"], s["theta"]), ts, poses[:, :2],
                                       poses[:, 2], float(r["t"]))
            data.plans.append(pts)
    return data


#: The largest plotting area (inches, width × height) a course is drawn in; the scale is
#: the one that fits the course, mark labels included, into it at equal aspect.
MAX_AXES_IN = (7.0, 9.0)
#: The smallest plotting width (inches): a narrow course still leaves room for its title.
MIN_AXES_WIDTH_IN = 3.0
#: Room around the plotting area (inches): tick labels and axis label on the left, the title
#: above, the colour bar on the right, tick labels, axis label and legend below.
MARGIN_IN = {"left": 1.0, "right": 1.1, "top": 0.45, "bottom": 0.7}
#: Space kept between a mark's clearance circle and its label (mm).
LABEL_GAP_MM = 60.0
#: Space between the data (labels included) and the plotting area's edge (fraction of the
#: larger extent): nothing touches the frame or sits among the tick marks.
EDGE_MARGIN = 0.03
#: Tick spacing at least this (inches) on x (tick labels such as "-1600" are ~0.45 in wide at
#: 10 pt) and y.
TICK_SPACING_IN = (0.9, 0.6)
#: Length of the direction arrows on the path (inches).
ARROW_IN = 0.15
#: The legend's top this far under the plotting area (inches): below the x tick labels and
#: the axis label.
LEGEND_BELOW_IN = 0.6
#: Layout passes: each one measures the labels at the previous scale (two settle it).
LAYOUT_PASSES = 3
#: Where a label may go around its mark, as directions (x, y); the one covering the least
#: is taken.
LABEL_DIRECTIONS = ((1.0, 0.0), (-1.0, 0.0), (0.7, 0.7), (-0.7, 0.7), (0.7, -0.7),
                    (-0.7, -0.7), (0.0, 1.0), (0.0, -1.0))


#: Points a wall is sampled at when labels are kept off it (more than a label's height
#: apart on the longest wall drawn at the smallest scale).
WALL_SAMPLES = 2000
#: How far out a label may go, in multiples of its nearest place (just outside the
#: clearance circle): beyond the path or a wall when nearer places are covered.
LABEL_REACHES = (1.0, 1.8, 2.8, 4.0)


def _label_candidates(m: PlotMark, clearance: float) -> list[tuple[np.ndarray, str, str]]:
    """Places for a mark's label, nearest first: outside its clearance circle in each
    direction, then farther out."""
    centre = np.asarray(m.xy, dtype=float)
    reach = max(clearance, m.radius_mm) + LABEL_GAP_MM
    out = []
    for times in LABEL_REACHES:
        for dx, dy in LABEL_DIRECTIONS:
            ha = "left" if dx > 0 else "right" if dx < 0 else "center"
            va = "bottom" if dy > 0 else "top" if dy < 0 else "center"
            out.append((centre + np.array([dx, dy]) * reach * times, ha, va))
    return out


def _extent(data: PlotData) -> tuple[float, float, float, float]:
    """x0, x1, y0, y1 of everything drawn in data coordinates (mm), labels apart."""
    xs: list[float] = []
    ys: list[float] = []
    for x1, y1, x2, y2 in data.walls:
        xs += [x1, x2]
        ys += [y1, y2]
    for corners in data.boxes:
        xs += [c[0] for c in corners]
        ys += [c[1] for c in corners]
    for m in data.marks:
        r = max(data.clearance_mm, m.radius_mm)
        xs += [m.xy[0] - r, m.xy[0] + r]
        ys += [m.xy[1] - r, m.xy[1] + r]
    for pts in [data.xy, *data.plans]:
        if len(pts):
            xs += [float(pts[:, 0].min()), float(pts[:, 0].max())]
            ys += [float(pts[:, 1].min()), float(pts[:, 1].max())]
    if not xs:
        return -1000.0, 1000.0, -1000.0, 1000.0
    return min(xs), max(xs), min(ys), max(ys)


def _obstacles(ax: Any, data: PlotData) -> np.ndarray:
    """Display points a label should not cover: the path, the plans, walls and the marks'
    clearance circles (sampled)."""
    pts: list[np.ndarray] = []
    for arr in [data.xy, *data.plans]:
        if len(arr) > 1:
            fine = np.linspace(0, len(arr) - 1, max(2, 4 * len(arr)))
            pts.append(np.column_stack([np.interp(fine, np.arange(len(arr)), arr[:, 0]),
                                        np.interp(fine, np.arange(len(arr)), arr[:, 1])]))
    for x1, y1, x2, y2 in data.walls:
        f = np.linspace(0.0, 1.0, WALL_SAMPLES)[:, None]
        pts.append(np.array([x1, y1]) + f * np.array([x2 - x1, y2 - y1]))
    a = np.linspace(0.0, 2 * math.pi, 48)
    for m in data.marks:
        r = max(data.clearance_mm, m.radius_mm)
        pts.append(np.column_stack([m.xy[0] + r * np.cos(a), m.xy[1] + r * np.sin(a)]))
        pts.append(np.asarray([m.xy], dtype=float))
    if not pts:
        return np.zeros((0, 2))
    return np.asarray(ax.transData.transform(np.concatenate(pts)))


def _covered(box: Any, points: np.ndarray) -> int:
    if not len(points):
        return 0
    return int(((points[:, 0] > box.x0) & (points[:, 0] < box.x1)
                & (points[:, 1] > box.y0) & (points[:, 1] < box.y1)).sum())


def _overlap(a: Any, b: Any) -> float:
    w = min(a.x1, b.x1) - max(a.x0, b.x0)
    h = min(a.y1, b.y1) - max(a.y0, b.y0)
    return max(0.0, w) * max(0.0, h)


def _place_labels(ax: Any, data: PlotData, labels: list[Any], renderer: Any) -> None:
    """Each label where it covers the fewest path, wall and mark points and overlaps the
    labels placed before it least (greedy, in mark order)."""
    points = _obstacles(ax, data)
    placed: list[Any] = []
    for m, label in zip(data.marks, labels, strict=True):
        best: tuple[tuple[int, float, int], tuple[np.ndarray, str, str]] | None = None
        for order, cand in enumerate(_label_candidates(m, data.clearance_mm)):
            label.set_position(tuple(cand[0]))
            label.set_ha(cand[1])
            label.set_va(cand[2])
            box = label.get_window_extent(renderer)
            # first what it covers, then how much of other labels, then the nearest place
            cost = (_covered(box, points), sum(_overlap(box, p) for p in placed), order)
            if best is None or cost < best[0]:
                best = (cost, cand)
        assert best is not None
        label.set_position(tuple(best[1][0]))
        label.set_ha(best[1][1])
        label.set_va(best[1][2])
        placed.append(label.get_window_extent(renderer))


def _fit(fig: Any, ax: Any, data: PlotData, labels: list[Any], renderer: Any) -> None:
    """Limits that hold the data and the labels, and a figure sized so the plotting area
    shows them at equal aspect within :data:`MAX_AXES_IN`."""
    x0, x1, y0, y1 = _extent(data)
    for label in labels:
        box = label.get_window_extent(renderer).transformed(ax.transData.inverted())
        x0, x1 = min(x0, box.x0), max(x1, box.x1)
        y0, y1 = min(y0, box.y0), max(y1, box.y1)
    pad = EDGE_MARGIN * max(x1 - x0, y1 - y0)
    x0, x1, y0, y1 = x0 - pad, x1 + pad, y0 - pad, y1 + pad
    mm_per_in = max((x1 - x0) / MAX_AXES_IN[0], (y1 - y0) / MAX_AXES_IN[1])
    width_in, height_in = (x1 - x0) / mm_per_in, (y1 - y0) / mm_per_in
    if width_in < MIN_AXES_WIDTH_IN:  # widen the view, not the scale
        extra = (MIN_AXES_WIDTH_IN - width_in) * mm_per_in / 2.0
        x0, x1, width_in = x0 - extra, x1 + extra, MIN_AXES_WIDTH_IN
    fig_w = MARGIN_IN["left"] + width_in + MARGIN_IN["right"]
    fig_h = MARGIN_IN["bottom"] + height_in + MARGIN_IN["top"]
    fig.set_size_inches(fig_w, fig_h)
    ax.set_position([MARGIN_IN["left"] / fig_w, MARGIN_IN["bottom"] / fig_h,
                     width_in / fig_w, height_in / fig_h])
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)


def _ticks(ax: Any) -> None:
    """As many ticks as fit the plotting area at :data:`TICK_SPACING_IN` apart."""
    from matplotlib.ticker import MaxNLocator

    pos = ax.get_position()
    fig_w, fig_h = ax.figure.get_size_inches()
    ax.xaxis.set_major_locator(MaxNLocator(
        nbins=max(2, int(pos.width * fig_w / TICK_SPACING_IN[0])), steps=[1, 2, 2.5, 5, 10]))
    ax.yaxis.set_major_locator(MaxNLocator(
        nbins=max(2, int(pos.height * fig_h / TICK_SPACING_IN[1])), steps=[1, 2, 2.5, 5, 10]))


def _path_marks(fig: Any, ax: Any, data: PlotData, lc: Any, handles: list[Any]) -> None:
    """The colour bar (right of the plotting area), direction arrows, start and end."""
    from matplotlib.lines import Line2D

    xy, ts = data.xy, data.t
    pos = ax.get_position()
    fig_w, fig_h = fig.get_size_inches()
    cax = fig.add_axes((pos.x1 + 0.15 / fig_w, pos.y0, 0.18 / fig_w, pos.height * 0.6))
    cbar = fig.colorbar(lc, cax=cax)
    cbar.set_label("time [s]")
    # an arrow every ~5 s of travel shows which way each leg was driven
    step = max(1, int(len(ts) / max(1.0, (ts[-1] - ts[0]) / 5.0)))
    arrow_mm = ARROW_IN * (ax.get_ylim()[1] - ax.get_ylim()[0]) / (pos.height * fig_h)
    for k in range(step, len(xy) - 1, step):
        d = xy[k + 1] - xy[k]
        if float(np.hypot(*d)) < 1e-6:
            continue
        ax.annotate("", xy=tuple(xy[k] + d / np.hypot(*d) * arrow_mm), xytext=tuple(xy[k]),
                    arrowprops={"arrowstyle": "-|>", "color": "black", "lw": 1.2}, zorder=6)
    ax.plot(*xy[0], "o", color="black", ms=7, zorder=8)
    ax.plot(*xy[-1], "s", color="black", ms=7, zorder=8)
    handles.append(Line2D([], [], marker="o", color="black", ls="", label="start"))
    handles.append(Line2D([], [], marker="s", color="black", ls="",
                          label=f"end (t = {ts[-1]:.1f} s)"))


def draw(data: PlotData, path: str | Path) -> None:
    """Render :class:`PlotData` to ``path``: the course at equal aspect, scaled to fit
    :data:`MAX_AXES_IN` with every mark label inside the plotting area where it covers least;
    the colour bar to the right of it and the legend under it, never over the course."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.patheffects as pe
        import matplotlib.pyplot as plt
        from matplotlib.collections import LineCollection
        from matplotlib.lines import Line2D
        from matplotlib.patches import Circle
    except ImportError:
        raise InputError("--plot needs matplotlib: pip install 'marknav[plot]'",
                         field="--plot") from None
    fig = plt.figure(figsize=(7.5, 10), dpi=100)
    ax = fig.add_axes((0.1, 0.1, 0.8, 0.8))
    for x1, y1, x2, y2 in data.walls:
        ax.plot([x1, x2], [y1, y2], color="0.3", lw=2)
    for corners in data.boxes:
        xs, ys = zip(*[*corners, corners[0]], strict=True)
        ax.fill(xs, ys, color="0.7")
    xy, ts = data.xy, data.t
    labels = []
    for m in data.marks:
        ax.add_patch(Circle(m.xy, m.radius_mm, color=m.rgb, zorder=3))
        ax.add_patch(Circle(m.xy, data.clearance_mm, fill=False, ls=":", color=m.rgb, zorder=2))
        labels.append(ax.text(*m.xy, m.label, fontsize=8, zorder=9,
                              bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": "0.7",
                                    "alpha": 0.85}))
    handles: list[Any] = []
    lc = None
    if len(xy) > 1:
        segs = np.stack([xy[:-1], xy[1:]], axis=1)
        lc = LineCollection(list(segs), cmap="viridis", lw=2.0, zorder=5)
        lc.set_array(ts[1:])
        ax.add_collection(lc)
        handles.append(Line2D([], [], color=plt.get_cmap("viridis")(0.6), lw=2,
                              label=f"{data.path_label}, coloured by time; arrows: direction"))
    # the plans above the path (they start on it), with a white edge to stand out from it
    outline = [pe.Stroke(linewidth=3.0, foreground="white"), pe.Normal()]
    for k, pts in enumerate(data.plans):
        ax.plot(pts[:, 0], pts[:, 1], color="tab:purple", lw=1.4, zorder=7, dashes=(4, 2),
                path_effects=outline)
        if k == 0:
            handles.insert(0, Line2D([], [], color="tab:purple", lw=1.5, dashes=(4, 2),
                                     label=data.plan_label))
    ax.set_aspect("equal", adjustable="box")
    renderer = cast(Any, fig.canvas).get_renderer()  # Agg's
    for _ in range(LAYOUT_PASSES):  # the labels' size in mm depends on the scale
        _fit(fig, ax, data, labels, renderer)
        _place_labels(ax, data, labels, renderer)
    _fit(fig, ax, data, labels, renderer)
    _ticks(ax)
    if lc is not None:
        _path_marks(fig, ax, data, lc, handles)
    for k, (bx, by) in enumerate(data.bumps):
        ax.plot(bx, by, "X", color="red", ms=12, zorder=8)
        if k == 0:
            handles.append(Line2D([], [], marker="X", color="red", ms=10, ls="", label="bump"))
    if data.marks:
        handles.append(Line2D([], [], marker="o", color="0.5", ls=":", mfc="0.5",
                              label=f"mark (#: waypoint) and its {data.clearance_mm:.0f} mm "
                                    "clearance"))
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.grid(True, alpha=0.3)
    ax.set_title(data.title, fontsize=9, wrap=True)
    # below the axes and their tick labels, so it never hides a wall or the path
    below = LEGEND_BELOW_IN / (ax.get_position().height * fig.get_size_inches()[1])
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -below), ncol=1,
              fontsize=8, handlelength=3.5, frameon=False)
    try:
        fig.savefig(str(path), bbox_inches="tight")
    except OSError as exc:
        raise InputError(f"cannot write the plot: {exc}", file=str(path)) from None
    finally:
        plt.close(fig)
