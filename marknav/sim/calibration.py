"""The paper's range calibration (§4.5, Table 1, eq. 19) reproduced in the simulator.

A mark is placed straight ahead of the camera (its axis through the mark's centre) at 2000 mm,
then 1900 mm, … down to 300 mm; at each distance the simulator renders frames, the real detector
(:mod:`marknav.vision.detect`) measures the mark's radius, and the rows (radius_px, distance_mm)
are what the paper's Table 1 holds. :func:`sim_calibration_fit` fits them with the real
calibration (:func:`marknav.vision.calibrate.fit_power_law`), as ``marknav calibrate --sim`` does.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Callable, Sequence

import numpy as np

from marknav.core.errors import MissionFailed
from marknav.planning.kinematics import Pose
from marknav.sim.builtin_camera import CameraConfig, Renderer
from marknav.sim.world.schema import Background, Conditions, MarkSpec, World
from marknav.vision.calibrate import PowerFit, fit_power_law
from marknav.vision.detect import Detector
from marknav.vision.palette import DEFAULT_PALETTE, ColourRange

__all__ = ["TABLE1_DISTANCES_MM", "sim_calibration_fit", "sim_calibration_table"]

#: The distances of the paper's Table 1: 2000 mm down to 300 mm in 100 mm steps.
TABLE1_DISTANCES_MM: tuple[float, ...] = tuple(float(d) for d in range(2000, 299, -100))


def sim_calibration_table(
    *,
    distances_mm: Sequence[float] = TABLE1_DISTANCES_MM,
    camera: CameraConfig | None = None,
    mark_radius_mm: float = 100.0,
    colour: str = "red",
    palette: Sequence[ColourRange] = DEFAULT_PALETTE,
    conditions: Conditions | None = None,
    frames: int = 1,
    seed: int = 0,
    on_row: Callable[[int, int], object] | None = None,
) -> list[tuple[float, float]]:
    """Rows ``(radius_px, distance_mm)``: the detected radius (median over ``frames`` noisy
    frames) of a mark straight ahead of the camera at each distance. ``camera`` defaults to
    :class:`CameraConfig` (640×480, f = 590 px), ``conditions`` to the default
    :class:`Conditions` (noise σ 2); the background is drawn from ``seed``. ``on_row(done,
    total)`` is called after each distance.

    Raises :class:`~marknav.core.errors.MissionFailed` if the detector misses the mark at a
    distance.
    """
    if frames < 1:
        raise ValueError(f"frames must be ≥ 1, got {frames}")
    camera = camera if camera is not None else CameraConfig()
    conditions = conditions if conditions is not None else Conditions()
    if colour not in {c.name for c in palette}:
        raise ValueError(f"colour {colour!r} is not in the palette")
    palette = tuple(palette)
    detector = Detector(palette)
    rng = np.random.default_rng([seed, 0xCA1])
    robot = Pose(0.0, 0.0, math.pi / 2.0)
    rows: list[tuple[float, float]] = []
    for d in distances_mm:
        # The camera sits forward_offset_mm ahead of the robot's centre: measure from the camera.
        mark = MarkSpec(colour=colour, x_mm=0.0, y_mm=float(d) + camera.forward_offset_mm,
                        radius_mm=mark_radius_mm)
        world = World(marks=(mark,), conditions=conditions, background=Background(seed=seed))
        renderer = Renderer(world, palette, camera)
        radii: list[float] = []
        for _ in range(frames):
            found = detector.detect(renderer.render(robot, rng))
            found = [m for m in found if m.colour == colour]
            if found:
                best = min(found, key=lambda m: math.hypot(m.x - camera.cx, m.y - camera.cy))
                radii.append(best.radius)
        if not radii:
            raise MissionFailed(
                f"simulated calibration: the detector did not find the {colour} mark "
                f"{d:g} mm ahead"
            )
        rows.append((float(statistics.median(radii)), float(d)))
        if on_row is not None:
            on_row(len(rows), len(distances_mm))
    return rows


def sim_calibration_fit(
    *,
    distances_mm: Sequence[float] = TABLE1_DISTANCES_MM,
    camera: CameraConfig | None = None,
    mark_radius_mm: float = 100.0,
    colour: str = "red",
    palette: Sequence[ColourRange] = DEFAULT_PALETTE,
    conditions: Conditions | None = None,
    frames: int = 1,
    seed: int = 0,
) -> PowerFit:
    """:func:`sim_calibration_table` fitted with the power law of eq. 19."""
    rows = sim_calibration_table(
        distances_mm=distances_mm, camera=camera, mark_radius_mm=mark_radius_mm, colour=colour,
        palette=palette, conditions=conditions, frames=frames, seed=seed,
    )
    return fit_power_law([r for r, _ in rows], [d for _, d in rows])
