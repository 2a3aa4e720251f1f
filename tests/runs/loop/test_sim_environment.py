"""The lock-step closed loop: the real driver and safety layer against the simulated Create in
the simulated world (collisions, bumps, ground truth)."""

from __future__ import annotations

import math

import pytest

from marknav.runs.loop.sim_environment import SimEnvironment, waypoint_truth
from marknav.sim.world import CREATE_RADIUS_MM, Conditions, MarkSpec, World
from marknav.vision.palette import DEFAULT_PALETTE

MARK = (0.0, 1000.0)


@pytest.fixture
def env() -> SimEnvironment:
    world = World(marks=(MarkSpec(colour="red", x_mm=MARK[0], y_mm=MARK[1], radius_mm=100.0),))
    e = SimEnvironment(world, DEFAULT_PALETTE, seed=3)
    yield e
    e.close()


def drive_for(env: SimEnvironment, seconds: float, *, left: float, right: float) -> None:
    for _ in range(round(seconds * 20)):
        env.poll()
        env.robot.drive(left=left, right=right)
        env.advance(env.clock.now() + 0.05)


def test_driving_into_a_mark_bumps_and_the_safety_layer_stops(env: SimEnvironment) -> None:
    drive_for(env, 6.0, left=200, right=200)  # 1.2 m of commands; contact after ~0.735 m
    assert env.robot.safety_state == "bumped"
    assert env.create.wheel_speeds.left == env.create.wheel_speeds.right == 0
    assert len(env.truth.collisions) == 1
    hit = env.truth.collisions[0]
    assert (hit["kind"], hit["index"], hit["bump"]) == ("mark", 0, "both")
    # Stopped at the mark, never through it: centre-to-centre never below robot + mark radius.
    closest = min(math.dist(p, MARK) for p in env.truth.xy)
    assert closest == pytest.approx(CREATE_RADIUS_MM + 100.0, abs=2.0)
    # Forward commands are refused while bumped; reversing is allowed and clears the bump.
    assert env.robot.drive(left=100, right=100) is False
    for _ in range(20):
        env.poll()
        env.robot.backoff(left=-100, right=-100)
        env.advance(env.clock.now() + 0.05)
    env.poll()
    assert env.robot.safety_state in ("ready", "driving")
    assert min(math.dist(p, MARK) for p in env.truth.xy[-5:]) > CREATE_RADIUS_MM + 100.0 + 50


def test_bump_reaches_the_wheels_within_one_stream_period(env: SimEnvironment) -> None:
    drive_for(env, 3.0, left=200, right=200)  # 600 mm: 135 mm short of contact
    env.robot.drive(left=200, right=200)
    t_contact = None
    while env.clock.now() < 10.0:
        env.poll()
        env.robot.drive(left=200, right=200)
        env.advance(env.clock.now() + 0.015)
        if t_contact is None and env.truth.collisions:
            t_contact = env.truth.collisions[0]["t"]
        if t_contact is not None and env.create.wheel_speeds.left == 0:
            break
    assert t_contact is not None
    # Contact found in one 15 ms step; the frame with the bump bits goes out at the next, and the
    # driver's zero Drive Direct reaches the simulated Create in that same step.
    assert env.clock.now() - t_contact <= 0.030 + 1e-9


def test_ground_truth_side_and_clearance(env: SimEnvironment) -> None:
    # Drive a path west of the mark by hand: curve left (49°), straight, curve back, straight:
    # about 390 mm to the left of the start line when it passes the mark.
    drive_for(env, 1.0, left=100, right=300)
    drive_for(env, 1.5, left=200, right=200)
    drive_for(env, 1.0, left=300, right=100)
    drive_for(env, 4.0, left=250, right=250)
    assert env.truth.collisions == []
    (mt,) = waypoint_truth(env.truth, env.world, ["red"], ["left"])
    assert (mt.passed_on, mt.mark_index, mt.truth) == ("left", 0, "passed")
    (mt_right,) = waypoint_truth(env.truth, env.world, ["red"], ["right"])
    assert mt_right.truth == "wrong_side"
    clearance = mt.min_clearance_mm
    assert clearance == pytest.approx(min(math.dist(p, MARK) for p in env.truth.xy), abs=0.1)


@pytest.mark.parametrize("delay_ms", [500.0, 2000.0])  # 2000: the world schema's bound
def test_a_slow_command_link_connects_and_drives(delay_ms: float) -> None:
    """The stream request reaches the robot ``command_delay_ms`` after it was written: the
    connect waits for the first frame on the simulated clock, so the sensor watchdog does not
    count the link's delay as a lost stream, and the delayed wheel commands move the robot."""
    world = World(marks=(MarkSpec(colour="red", x_mm=MARK[0], y_mm=MARK[1], radius_mm=100.0),),
                  conditions=Conditions(command_delay_ms=delay_ms))
    with SimEnvironment(world, DEFAULT_PALETTE, seed=3) as env:
        assert env.robot.safety_state == "ready"
        assert env.robot.latest is not None
        start_y = env.create.pose.y
        drive_for(env, delay_ms / 1000.0 + 1.0, left=200, right=200)
        assert [e.event for e in env.robot.safety_events if e.state == "fault"] == []
        assert env.robot.safety_state == "driving"
        # about 1 s of 200 mm/s once the first command arrived
        assert env.create.pose.y - start_y == pytest.approx(200.0, abs=40.0)
