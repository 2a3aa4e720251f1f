"""FakeRobot: integrated pose, recorded commands, and the real safety layer's semantics."""

import math

import pytest

from marknav.planning.kinematics import Pose, integrate_pose
from marknav.robot.robot import BUMPED, DRIVING, ESTOPPED, FAULT, READY, Robot
from marknav.testing import FakeRobot, WheelCommand


def test_satisfies_the_robot_protocol(fake_robot):
    assert isinstance(fake_robot, Robot)
    assert fake_robot.safety_state == READY
    assert fake_robot.pose() == Pose(0.0, 0.0, math.pi / 2)


def test_pose_integrates_the_commanded_arc_exactly(fake_robot, manual_clock):
    assert fake_robot.drive(left=180, right=220) is True
    for _ in range(20):  # a command every 50 ms keeps the watchdog quiet
        manual_clock.advance(0.05)
        fake_robot.drive(left=180, right=220)
    expected = integrate_pose(Pose(0.0, 0.0, math.pi / 2), left=180, right=220, dt=1.0,
                              wheel_base_mm=235.0)
    got = fake_robot.pose()
    assert got.x == pytest.approx(expected.x, abs=1e-6)
    assert got.y == pytest.approx(expected.y, abs=1e-6)
    assert got.theta == pytest.approx(expected.theta, abs=1e-9)
    assert fake_robot.safety_state == DRIVING


def test_commands_are_recorded_with_clock_time_and_scaled_together(fake_robot, manual_clock):
    manual_clock.advance(0.25)
    fake_robot.drive(left=1000, right=500)  # over the 500 mm/s limit: both halved
    manual_clock.advance(0.05)
    fake_robot.stop()
    # the first zero is the safety layer's, written when it connected
    assert fake_robot.commands == [WheelCommand(0.0, 0, 0), WheelCommand(0.25, 500, 250),
                                   WheelCommand(0.3, 0, 0)]
    assert [r.kind for r in fake_robot.requests] == ["drive", "stop"]


def test_command_watchdog_stops_the_wheels(fake_robot, manual_clock):
    fake_robot.drive(left=200, right=200)
    manual_clock.advance(0.29)
    assert fake_robot.wheels == (200, 200)
    manual_clock.advance(0.05)  # > 0.3 s without a command
    assert fake_robot.wheels == (0, 0)
    assert fake_robot.safety_state == READY
    assert fake_robot.events[-1].event == "command_timeout"
    y = fake_robot.pose().y
    manual_clock.advance(1.0)
    assert fake_robot.pose().y == pytest.approx(y)  # it stays put


def test_bump_stops_refuses_forward_and_allows_backoff(fake_robot, manual_clock):
    fake_robot.drive(left=200, right=200)
    fake_robot.bump(left=True, right=False)
    assert fake_robot.safety_state == BUMPED
    assert fake_robot.wheels == (0, 0)
    assert fake_robot.drive(left=100, right=100) is False
    assert fake_robot.backoff(left=-150, right=-150) is True
    manual_clock.advance(0.2)
    assert fake_robot.pose().y == pytest.approx(-30.0)
    fake_robot.release_bump()
    assert fake_robot.safety_state == READY


def test_cliff_latches_a_fault_with_a_reason(fake_robot):
    fake_robot.drive(left=100, right=100)
    fake_robot.set_sensors(cliff_front_left=True)
    assert fake_robot.safety_state == FAULT
    assert fake_robot.fault_reason == "cliff front left"
    assert fake_robot.wheels == (0, 0)
    fake_robot.set_sensors(cliff_front_left=False)
    assert fake_robot.reset() is True
    assert fake_robot.safety_state == READY


def test_estop_and_sensor_loss(manual_clock):
    robot = FakeRobot(clock=manual_clock)
    robot.estop("operator")
    assert robot.safety_state == ESTOPPED
    assert robot.fault_reason == "e-stop: operator"
    other = FakeRobot(clock=manual_clock)
    other.sensors_streaming = False
    manual_clock.advance(0.25)
    assert other.safety_state == FAULT
    assert "no sensor frame" in (other.fault_reason or "")


def test_wheel_scale_moves_the_true_pose_but_not_odometry(manual_clock):
    robot = FakeRobot(clock=manual_clock, wheel_scale=(1.0, 0.97))
    for _ in range(40):
        robot.drive(left=250, right=250)
        manual_clock.advance(0.05)
    assert robot.pose().x == pytest.approx(0.0, abs=1e-9)  # odometry: straight
    truth = integrate_pose(Pose(0.0, 0.0, math.pi / 2), left=250.0, right=242.5, dt=2.0,
                           wheel_base_mm=235.0)
    assert robot.true_pose.x == pytest.approx(truth.x)  # really curving right
    assert robot.true_pose.x > 15.0
    assert len(robot.trajectory) > 100  # a true pose every 15 ms
