"""The ``Robot`` protocol's contract (marknav.robot.robot), asserted of every implementation.

Each implementation is one factory in ``RIGS``: it builds the robot connected (state ``ready``)
on a ManualClock and says how to let time pass, how to press the bumper and what the wheels are
doing. The suite asserts what the protocol's docstrings promise a behaviour: wheel commands go
through the safety layer (``drive`` returns whether it was accepted; a bump refuses them except
a backward ``backoff``), ``stop`` is always allowed and zeroes the wheels, the command watchdog
stops a robot left without commands, the pose is odometry that follows the wheels, and
``safety_state`` is always one of ``SAFETY_STATES``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from typing import Protocol

import pytest

from marknav.core.clock import ManualClock
from marknav.planning.kinematics import Pose
from marknav.robot import oi
from marknav.robot.driver import CreateDriver
from marknav.robot.oi import Model
from marknav.robot.robot import BUMPED, DRIVING, READY, SAFETY_STATES, Robot
from marknav.sim import protocol_createsim
from marknav.sim.simulated_create import Body, SimulatedCreate
from marknav.testing.robot import FakeRobot

TICK = oi.STREAM_PERIOD_S


class Rig(Protocol):
    """A connected robot and its world: time, the bumper, the wheels as the robot turns them."""

    robot: Robot

    def advance(self, seconds: float) -> None: ...
    def press_bumper(self, pressed: bool) -> None: ...
    def wheels(self) -> tuple[float, float]: ...
    def close(self) -> None: ...


class FakeRig:
    def __init__(self) -> None:
        self.clock = ManualClock()
        self.fake = FakeRobot(clock=self.clock)
        self.robot: Robot = self.fake

    def advance(self, seconds: float) -> None:
        self.clock.advance(seconds)

    def press_bumper(self, pressed: bool) -> None:
        if pressed:
            self.fake.bump()
        else:
            self.fake.release_bump()

    def wheels(self) -> tuple[float, float]:
        return self.fake.wheels

    def close(self) -> None:
        pass  # nothing to release


class DriverRig:
    """The Create driver, in lock-step with the byte-level simulated Create (``body``: its
    engine, None for the built-in one)."""

    def __init__(self, body: Body | None = None) -> None:
        self.clock = ManualClock()
        self.sim = SimulatedCreate(model=Model.CREATE2, clock=self.clock, body=body)
        self.url = protocol_createsim.register(self.sim)
        self.driver = CreateDriver(self.url, model=Model.CREATE2, clock=self.clock, settle_s=0.0,
                                   first_frame_timeout_s=None, reader_thread=False)
        self.robot: Robot = self.driver
        self.driver.connect()
        self.advance(TICK)

    def advance(self, seconds: float) -> None:
        for _ in range(max(1, round(seconds / TICK))):
            self.sim.step(TICK)
            self.driver.process_input()

    def press_bumper(self, pressed: bool) -> None:
        self.sim.set_bump(pressed, pressed)
        self.advance(TICK)  # the next stream frame carries it

    def wheels(self) -> tuple[float, float]:
        self.advance(TICK)  # the robot applies a command when it has read it
        speeds = self.sim.wheel_speeds
        return (speeds.left, speeds.right)

    def close(self) -> None:
        self.driver.close()
        protocol_createsim.unregister(self.url.split("//")[1])


def mujoco_rig() -> Rig:
    from marknav.sim.mujoco import gl

    gl.backend()  # the headless renderer, chosen before anything imports mujoco
    pytest.importorskip("mujoco")
    from marknav.sim.mujoco.body import MujocoBody
    from marknav.sim.world import Conditions, World
    from marknav.vision.palette import DEFAULT_PALETTE

    body = MujocoBody(World(marks=(), conditions=Conditions(noise_sigma=0.0)), DEFAULT_PALETTE,
                      render=False)
    return DriverRig(body)


#: Every Robot implementation: one line each.
RIGS: list[object] = [
    pytest.param(FakeRig, id="fake"),
    pytest.param(DriverRig, id="driver-on-simulated-create"),
    pytest.param(mujoco_rig, id="driver-on-mujoco-create"),
]


@pytest.fixture(params=RIGS)
def rig(request: pytest.FixtureRequest) -> Iterator[Rig]:
    factory: Callable[[], Rig] = request.param
    r = factory()
    yield r
    r.close()


def drive_for(rig: Rig, seconds: float, *, left: float, right: float) -> None:
    """Command every 50 ms (a 20 Hz tree) for ``seconds``; every command must be accepted."""
    for _ in range(round(seconds / 0.05)):
        assert rig.robot.drive(left=left, right=right)
        rig.advance(0.05)


def test_it_is_a_robot_connected_and_still(rig: Rig) -> None:
    assert isinstance(rig.robot, Robot)
    assert rig.robot.safety_state == READY
    assert rig.robot.fault_reason is None
    assert rig.wheels() == (0, 0)
    pose = rig.robot.pose()
    assert isinstance(pose, Pose) and all(math.isfinite(v) for v in (pose.x, pose.y, pose.theta))


def test_an_accepted_drive_turns_the_wheels_and_the_pose_follows(rig: Rig) -> None:
    start = rig.robot.pose()
    assert rig.robot.drive(left=200, right=200)
    assert rig.robot.safety_state == DRIVING
    assert rig.wheels() == (200, 200)
    drive_for(rig, 1.0, left=200, right=200)
    end = rig.robot.pose()
    ahead = ((end.x - start.x) * math.cos(start.theta) + (end.y - start.y) * math.sin(start.theta))
    assert 150 < ahead < 250  # about 1 s at 200 mm/s, straight ahead
    assert abs(end.theta - start.theta) < 0.05


def test_speeds_over_the_limit_are_scaled_together(rig: Rig) -> None:
    assert rig.robot.drive(left=1000, right=500)
    assert rig.wheels() == (500, 250)


def test_stop_zeroes_the_wheels_returns_to_ready_and_the_pose_holds(rig: Rig) -> None:
    drive_for(rig, 0.5, left=150, right=250)
    rig.robot.stop()
    assert rig.robot.safety_state == READY
    assert rig.wheels() == (0, 0)
    rig.advance(0.5)  # a real body coasts to rest
    held = rig.robot.pose()
    rig.advance(1.0)
    after = rig.robot.pose()
    assert math.hypot(after.x - held.x, after.y - held.y) < 1.0
    assert abs(after.theta - held.theta) < 0.005


def test_stop_is_always_allowed_and_idempotent(rig: Rig) -> None:
    rig.robot.stop()
    rig.robot.stop()
    assert rig.robot.safety_state == READY
    rig.press_bumper(True)
    rig.robot.stop()
    assert rig.robot.safety_state == BUMPED  # stopping clears no latch
    assert rig.wheels() == (0, 0)


def test_a_robot_left_without_commands_stops_by_itself(rig: Rig) -> None:
    assert rig.robot.drive(left=200, right=200)
    rig.advance(1.0)  # far past the command watchdog (0.3 s)
    assert rig.robot.safety_state == READY
    assert rig.wheels() == (0, 0)


def test_a_bump_stops_the_wheels_and_refuses_all_but_backing_off(rig: Rig) -> None:
    drive_for(rig, 0.2, left=200, right=200)
    rig.press_bumper(True)
    assert rig.robot.safety_state == BUMPED
    assert rig.wheels() == (0, 0)
    assert rig.robot.drive(left=100, right=100) is False
    assert rig.robot.backoff(left=100, right=-100) is False  # one wheel forward: not backing
    assert rig.wheels() == (0, 0)
    assert rig.robot.backoff(left=-100, right=-100) is True
    assert rig.wheels() == (-100, -100)
    assert rig.robot.safety_state == BUMPED
    rig.press_bumper(False)
    assert rig.robot.safety_state == READY
    assert rig.wheels() == (0, 0)  # clearing the bump stops the back-off too
    assert rig.robot.drive(left=100, right=100)


def test_backoff_outside_a_bump_is_an_ordinary_command(rig: Rig) -> None:
    assert rig.robot.backoff(left=-80, right=-120)
    assert rig.robot.safety_state == DRIVING
    assert rig.wheels() == (-80, -120)


def test_a_non_finite_speed_stops_the_wheels_and_raises(rig: Rig) -> None:
    drive_for(rig, 0.2, left=200, right=200)
    with pytest.raises(ValueError):
        rig.robot.drive(left=math.nan, right=100)
    assert rig.wheels() == (0, 0)
    assert rig.robot.safety_state in SAFETY_STATES
    assert rig.robot.safety_state != DRIVING
