"""Range error through a distorted lens, with and without undistorting the detections.

:func:`lens_range_errors` renders a mark through each lens (:class:`marknav.sim.lens.Lens`) at
each distance and at positions across the whole image width (the marks stand at camera height,
so they lie on the principal point's row), finds it with the real detector, and estimates its
range (distance along the camera axis) with the pinhole law of the camera's focal length — once
from the raw detection, once after :func:`marknav.vision.undistort.undistort_mark`. Positions
whose mark is not wholly inside the distorted image are skipped.
:func:`plot_lens_errors` draws the relative errors against the mark's image column.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from marknav.planning.kinematics import Pose
from marknav.sim.builtin_camera import CameraConfig, Renderer
from marknav.sim.lens import Lens
from marknav.sim.world.schema import Background, Conditions, MarkSpec, World
from marknav.vision.detect import Detector
from marknav.vision.estimate import Pinhole, estimate
from marknav.vision.palette import DEFAULT_PALETTE
from marknav.vision.undistort import Intrinsics, undistort_mark

__all__ = ["LensSample", "lens_range_errors", "plot_lens_errors"]


@dataclass(frozen=True)
class LensSample:
    """One detection: the lens's k1, the true distance, the image column it was seen at, and the
    relative range errors (estimate / truth − 1) raw and after undistortion."""

    k1: float
    distance_mm: float
    u_px: float
    raw: float
    undistorted: float


def _distort(points: np.ndarray, intr: Intrinsics) -> np.ndarray:
    norm = np.stack([(points[:, 0] - intr.cx) / intr.fx, (points[:, 1] - intr.cy) / intr.fy,
                     np.ones(len(points))], axis=1)
    out, _ = cv2.projectPoints(norm, np.zeros(3), np.zeros(3), intr.matrix, intr.coefficients)
    return np.asarray(out, dtype=np.float64).reshape(-1, 2)


def lens_range_errors(lenses: Sequence[Lens], *,
                      distances_mm: Sequence[float] = (500.0, 1000.0, 1500.0, 2000.0, 2500.0,
                                                       3000.0),
                      columns: int = 9, frames: int = 2, camera: CameraConfig | None = None,
                      mark_radius_mm: float = 100.0, seed: int = 0) -> list[LensSample]:
    """Every detection's raw and undistorted relative range error (see the module doc)."""
    camera = camera if camera is not None else CameraConfig()
    palette = DEFAULT_PALETTE
    detector = Detector(palette)
    model = Pinhole(camera.focal_px, mark_radius_mm)
    robot = Pose(0.0, 0.0, math.pi / 2.0)
    rng = np.random.default_rng([seed, 0x1E45])
    out: list[LensSample] = []
    for lens in lenses:
        cond = Conditions(lens=lens)
        probe = Renderer(World(conditions=cond, background=Background(seed=seed)), palette,
                         camera)
        intr = probe.intrinsics
        for d in distances_mm:
            r_px = camera.focal_px * mark_radius_mm / d
            for q in np.linspace(0.0, 1.0, columns):
                # Aim the mark at a column of the distorted image, then place it in the world.
                u_target = r_px + 2.0 + q * (camera.width - 1 - 2.0 * r_px - 4.0)
                ideal = _undistort_column(u_target, intr)
                x = (ideal - intr.cx) / camera.focal_px * d
                mark = MarkSpec(colour="red", x_mm=float(x), y_mm=float(d),
                                radius_mm=mark_radius_mm)
                world = World(marks=(mark,), conditions=cond, background=Background(seed=seed))
                renderer = Renderer(world, palette, camera)
                seen = renderer.project(robot)
                if not seen:
                    continue
                rim = _distort(seen[0].polygon, intr)
                if (rim[:, 0].min() < 1 or rim[:, 1].min() < 1 or rim[:, 0].max() > camera.width - 2
                        or rim[:, 1].max() > camera.height - 2):
                    continue
                for _ in range(frames):
                    found = [m for m in detector.detect(renderer.render(robot, rng))
                             if m.colour == "red"]
                    if not found:
                        continue
                    m = min(found, key=lambda m: abs(m.x - u_target))
                    raw = estimate(x_px=m.x, radius_px=m.radius, cx=intr.cx, model=model,
                                   mark_radius_mm=mark_radius_mm)
                    um = undistort_mark(m, intr)
                    und = estimate(x_px=um.x, radius_px=um.radius, cx=intr.cx, model=model,
                                   mark_radius_mm=mark_radius_mm)
                    out.append(LensSample(k1=lens.k1, distance_mm=float(d), u_px=m.x,
                                          raw=raw.distance_mm / d - 1.0,
                                          undistorted=und.distance_mm / d - 1.0))
    return out


def _undistort_column(u: float, intr: Intrinsics) -> float:
    from marknav.vision.undistort import undistort_points

    return float(undistort_points([(u, intr.cy)], intr)[0, 0])


def plot_lens_errors(samples: Sequence[LensSample], out: str | Path) -> None:
    """Relative range error against image column, raw and undistorted, coloured by k1."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), dpi=100, sharey=True)
    k1 = np.array([s.k1 for s in samples])
    u = np.array([s.u_px for s in samples])
    for ax, key, title in ((axes[0], "raw", "raw detections"),
                           (axes[1], "undistorted", "detections undistorted")):
        e = np.array([getattr(s, key) for s in samples]) * 100.0
        sc = ax.scatter(u, e, c=k1, cmap="viridis", s=10)
        p95 = float(np.percentile(np.abs(e), 95))
        ax.set_title(f"{title}: |error| p95 {p95:.2f} %, max {np.abs(e).max():.2f} %",
                     fontsize=9)
        ax.set_xlabel("mark's image column u [px]")
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("range error (pinhole law) [%]")
    fig.colorbar(sc, ax=axes, label="k1")
    fig.suptitle("Rendered through webcam lenses (k1 −0.4…0, k2, p1, p2, principal point off "
                 "centre), marks 0.5–3 m", fontsize=10)
    fig.savefig(str(out))
    plt.close(fig)
