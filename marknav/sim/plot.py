"""Top-down picture of a simulated run: marks with their colours and pass sides, the planned
Bézier curves, the driven path, and where bumps happened, with axes in millimetres.

Needs matplotlib (the ``plot`` extra).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from marknav.errors import InputError
from marknav.missions.report import RunReport
from marknav.missions.schema import Mission
from marknav.sim.camera import mark_bgr
from marknav.sim.environment import GroundTruth
from marknav.sim.world import World


def _rgb(bgr: Any) -> tuple[float, float, float]:
    b, g, r = (float(v) for v in np.asarray(bgr).reshape(-1)[:3])
    return (r / 255.0, g / 255.0, b / 255.0)


def _believed_to_true(
    pts: np.ndarray, believed: Any, truth: GroundTruth, ts: np.ndarray, t: float
) -> np.ndarray:
    """Move a plan made in the odometry frame to where the robot really was when it planned.

    Odometry drifts (wheel mismatch and slip are invisible to encoders), so a plan drawn in the
    believed frame would float away from the driven path; this draws it as the robot meant it.
    """
    if len(ts) == 0:
        return pts
    k = int(np.clip(np.searchsorted(ts, t), 0, len(ts) - 1))
    tx, ty = truth.xy[k]
    dth = truth.theta[k] - believed.theta
    c, s = np.cos(dth), np.sin(dth)
    rel = pts - np.array([believed.x, believed.y])
    return np.column_stack([tx + c * rel[:, 0] - s * rel[:, 1], ty + s * rel[:, 0] + c * rel[:, 1]])


def plot_run(
    mission: Mission,
    world: World,
    truth: GroundTruth,
    plans: Sequence[Any],
    report: RunReport,
    path: str | Path,
) -> None:
    """Write the picture to ``path`` (PNG, or any format matplotlib knows by the suffix)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.patches import Circle
    except ImportError:
        raise InputError("--plot needs matplotlib: pip install 'marknav[plot]'",
                         field="--plot") from None
    palette = {c.name: c for c in mission.palette()}
    fig, ax = plt.subplots(figsize=(7, 9), dpi=100)
    for wall in world.walls:
        (x1, y1), (x2, y2) = wall.segment()
        ax.plot([x1, x2], [y1, y2], color="0.3", lw=2)
    for box in world.boxes:
        xs, ys = zip(*[*box.corners(), box.corners()[0]], strict=True)
        ax.fill(xs, ys, color="0.7")
    clearance = mission.navigation.clearance_mm
    for i, m in enumerate(world.marks):
        colour = palette.get(m.colour)
        face = _rgb(mark_bgr(colour)) if colour is not None else (0.5, 0.5, 0.5)
        r = m.radius(mission.marks.radius_mm)
        ax.add_patch(Circle(m.xy, r, color=face, zorder=3))
        ax.add_patch(Circle(m.xy, clearance, fill=False, ls=":", color=face, zorder=2))
        side = mission.side_of(m.colour) if m.colour in palette else "?"
        ax.annotate(f"{i + 1}: {m.colour}\npass on its {side}", m.xy, xytext=(12, -4),
                    textcoords="offset points", fontsize=8)
    ts = np.asarray(truth.t)
    for k, rec in enumerate(plans):
        pts = _believed_to_true(rec.plan.sample(20.0), rec.plan.start_pose, truth, ts, rec.t)
        ax.plot(pts[:, 0], pts[:, 1], "--", color="tab:purple", lw=2, zorder=4,
                label="planned Bézier bypass (placed from the true pose)" if k == 0 else None)
    xy = np.asarray(truth.xy, dtype=float).reshape(-1, 2)
    if len(xy):
        ax.plot(xy[:, 0], xy[:, 1], color="black", lw=1.5, label="driven path (ground truth)")
        ax.plot(*xy[0], "o", color="black", ms=5)
        ax.plot(*xy[-1], "s", color="black", ms=5)
    for k, c in enumerate(truth.collisions):
        ax.plot(c["x_mm"], c["y_mm"], "X", color="red", ms=12, zorder=5,
                label="bump" if k == 0 else None)
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.grid(True, alpha=0.3)
    ax.set_title(f"{mission.name}: {report.outcome} ({report.reason})", fontsize=9)
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    try:
        fig.savefig(str(path))
    except OSError as exc:
        raise InputError(f"cannot write the plot: {exc}", file=str(path)) from None
    finally:
        plt.close(fig)
