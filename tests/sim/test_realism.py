"""The simulator's realism conditions do what their documentation says: camera frame rate apart
from the control rate, dropped frames, motion blur from turning, exposure drift, printed marks'
saturation; wheel acceleration, top speed, command delay, encoder scale; friction patches."""

from __future__ import annotations

import itertools
import math

import cv2
import numpy as np
import pytest

from marknav.core.clock import ManualClock
from marknav.planning.kinematics import Pose
from marknav.robot import oi
from marknav.runs.loop.sim_environment import GroundTruth
from marknav.sim.builtin_camera import SimCamera, mark_bgr, mark_inks
from marknav.sim.simulated_create import SimulatedCreate
from marknav.sim.world import (
    Conditions,
    FaultEvent,
    FrictionPatch,
    MarkSpec,
    World,
    generate_world,
    random_realism,
)
from marknav.vision.palette import ColourRange

RED = ColourRange(name="red", hue_lo=170, hue_hi=10)
START = Pose(0.0, 0.0, math.pi / 2)


def _world(**conditions: float) -> World:
    return World(marks=(MarkSpec(colour="red", x_mm=0.0, y_mm=1500.0),),
                 conditions=Conditions(noise_sigma=0.0, **conditions))


def _camera(world: World, clock: ManualClock, pose: list[Pose],
            truth: GroundTruth | None = None) -> SimCamera:
    return SimCamera(world, [RED], pose_fn=lambda: pose[0], clock=clock, seed=3,
                     pose_at=truth.pose_at if truth is not None else None)


def test_a_15_fps_camera_gives_a_new_frame_on_three_of_four_20_hz_cycles() -> None:
    clock = ManualClock()
    cam = _camera(_world(frame_rate_hz=15.0), clock, [START])
    indices, times = [], []
    for _ in range(40):
        f = cam.read()
        assert f is not None
        indices.append(f.index)
        times.append(f.t)
        clock.advance(0.05)
    new = len(set(indices))
    assert new == 30  # 2 s at 15 fps
    # each frame carries the time it was taken: a multiple of 1/15 s, never after the read
    assert all(abs(t * 15 - round(t * 15)) < 1e-6 for t in times)


def test_dropped_frames_repeat_the_last_frame() -> None:
    clock = ManualClock()
    cam = _camera(_world(dropped_frames=0.3), clock, [START])
    seen = []
    for _ in range(400):
        f = cam.read()
        assert f is not None
        seen.append(f.index)
        clock.advance(0.05)
    fresh = sum(1 for a, b in itertools.pairwise(seen) if b != a)
    assert 0.6 * 399 < fresh < 0.8 * 399
    assert cam.frames_dropped == 399 - fresh


def test_turning_during_the_exposure_smears_the_mark_sideways() -> None:
    truth = GroundTruth()
    # turning at 90°/s: 30 ms of exposure is 2.7° = 27.8 px at f = 590
    for k in range(11):
        t = k * 0.01
        truth.record(t, Pose(0.0, 0.0, math.pi / 2 + math.radians(90.0) * t))
    clock = ManualClock()
    clock.advance(0.1)
    pose = [truth.pose_at(0.1)]

    cam = _camera(_world(exposure_ms=30.0), clock, pose, truth)
    asked: list[float] = []
    render = cam.renderer.render

    def spy(p: Pose, rng: object, *, motion_px: float = 0.0, gain: float = 1.0) -> object:
        asked.append(motion_px)
        return render(p, rng, motion_px=motion_px, gain=gain)  # type: ignore[arg-type]

    cam.renderer.render = spy  # type: ignore[method-assign,assignment]
    f = cam.read()
    assert f is not None
    assert asked[0] == pytest.approx(590 * math.radians(2.7), rel=1e-6)
    # the smear widens the mark's saturated extent in the middle row, and only sideways
    sharp = cam.renderer.render(pose[0], None)
    hsv_f = cv2.cvtColor(f.image, cv2.COLOR_BGR2HSV)
    hsv_s = cv2.cvtColor(sharp, cv2.COLOR_BGR2HSV)
    row = 239
    assert np.count_nonzero(hsv_f[row, :, 1] > 20) > np.count_nonzero(hsv_s[row, :, 1] > 20) + 10
    col_f = np.count_nonzero(hsv_f[:, :, 1].max(axis=1) > 128)
    col_s = np.count_nonzero(hsv_s[:, :, 1].max(axis=1) > 128)
    assert abs(col_f - col_s) <= 2


def test_exposure_drift_swings_the_brightness() -> None:
    clock = ManualClock()
    cam = _camera(_world(exposure_drift=0.2, exposure_period_s=4.0), clock, [START])
    means = []
    for _ in range(80):
        f = cam.read()
        assert f is not None
        means.append(float(f.image.mean()))
        clock.advance(0.05)
    assert max(means) / min(means) > 1.3


def test_printed_marks_are_painted_less_saturated() -> None:
    b, g, r = mark_bgr(RED, saturation=0.5)
    hsv = cv2.cvtColor(np.uint8([[[b, g, r]]]), cv2.COLOR_BGR2HSV)[0, 0]
    assert hsv[1] == pytest.approx(128, abs=2) and hsv[2] == 255
    world = World(marks=tuple(MarkSpec(colour="red", x_mm=400.0 * i, y_mm=2000.0)
                              for i in range(6)),
                  conditions=Conditions(mark_saturation=0.8, mark_saturation_spread=0.1,
                                        mark_hue_spread=3.0))
    inks = mark_inks(world)
    assert all(0.7 - 1e-9 <= s <= 0.9 + 1e-9 and abs(dh) <= 3.0 for s, dh in inks)
    assert len({round(s, 4) for s, _ in inks}) == 6  # each mark its own


def test_acceleration_top_speed_and_command_delay() -> None:
    clock = ManualClock()
    sim = SimulatedCreate(clock=clock, accel_mm_s2=500.0, top_speed_mm_s=330.0,
                          command_delay_s=0.03)
    sim.write(oi.start() + oi.safe() + oi.drive_direct(left=500, right=500))
    sim.step(0.015)
    assert sim.pose.y == 0.0  # the command is still on its way
    sim.step(0.015)
    for _ in range(200):  # 3 s: accelerating for 0.66 s to the battery's top speed
        sim.step(0.015)
    v_end = (sim.pose.y - 0.0) / 1.0
    assert sim.wheel_speeds.left == 500.0  # commanded
    expected = 330.0 * (3.0 - 0.66) + 0.5 * 330.0 * 0.66
    assert sim.pose.y == pytest.approx(expected, rel=0.02), v_end


def test_the_encoder_scale_is_what_odometry_gets_wrong() -> None:
    sim = SimulatedCreate(clock=ManualClock(), encoder_scale=1.05)
    sim.write(oi.start() + oi.safe() + oi.drive_direct(left=200, right=200))
    for _ in range(100):
        sim.step(0.015)
    counts = sim.encoder_counts[0] * math.pi * 72.0 / 508.8
    assert counts == pytest.approx(1.05 * sim.pose.y, rel=0.01)


def test_a_friction_patch_under_one_wheel_turns_the_robot() -> None:
    patch = FrictionPatch(x_mm=-300.0, y_mm=500.0, radius_mm=250.0, slip=0.3)

    def ground(pose: Pose) -> tuple[float, float]:
        half = 117.5
        lx, ly = -math.sin(pose.theta) * half, math.cos(pose.theta) * half
        return tuple(1.0 - patch.slip if patch.contains(pose.x + sx * lx, pose.y + sx * ly)
                     else 1.0 for sx in (1, -1))  # type: ignore[return-value]

    sim = SimulatedCreate(clock=ManualClock(), ground_fn=ground)
    sim.write(oi.start() + oi.safe() + oi.drive_direct(left=200, right=200))
    for _ in range(400):
        sim.step(0.015)
    # the left wheel slipped on the patch: the robot turned left... no: the left wheel lost
    # travel, so the right one drove further and the heading turned counter-clockwise
    assert sim.pose.theta > math.pi / 2 + 0.05


def test_randomised_worlds_draw_realism_from_their_own_stream() -> None:
    a = generate_world(["red", "red"], seed=4, clearance_mm=300.0, conditions="randomised")
    b = generate_world(["red", "red"], seed=4, clearance_mm=300.0, conditions="randomised")
    assert a == b
    c = a.conditions
    assert 15.0 <= c.frame_rate_hz <= 30.0 and 0.75 <= c.mark_saturation <= 1.0
    assert 330.0 <= c.top_speed_mm_s <= 500.0 and c.accel_mm_s2 >= 400.0
    # patches only when asked: unseen by odometry, they turn the robot during bypasses
    assert a.patches == ()
    with_patches = generate_world(["red", "red"], seed=4, clearance_mm=300.0,
                                  conditions="randomised", patches=True)
    assert with_patches.marks == a.marks and with_patches.conditions == a.conditions
    keys = set(random_realism(np.random.default_rng(0)))
    assert keys <= set(Conditions.model_fields)


def test_a_fault_event_names_a_side_it_can_happen_on() -> None:
    with pytest.raises(ValueError, match="wheel_drop happens on side left, right, both"):
        FaultEvent(t_s=1.0, fault="wheel_drop", side="front_left")
