"""Position accuracy: the paper's Fig. 13 experiment in the simulator — a mark placed at every
point of a grid in front of the camera, its position estimated from many rendered frames and
compared with the truth (eq. 40's error) — run with a mission's camera, range law and mark, or a
default camera; the resulting table as text and as a plot of error against distance.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from marknav.core.errors import InputError
from marknav.core.figures import save_figure
from marknav.runs.metrics.position_accuracy import DEFAULT_XS_MM, DEFAULT_YS_MM

__all__ = ["ACCURACY_GRIDS", "AccuracyResult", "format_accuracy", "plot_accuracy",
           "position_accuracy"]

#: Grids of the accuracy experiment (x across, y ahead; mm). "paper" is Fig. 13's span.
ACCURACY_GRIDS: dict[str, tuple[tuple[float, ...], tuple[float, ...]]] = {
    "paper": (DEFAULT_XS_MM, DEFAULT_YS_MM),
    "coarse": ((-300.0, 0.0, 300.0), (500.0, 1000.0, 2000.0, 3000.0)),
}


@dataclass(frozen=True)
class AccuracyResult:
    """The Fig. 13 table and what it was measured with."""

    table: Any  # marknav.runs.metrics.position_accuracy.AccuracyTable
    source: str  # the mission path, or "default camera"
    grid: str
    focal_px: float
    mark_radius_mm: float

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"source": self.source, "grid": self.grid,
                             "focal_px": self.focal_px, "mark_radius_mm": self.mark_radius_mm}
        d.update(self.table.to_dict())
        return d


def position_accuracy(mission_path: str | None = None, *, frames: int = 100,
                      grid: str = "paper", seed: int = 0) -> AccuracyResult:
    """The paper's Fig. 13 experiment in the simulator
    (:func:`marknav.runs.metrics.position_accuracy.
    accuracy_table`): with a mission, its camera, range model, mark radius, palette and first
    route colour; without, a pinhole camera f = 590 px and a 100 mm red mark."""
    from marknav.runs.metrics.position_accuracy import accuracy_table
    from marknav.sim.builtin_camera import CameraConfig

    if frames < 1:
        raise InputError(f"must be at least 1, got {frames}", field="--frames")
    if grid not in ACCURACY_GRIDS:
        raise InputError(f"unknown grid {grid!r} ({', '.join(ACCURACY_GRIDS)})", field="--grid")
    xs, ys = ACCURACY_GRIDS[grid]
    if mission_path is None:
        table = accuracy_table(xs_mm=xs, ys_mm=ys, frames=frames, seed=seed)
        return AccuracyResult(table, "default camera", grid, CameraConfig().focal_px, 100.0)

    from marknav.missions.camera import range_model_of
    from marknav.missions.schema import load_mission

    mission = load_mission(mission_path)
    cam = mission.camera
    table = accuracy_table(
        xs_mm=xs, ys_mm=ys, frames=frames, model=range_model_of(mission),
        camera=CameraConfig(width=cam.width, height=cam.height, focal_px=cam.focal_px),
        mark_radius_mm=mission.marks.radius_mm, colour=mission.route[0],
        palette=mission.palette(), seed=seed)
    return AccuracyResult(table, mission_path, grid, cam.focal_px, mission.marks.radius_mm)


def format_accuracy(result: AccuracyResult) -> str:
    """The accuracy table as text, one row per distance."""
    t = result.table
    lines = [
        f"Position error (paper eq. 40) against ground truth, {result.source}: {t.model}, "
        f"{t.frames_per_point} frames per point, grid {result.grid}",
        f"{'y mm':>6} {'points':>6} {'median mm':>10} {'p95 mm':>8} {'max mm':>8} "
        f"{'median %':>9} {'missed':>7}",
    ]
    for row in t.rows:
        if row.points == 0:
            lines.append(f"{row.y_mm:6.0f} {0:6d} {'—':>10} {'—':>8} {'—':>8} {'—':>9} "
                         f"{row.missed:7d}")
            continue
        lines.append(f"{row.y_mm:6.0f} {row.points:6d} {row.median_mm:10.1f} {row.p95_mm:8.1f} "
                     f"{row.max_mm:8.1f} {100.0 * row.median_rel:9.2f} {row.missed:7d}")
    lines.append(f"grid points not wholly in view (skipped): {t.skipped}; frames in which the "
                 f"detector missed the mark: {t.missed}")
    return "\n".join(lines)


def plot_accuracy(result: AccuracyResult, out: str | Path) -> None:
    """Error against distance: median, 95th percentile and maximum of eq. 40's error per
    distance (mm, left) and the median as a share of the distance (right), with the range error
    that half a pixel of radius error causes (δd ≈ d²·δr / (f·R)) for scale."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise InputError("--plot needs matplotlib: pip install 'marknav[plot]'",
                         field="--plot") from None
    rows = [r for r in result.table.rows if r.points > 0]
    if not rows:
        raise InputError("no grid point had the mark in view: nothing to plot", field="--plot")
    y = np.array([r.y_mm for r in rows])
    med = np.array([r.median_mm for r in rows])
    p95 = np.array([r.p95_mm for r in rows])
    mx = np.array([r.max_mm for r in rows])
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(11.0, 4.4), dpi=100)
    ax.fill_between(y, med, p95, alpha=0.25, label="median … 95th percentile")
    ax.plot(y, med, "o-", label="median")
    ax.plot(y, p95, "s--", label="95th percentile")
    ax.plot(y, mx, "^:", label="maximum")
    dense = np.linspace(float(y.min()), float(y.max()), 200)
    ax.plot(dense, dense**2 * 0.5 / (result.focal_px * result.mark_radius_mm), "-",
            color="grey", lw=1, label="δd for δr = 0.5 px")
    ax.set_xlabel("distance ahead y [mm]")
    ax.set_ylabel("position error e (eq. 40) [mm]")
    ax.grid(True, alpha=0.3)
    # below the axes: the curves rise to the upper right corner, where 'best' would put it
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=3,
              frameon=False)
    ax2.plot(y, 100.0 * med / y, "o-")
    ax2.set_xlabel("distance ahead y [mm]")
    ax2.set_ylabel("median error [% of distance]")
    ax2.set_ylim(bottom=0)
    ax2.grid(True, alpha=0.3)
    t = result.table
    fig.suptitle(f"Position accuracy ({result.source}; {t.model}; {t.frames_per_point} frames "
                 "per point)", fontsize=10)
    save_figure(fig, out)
