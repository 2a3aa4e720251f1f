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
from typing import Any

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
    draw(data, path)


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


def _label_place(m: PlotMark, xy: np.ndarray, clearance: float) -> tuple[np.ndarray, str]:
    """Where a mark's label goes: outside its clearance circle, away from the path."""
    centre = np.asarray(m.xy, dtype=float)
    if len(xy):
        near = xy[int(np.argmin(np.hypot(*(xy - centre).T)))]
        d = centre - near
        n = float(np.hypot(*d))
        d = d / n if n > 1e-6 else np.array([1.0, 0.0])
    else:
        d = np.array([1.0, 0.0])
    d = np.array([math.copysign(1.0, d[0]) if abs(d[0]) > 0.2 else d[0], d[1] * 0.3])
    d /= float(np.hypot(*d)) or 1.0
    return centre + d * (max(clearance, m.radius_mm) + 60.0), "left" if d[0] >= 0 else "right"


def draw(data: PlotData, path: str | Path) -> None:
    """Render :class:`PlotData` to ``path``."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.collections import LineCollection
        from matplotlib.lines import Line2D
        from matplotlib.patches import Circle
        from matplotlib.ticker import MaxNLocator
    except ImportError:
        raise InputError("--plot needs matplotlib: pip install 'marknav[plot]'",
                         field="--plot") from None
    fig, ax = plt.subplots(figsize=(7.5, 10), dpi=100)
    for x1, y1, x2, y2 in data.walls:
        ax.plot([x1, x2], [y1, y2], color="0.3", lw=2)
    for corners in data.boxes:
        xs, ys = zip(*[*corners, corners[0]], strict=True)
        ax.fill(xs, ys, color="0.7")
    xy, ts = data.xy, data.t
    for m in data.marks:
        ax.add_patch(Circle(m.xy, m.radius_mm, color=m.rgb, zorder=3))
        ax.add_patch(Circle(m.xy, data.clearance_mm, fill=False, ls=":", color=m.rgb, zorder=2))
        where, ha = _label_place(m, xy, data.clearance_mm)
        ax.annotate(m.label, m.xy, xytext=tuple(where), ha=ha, va="center", fontsize=8,
                    zorder=6, bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": "0.7",
                                    "alpha": 0.85})
    handles: list[Any] = []
    for k, pts in enumerate(data.plans):
        ax.plot(pts[:, 0], pts[:, 1], color="tab:purple", lw=1.2, zorder=6, dashes=(4, 2))
        if k == 0:
            handles.append(Line2D([], [], color="tab:purple", lw=1.5, dashes=(4, 2),
                                  label=data.plan_label))
    if len(xy) > 1:
        segs = np.stack([xy[:-1], xy[1:]], axis=1)
        lc = LineCollection(list(segs), cmap="viridis", lw=2.0, zorder=5)
        lc.set_array(ts[1:])
        ax.add_collection(lc)
        cbar = fig.colorbar(lc, ax=ax, shrink=0.6, pad=0.02)
        cbar.set_label("time [s]")
        handles.append(Line2D([], [], color=plt.get_cmap("viridis")(0.6), lw=2,
                              label=f"{data.path_label}, coloured by time; arrows: direction"))
        # an arrow every ~5 s of travel shows which way each leg was driven
        step = max(1, int(len(ts) / max(1.0, (ts[-1] - ts[0]) / 5.0)))
        for k in range(step, len(xy) - 1, step):
            d = xy[k + 1] - xy[k]
            if float(np.hypot(*d)) < 1e-6:
                continue
            ax.annotate("", xy=tuple(xy[k] + d / np.hypot(*d) * 120.0), xytext=tuple(xy[k]),
                        arrowprops={"arrowstyle": "-|>", "color": "black", "lw": 1.2},
                        zorder=6)
        ax.plot(*xy[0], "o", color="black", ms=7, zorder=7)
        ax.plot(*xy[-1], "s", color="black", ms=7, zorder=7)
        handles.append(Line2D([], [], marker="o", color="black", ls="", label="start"))
        handles.append(Line2D([], [], marker="s", color="black", ls="",
                              label=f"end (t = {ts[-1]:.1f} s)"))
    for k, (bx, by) in enumerate(data.bumps):
        ax.plot(bx, by, "X", color="red", ms=12, zorder=8)
        if k == 0:
            handles.append(Line2D([], [], marker="X", color="red", ms=10, ls="", label="bump"))
    if data.marks:
        handles.append(Line2D([], [], marker="o", color="0.5", ls=":", mfc="0.5",
                              label=f"mark (#: waypoint) and its {data.clearance_mm:.0f} mm "
                                    "clearance"))
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.xaxis.set_major_locator(MaxNLocator(nbins=5))
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.grid(True, alpha=0.3)
    ax.set_title(data.title, fontsize=9)
    # below the axes, so it never hides a wall or the path
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.06), ncol=1,
              fontsize=8, handlelength=3.5, frameon=False)
    fig.tight_layout()
    try:
        fig.savefig(str(path), bbox_inches="tight")
    except OSError as exc:
        raise InputError(f"cannot write the plot: {exc}", file=str(path)) from None
    finally:
        plt.close(fig)
