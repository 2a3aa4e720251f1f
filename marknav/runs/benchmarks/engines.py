"""MuJoCo's camera speed: frames per second at 320×240 and 640×480, with and without shadows.

``marknav bench mujoco`` (:mod:`marknav.cli.bench`; needs the ``mujoco`` extra and headless
OpenGL). The room is the randomised MuJoCo room of a generated slalom (lamps, textures, poles and
distractors: what ``evaluate --engine mujoco`` renders); the camera walks the same poses as
``bench render``. The floor, measured in the same run on the same poses, is the built-in
renderer at the same size: the ratio says what the second engine costs on this machine, whatever
the machine. Each figure is the best median of a few batches, since the machine may be shared.
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Any

import numpy as np

from marknav.core.clock import ManualClock
from marknav.runs.benchmarks.render import _PALETTE, example_poses
from marknav.sim.builtin_camera import CameraConfig, Renderer
from marknav.sim.world.generate import generate_world
from marknav.sim.world.schema import World

__all__ = ["SIZES", "bench_mujoco"]

#: The camera sizes measured (width, height): a webcam's two usual modes.
SIZES = ((320, 240), (640, 480))


def _room(seed: int) -> World:
    return generate_world(["red", "green", "red", "blue"], seed=seed, clearance_mm=300.0,
                          conditions="randomised", engine="mujoco")


def _best_median_ms(render: Any, poses: list[Any], batches: int) -> float:
    medians = []
    for _ in range(batches):
        times = []
        for pose in poses:
            t0 = time.perf_counter()
            render(pose)
            times.append(time.perf_counter() - t0)
        medians.append(float(np.median(times)) * 1000.0)
    return min(medians)


def bench_mujoco(*, frames: int = 40, batches: int = 3, seed: int = 0) -> dict[str, Any]:
    """ms per frame and frames per second for each of :data:`SIZES`, MuJoCo with and without
    shadows, and the built-in renderer (the floor) on the same world and poses."""
    from marknav.sim.mujoco.body import MujocoBody
    from marknav.sim.mujoco.camera import MujocoCamera

    if frames < 1 or batches < 1:
        raise ValueError(f"frames and batches must be at least 1, got {frames}, {batches}")
    world = _room(seed)
    poses = example_poses(frames)
    rng = np.random.default_rng(seed)
    out: dict[str, Any] = {"frames": frames, "batches": batches, "floor": "builtin renderer"}
    for width, height in SIZES:
        cam = replace(CameraConfig(), width=width, height=height,
                      focal_px=CameraConfig().focal_px * width / 640.0, principal=None)
        row: dict[str, Any] = {}
        builtin = Renderer(world, _PALETTE, cam)
        row["builtin_ms_p50"] = round(_best_median_ms(
            lambda p, r=builtin: r.render(p, rng), poses, batches), 3)
        for shadows in (False, True):
            body = MujocoBody(world, _PALETTE, camera=cam, shadows=shadows)
            with MujocoCamera(body, clock=ManualClock(), seed=seed) as camera:
                def render(pose: Any, body: MujocoBody = body,
                           camera: MujocoCamera = camera) -> None:
                    body.set_pose(pose)
                    camera.render()

                ms = _best_median_ms(render, poses, batches)
            key = "shadows" if shadows else "no_shadows"
            row[f"mujoco_{key}_ms_p50"] = round(ms, 3)
            row[f"mujoco_{key}_fps"] = round(1000.0 / ms, 1)
            row[f"mujoco_{key}_over_builtin"] = round(ms / max(row["builtin_ms_p50"], 1e-9), 1)
        out[f"{width}x{height}"] = row
    return out

