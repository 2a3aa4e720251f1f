"""The simulated camera's time (latency in continuous time, capture time stamps) and pose
(pitch, roll, marks off the camera's height)."""

from __future__ import annotations

import math

import pytest

from marknav.core.clock import ManualClock
from marknav.planning.kinematics import Pose
from marknav.sim.builtin_camera import SimCamera
from marknav.sim.world import Conditions
from tests.sim.test_builtin_camera import (
    PALETTE,
    START,
    F,
    area_radius_and_centroid,
    coverage,
    one_mark,
)


def test_a_late_frame_is_rendered_at_and_stamped_with_its_capture_time() -> None:
    clock = ManualClock(10.0)
    asked: list[float] = []

    def pose_at(t: float) -> Pose:
        asked.append(t)
        return START

    world = one_mark(0.0, 1500.0, conditions=Conditions(noise_sigma=0.0, camera_latency_s=0.23,
                                                        processing_s=0.04))
    cam = SimCamera(world, PALETTE, pose_fn=lambda: START, clock=clock, pose_at=pose_at)
    assert cam.delay_s == pytest.approx(0.27)
    frame = cam.read()
    assert frame is not None and frame.t == pytest.approx(9.73)  # not whole control ticks
    assert asked == [pytest.approx(9.73)]
    clock.advance(0.05)
    assert cam.read().t == pytest.approx(9.78)  # type: ignore[union-attr]


def test_without_delay_the_frame_is_of_now() -> None:
    clock = ManualClock(2.0)
    cam = SimCamera(one_mark(0.0, 1500.0), PALETTE, pose_fn=lambda: START, clock=clock,
                    pose_at=lambda t: pytest.fail("no history needed"))
    assert cam.read().t == 2.0  # type: ignore[union-attr]


@pytest.mark.parametrize("pitch", [-8.0, 8.0])
def test_a_pitched_camera_sees_a_mark_at_its_height_off_the_middle_row(pitch: float) -> None:
    world = one_mark(0.0, 2000.0, conditions=Conditions(noise_sigma=0.0, camera_pitch_deg=pitch))
    _, _, v = area_radius_and_centroid(coverage(world))
    assert v == pytest.approx(239.5 + F * math.tan(math.radians(pitch)), abs=1.5)


@pytest.mark.parametrize("rise", [-120.0, 120.0])
def test_a_mark_above_the_camera_is_seen_above_the_middle_row(rise: float) -> None:
    d = 1000.0
    world = one_mark(0.0, d, conditions=Conditions(noise_sigma=0.0, mark_height_offset_mm=rise))
    _, _, v = area_radius_and_centroid(coverage(world))
    assert v == pytest.approx(239.5 - F * rise / d, abs=1.0)
