"""Odometry calibration: drive a known distance and a known turn, compare with a measurement.

The encoders count wheel turns; what a turn carries the robot over the floor depends on the tyres
(wear, load, a diameter off the nominal 72 mm, Create 2 spec "Encoder Counts": 508.8 counts per
turn): odometry's distances are off by a scale, and its turns by that scale and the wheels'
effective contact spacing. :func:`drive_straight` drives ``distance_mm`` by odometry and
:func:`turn_in_place` turns ``angle_deg`` by odometry; a tape measure (or, in the simulator, the
ground truth) gives the true figures, and

- :func:`odometry_scale`: ground travel per odometry millimetre = measured / odometry (the
  mission's ``robot.odometry_scale``, multiplied into the scale the run already used);
- :func:`effective_wheel_base`: the wheel base that makes the scaled odometry turn what was
  measured (``robot.wheel_base_mm``): B' = B · s·θ_odometry / θ_measured.

The mean speed over the straight (measured distance over driving time) against the commanded
speed shows a sagging battery's top speed or an acceleration limit.

Both manoeuvres go through the robot's safety layer at the control rate, as a mission does: a
fault it reports (bump, cliff, wheel drop, overcurrent, low battery, a lost link) stops the
wheels and ends the calibration with :class:`CalibrationAborted` (exit 1, the fault named), as
it aborts a run.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass
from typing import Protocol

from marknav.core.clock import Clock, MonotonicClock
from marknav.core.errors import MarknavError
from marknav.planning.kinematics import Pose, wrap_angle
from marknav.robot.driver import CreateDriver
from marknav.robot.robot import Robot

__all__ = ["CalibrationAborted", "DriverEnvironment", "DrivingEnvironment", "Leg", "drive_straight",
           "effective_wheel_base", "odometry_scale", "turn_in_place"]

log = logging.getLogger(__name__)

#: Time for the last sensor frames to report the stopped wheels before odometry is read, s.
SETTLE_S = 0.3
#: Longest a leg may take, as a multiple of its nominal time (a stalled robot ends the leg).
TIMEOUT_FACTOR = 3.0


class CalibrationAborted(MarknavError):
    """The safety layer refused a manoeuvre (a fault): the wheels were stopped; exit 1."""


class DrivingEnvironment(Protocol):
    """What calibration needs of a run environment (the simulator's or a real robot's)."""

    @property
    def clock(self) -> Clock: ...

    @property
    def robot(self) -> Robot: ...

    def poll(self) -> None: ...

    def advance(self, until: float) -> None: ...


class DriverEnvironment:
    """A connected real robot, on wall-clock time (its reader thread feeds the safety layer)."""

    def __init__(self, driver: CreateDriver) -> None:
        self.driver = driver
        self.clock: Clock = MonotonicClock()

    @property
    def robot(self) -> Robot:
        return self.driver

    def poll(self) -> None:
        self.driver.safety.poll()

    def advance(self, until: float) -> None:
        delay = until - self.clock.now()
        if delay > 0:
            time.sleep(delay)

    def close(self) -> None:
        self.driver.close()


@dataclass(frozen=True)
class Leg:
    """One manoeuvre: what odometry says it did (mm or degrees) and how long it drove (s)."""

    odometry: float
    drive_s: float
    start: Pose
    end: Pose


def _cycle(env: DrivingEnvironment, period: float) -> None:
    env.advance(env.clock.now() + period)
    env.poll()


def _settle(env: DrivingEnvironment, period: float) -> None:
    env.robot.stop()
    t_end = env.clock.now() + SETTLE_S
    while env.clock.now() < t_end:
        _cycle(env, period)


def _abort(env: DrivingEnvironment, what: str) -> CalibrationAborted:
    """Stop the wheels (again: the safety layer did) and say which fault refused ``what``."""
    robot = env.robot
    why = f"{robot.safety_state}: {robot.fault_reason or 'no reason given'}"
    try:
        robot.stop()
    except Exception:  # the link may be gone; closing the environment tries again
        log.exception("stopping the wheels failed")
    return CalibrationAborted(f"aborted: the safety layer refused to {what} ({why}); "
                              "nothing was measured")


def drive_straight(env: DrivingEnvironment, *, distance_mm: float, speed_mm_s: float,
                   rate_hz: float = 20.0) -> Leg:
    """Drive straight ahead until odometry has covered ``distance_mm``; the odometry distance
    (start to end, after the wheels stopped) and the driving time."""
    if distance_mm <= 0 or speed_mm_s <= 0:
        raise ValueError("distance and speed must be positive")
    period = 1.0 / rate_hz
    env.poll()
    start = env.robot.pose()
    t0 = env.clock.now()
    limit = t0 + TIMEOUT_FACTOR * distance_mm / speed_mm_s + 2.0
    while env.clock.now() < limit:
        p = env.robot.pose()
        if math.hypot(p.x - start.x, p.y - start.y) >= distance_mm:
            break
        if not env.robot.drive(left=speed_mm_s, right=speed_mm_s):
            raise _abort(env, "drive")
        _cycle(env, period)
    drive_s = env.clock.now() - t0
    _settle(env, period)
    end = env.robot.pose()
    return Leg(math.hypot(end.x - start.x, end.y - start.y), drive_s, start, end)


def turn_in_place(env: DrivingEnvironment, *, angle_deg: float, turn_speed_deg_s: float,
                  wheel_base_mm: float, rate_hz: float = 20.0) -> Leg:
    """Turn counter-clockwise on the spot until odometry has turned ``angle_deg`` (it may be
    more than a whole turn); the odometry angle (degrees, after the wheels stopped)."""
    if angle_deg <= 0 or turn_speed_deg_s <= 0:
        raise ValueError("angle and turn speed must be positive")
    period = 1.0 / rate_hz
    wheel = math.radians(turn_speed_deg_s) * wheel_base_mm / 2.0
    env.poll()
    start = env.robot.pose()
    turned, last = 0.0, start.theta
    t0 = env.clock.now()
    limit = t0 + TIMEOUT_FACTOR * angle_deg / turn_speed_deg_s + 2.0
    while env.clock.now() < limit and math.degrees(turned) < angle_deg:
        if not env.robot.drive(left=-wheel, right=wheel):
            raise _abort(env, "turn")
        _cycle(env, period)
        theta = env.robot.pose().theta
        turned += wrap_angle(theta - last)
        last = theta
    drive_s = env.clock.now() - t0
    _settle(env, period)
    end = env.robot.pose()
    turned += wrap_angle(end.theta - last)
    return Leg(math.degrees(turned), drive_s, start, end)


def odometry_scale(*, measured_mm: float, odometry_mm: float, current: float = 1.0) -> float:
    """The mission's ``robot.odometry_scale`` that makes odometry read ``measured_mm`` where it
    read ``odometry_mm`` with the scale ``current``."""
    if measured_mm <= 0 or odometry_mm <= 0:
        raise ValueError("measured and odometry distances must be positive")
    return current * measured_mm / odometry_mm


def effective_wheel_base(*, wheel_base_mm: float, odometry_deg: float, measured_deg: float,
                         scale_change: float = 1.0) -> float:
    """The wheel base with which odometry (its distances times ``scale_change``) turns
    ``measured_deg`` where it turned ``odometry_deg``."""
    if measured_deg <= 0 or odometry_deg <= 0:
        raise ValueError("measured and odometry angles must be positive")
    return wheel_base_mm * scale_change * odometry_deg / measured_deg
