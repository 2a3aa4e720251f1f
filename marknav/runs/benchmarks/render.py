"""The renderer's speed: milliseconds per 640×480 frame of the example world with noise and blur.

``marknav bench render`` (:mod:`marknav.cli.bench`). The target is :data:`TARGET_MS` per frame
(a 20 Hz control loop renders, detects and ticks in one period); the figure is the best median
of a few batches, since the machine may be shared. Speed lives here, not in the tests.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numpy as np

import marknav
from marknav.planning.kinematics import Pose
from marknav.sim.builtin_camera import CameraConfig, Renderer
from marknav.sim.world.generate import generate_world
from marknav.sim.world.schema import Conditions, World, load_world
from marknav.vision.palette import ColourRange

__all__ = ["TARGET_MS", "bench_render", "example_poses", "example_renderer", "example_world"]

#: Per-frame rendering target (ms) at 640×480.
TARGET_MS = 2.0
_EXAMPLE = Path(marknav.__file__).resolve().parents[1] / "missions" / "worlds" / "slalom-world.yaml"
_PALETTE = (ColourRange("red", 170, 10), ColourRange("blue", 95, 130),
            ColourRange("green", 40, 85))


def example_poses(n: int) -> list[Pose]:
    """``n`` poses approaching the example world's marks, weaving a little."""
    return [Pose(20.0 * math.sin(k / 7), 10.0 * k, math.pi / 2 + 0.2 * math.sin(k / 11))
            for k in range(n)]


def example_world() -> World:
    """The repository's slalom world when marknav runs from a checkout, else a generated slalom
    world (100 mm marks)."""
    if _EXAMPLE.is_file():
        return load_world(_EXAMPLE).with_mark_radius(100.0)
    return generate_world(["red", "green", "blue", "red"], seed=0, clearance_mm=300.0)


def example_renderer() -> Renderer:
    """:func:`example_world` with noise (σ = 3) and blur (σ = 1 px), 640×480."""
    world = example_world()
    return Renderer(world.with_conditions(Conditions(noise_sigma=3.0, blur_sigma_px=1.0)),
                    _PALETTE, CameraConfig())


def bench_render(*, frames: int = 100, batches: int = 3, seed: int = 0) -> dict[str, Any]:
    """Render ``frames`` frames ``batches`` times; the best batch median (ms per frame)."""
    if frames < 1 or batches < 1:
        raise ValueError(f"frames and batches must be at least 1, got {frames}, {batches}")
    renderer = example_renderer()
    poses = example_poses(frames)
    rng = np.random.default_rng(seed)
    medians = []
    for _ in range(batches):
        times = []
        for pose in poses:
            t0 = time.perf_counter()
            renderer.render(pose, rng)
            times.append(time.perf_counter() - t0)
        medians.append(float(np.median(times)) * 1000.0)
    best = min(medians)
    cfg = renderer.config
    return {"width": cfg.width, "height": cfg.height, "frames": frames, "batches": batches,
            "frame_ms_p50": round(best, 3), "target_ms": TARGET_MS,
            "within_target": best < TARGET_MS}
