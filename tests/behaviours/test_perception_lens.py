"""Perception undistorts detections with the mission's intrinsics (scaled to the frame's size)."""

from __future__ import annotations

import math

import pytest

from marknav.behaviours import keys
from marknav.behaviours.perception import Perception
from marknav.planning.kinematics import Pose
from marknav.sim.builtin_camera import CameraConfig, Renderer
from marknav.sim.lens import Lens
from marknav.sim.world import Background, Conditions, MarkSpec, World
from marknav.testing import FakeRobot
from marknav.vision.palette import DEFAULT_PALETTE
from marknav.vision.sources import Frame

LENS = Lens(k1=-0.35, k2=0.1, p1=0.001, p2=-0.001, principal_offset=(0.03, -0.02))


class OneFrame:
    name = "one"

    def __init__(self, frame: Frame) -> None:
        self.frame = frame

    def read(self) -> Frame | None:
        return self.frame

    def close(self) -> None:
        pass


def _seen(mission_factory, manual_clock, camera: dict) -> keys.SeenMark:
    # A 320x240 camera (f = 295 px) through a barrel lens; a red mark 1.5 m ahead, 0.6 m right.
    cfg = CameraConfig(width=320, height=240, focal_px=295.0)
    world = World(marks=(MarkSpec(colour="red", x_mm=600.0, y_mm=1500.0, radius_mm=100.0),),
                  conditions=Conditions(lens=LENS, noise_sigma=0.0),
                  background=Background(seed=1))
    renderer = Renderer(world, DEFAULT_PALETTE, cfg)
    image = renderer.render(Pose(0.0, 0.0, math.pi / 2))
    robot = FakeRobot(clock=manual_clock, pose=Pose(0.0, 0.0, math.pi / 2))
    p = Perception()
    p.setup(robot=robot, clock=manual_clock, mission=mission_factory(camera=camera),
            camera=OneFrame(Frame(image=image, t=0.0, index=0)))
    p.tick_once()
    (m,) = p.blackboard.get(keys.MARKS)
    return m


def test_intrinsics_calibrated_at_640x480_undistort_320x240_frames(
        blackboard, manual_clock, mission_factory) -> None:
    cfg = CameraConfig(width=320, height=240, focal_px=295.0)
    cx, cy = 159.5 + 0.03 * 320, 119.5 - 0.02 * 240
    # the same lens calibrated at twice the resolution (pixel centres at integers)
    intr = {"fx": 590.0, "fy": 590.0, "cx": (cx + 0.5) * 2 - 0.5, "cy": (cy + 0.5) * 2 - 0.5,
            "dist": list(LENS.dist)}
    pinhole = {"model": "pinhole", "focal_px": 295.0}
    plain = _seen(mission_factory, manual_clock,
                  {"width": 320, "height": 240, "focal_px": 295.0, "range": pinhole,
                   "learn_range": False})
    assert plain.forward_mm > 1.05 * 1500.0  # the lens shrank the off-axis mark: reads far
    fixed = _seen(mission_factory, manual_clock,
                  {"width": 640, "height": 480, "focal_px": 590.0, "intrinsics": intr,
                   "range": pinhole, "learn_range": False})
    assert fixed.forward_mm == pytest.approx(1500.0, rel=0.015)
    assert fixed.left_mm == pytest.approx(-600.0, abs=15.0)
    # x_px is relative to the principal point: the mark's bearing from it, at f = 295 px
    assert math.atan2(-fixed.pixel_error, cfg.focal_px) == pytest.approx(
        math.atan2(-600.0, 1500.0), abs=0.01)
