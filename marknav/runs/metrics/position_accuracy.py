"""Accuracy of a mark's position estimate against ground truth: the paper's Fig. 13 in simulation.

The paper (§5) placed a mark at many positions in front of the robot, took 100 measurements at
each with the camera and compared them with a laser scanner using the error of eq. 40,
e = √((x_visual − x_true)² + (y_visual − y_true)²). Here the simulator is the laser scanner:
:func:`accuracy_table` puts one mark at each grid point (x across, y ahead of the camera, mm),
renders ``frames`` noisy frames, finds the mark with the real detector, estimates its position
with :func:`marknav.vision.estimate.estimate` (range model: the pinhole model of eq. 2 with the
camera's focal length and the mark's radius unless another is given) and reports eq. 40's error
per distance y: median, 95th percentile and maximum, with the grid points skipped because the mark
is not wholly inside the image and the frames in which the detector missed it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from marknav.planning.kinematics import Pose
from marknav.sim.builtin_camera import CameraConfig, Renderer
from marknav.sim.world.schema import Background, Conditions, MarkSpec, World
from marknav.vision.detect import Detector
from marknav.vision.estimate import Pinhole, RangeModel, estimate
from marknav.vision.palette import DEFAULT_PALETTE, ColourRange

__all__ = ["DEFAULT_XS_MM", "DEFAULT_YS_MM", "AccuracyRow", "AccuracyTable", "accuracy_table"]

#: The paper's Fig. 13 span: x from −600 to 600 mm, y from 500 to 3000 mm.
DEFAULT_XS_MM: tuple[float, ...] = tuple(float(x) for x in range(-600, 601, 200))
DEFAULT_YS_MM: tuple[float, ...] = tuple(float(y) for y in range(500, 3001, 250))


@dataclass(frozen=True)
class AccuracyRow:
    """Eq. 40's error over every frame of every grid point at one distance ``y_mm``."""

    y_mm: float
    points: int  # grid points measured at this distance
    skipped: int  # grid points whose mark was not wholly in view
    frames: int  # frames rendered at the measured points
    missed: int  # frames in which the detector did not find the mark
    median_mm: float
    p95_mm: float
    max_mm: float

    @property
    def median_rel(self) -> float:
        """Median error as a fraction of the distance."""
        return self.median_mm / self.y_mm

    def to_dict(self) -> dict[str, Any]:
        return {
            "y_mm": self.y_mm,
            "points": self.points,
            "skipped": self.skipped,
            "frames": self.frames,
            "missed": self.missed,
            "median_mm": round(self.median_mm, 2),
            "p95_mm": round(self.p95_mm, 2),
            "max_mm": round(self.max_mm, 2),
            "median_rel": round(self.median_rel, 5),
        }


@dataclass(frozen=True)
class AccuracyTable:
    """One row per distance, nearest first, and what produced them."""

    rows: tuple[AccuracyRow, ...]
    model: str
    frames_per_point: int

    @property
    def skipped(self) -> int:
        return sum(r.skipped for r in self.rows)

    @property
    def missed(self) -> int:
        return sum(r.missed for r in self.rows)

    def to_dict(self) -> dict[str, Any]:
        return {
            "model": self.model,
            "frames_per_point": self.frames_per_point,
            "skipped_points": self.skipped,
            "missed_frames": self.missed,
            "rows": [r.to_dict() for r in self.rows],
        }


def _describe(model: RangeModel) -> str:
    if isinstance(model, Pinhole):
        return f"pinhole f={model.focal_px:g} px R={model.radius_mm:g} mm"
    a, b = getattr(model, "a", None), getattr(model, "b", None)
    if a is not None and b is not None:
        return f"power a={a:.6g} b={b:.6g}"
    return type(model).__name__


def accuracy_table(
    *,
    xs_mm: Sequence[float] = DEFAULT_XS_MM,
    ys_mm: Sequence[float] = DEFAULT_YS_MM,
    frames: int = 100,
    model: RangeModel | None = None,
    conditions: Conditions | None = None,
    camera: CameraConfig | None = None,
    mark_radius_mm: float = 100.0,
    yaw_deg: float = 0.0,
    colour: str = "red",
    palette: Sequence[ColourRange] = DEFAULT_PALETTE,
    seed: int = 0,
) -> AccuracyTable:
    """The Fig. 13 experiment: position error (eq. 40) per distance over an x × y grid.

    Positions are relative to the camera (x to the right, y ahead, mm); the robot faces +y.
    ``model`` defaults to ``Pinhole(camera.focal_px, mark_radius_mm)``, ``conditions`` to the
    default :class:`Conditions` (noise σ 2), ``camera`` to :class:`CameraConfig`. ``yaw_deg`` 0
    keeps the disc parallel to the image plane (the paper's set-up). A grid point is skipped
    when the mark's outline is not wholly inside the image (1 px margin).
    """
    if frames < 1:
        raise ValueError(f"frames must be ≥ 1, got {frames}")
    camera = camera if camera is not None else CameraConfig()
    conditions = conditions if conditions is not None else Conditions()
    model = model if model is not None else Pinhole(camera.focal_px, mark_radius_mm)
    if colour not in {c.name for c in palette}:
        raise ValueError(f"colour {colour!r} is not in the palette")
    palette = tuple(palette)
    detector = Detector(palette)
    rng = np.random.default_rng([seed, 0xF16])
    robot = Pose(0.0, 0.0, math.pi / 2.0)
    rows: list[AccuracyRow] = []
    for y in sorted(ys_mm):
        errors: list[float] = []
        points = skipped = missed = rendered = 0
        for x in xs_mm:
            mark = MarkSpec(colour=colour, x_mm=float(x),
                            y_mm=float(y) + camera.forward_offset_mm, yaw_deg=yaw_deg,
                            radius_mm=mark_radius_mm)
            world = World(marks=(mark,), conditions=conditions, background=Background(seed=seed))
            renderer = Renderer(world, palette, camera)
            seen = renderer.project(robot)
            if not seen or not seen[0].inside(camera, margin_px=1.0):
                skipped += 1
                continue
            points += 1
            truth_u = seen[0].u
            for _ in range(frames):
                rendered += 1
                found = [m for m in detector.detect(renderer.render(robot, rng))
                         if m.colour == colour]
                if not found:
                    missed += 1
                    continue
                best = min(found, key=lambda m: abs(m.x - truth_u))
                est = estimate(x_px=best.x, radius_px=best.radius, minor_px=best.axes[1],
                               cx=camera.cx, model=model, mark_radius_mm=mark_radius_mm)
                # Eq. 40 in the camera frame: forward = y, left = −x.
                errors.append(math.hypot(est.forward_mm - float(y), est.left_mm + float(x)))
        arr = np.asarray(errors) if errors else np.asarray([math.nan])
        rows.append(AccuracyRow(
            y_mm=float(y), points=points, skipped=skipped, frames=rendered, missed=missed,
            median_mm=float(np.median(arr)), p95_mm=float(np.percentile(arr, 95)),
            max_mm=float(np.max(arr)),
        ))
    return AccuracyTable(rows=tuple(rows), model=_describe(model), frames_per_point=frames)
