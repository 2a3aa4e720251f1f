"""A fake robot for behaviour tests: the real safety layer, an integrated pose, injectable trouble.

:class:`FakeRobot` satisfies :class:`marknav.robot.robot.Robot`. Its wheel commands go through
the real :class:`marknav.robot.safety.SafetyLayer` (so bumps, faults, e-stops, the command
watchdog and the back-off rule behave exactly as on the Create), into a recording sink. Time comes
from the injected clock: whenever the robot is used it catches up with the clock in 15 ms steps
(the Create's sensor-stream period), integrating the pose from the wheel speeds the sink last
accepted (eqs. 25–30, :func:`marknav.planning.kinematics.integrate_pose`), delivering a sensor
frame to the safety layer and so letting its watchdogs run. A test that advances its clock by a
second sees what a real robot would have done in that second.

Odometry (:meth:`FakeRobot.pose`) integrates the commanded speeds; the true pose
(:attr:`FakeRobot.true_pose`) integrates them times ``wheel_scale`` — a wheel 3 % slow is
``wheel_scale=(1.0, 0.97)`` — so closed-loop behaviour under slip can be tested.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from marknav.core.clock import Clock, ManualClock
from marknav.planning.kinematics import Pose, integrate_pose
from marknav.robot.safety import SafetyEvent, SafetyFlags, SafetyLayer

__all__ = ["DriveRequest", "FakeRobot", "WheelCommand"]

#: The Create streams a sensor frame every 15 ms.
SENSOR_PERIOD_S = 0.015


@dataclass(frozen=True, init=False)
class WheelCommand:
    """What reached the wheels (the safety layer's sink): clock time, mm/s per wheel. (Made at
    every change of speed: a one-step constructor, as keys.SeenMark's.)"""

    t: float
    left: int
    right: int

    def __init__(self, t: float, left: int, right: int) -> None:
        self.__dict__.update(t=t, left=left, right=right)


@dataclass(frozen=True, init=False)
class DriveRequest:
    """What a behaviour asked for: ``kind`` is ``drive``, ``backoff`` or ``stop``. (Made every
    tick: a one-step constructor, as keys.SeenMark's.)"""

    t: float
    kind: str
    left: float
    right: float
    accepted: bool

    def __init__(self, t: float, kind: str, left: float, right: float,
                 accepted: bool) -> None:
        self.__dict__.update(t=t, kind=kind, left=left, right=right, accepted=accepted)


class _Sink:
    """The safety layer's wheel sink: records and sets the speeds the fake integrates."""

    def __init__(self, robot: FakeRobot) -> None:
        self._robot = robot

    def drive_direct(self, *, left: int, right: int) -> None:
        self._robot._on_wheels(left, right)


class FakeRobot:
    """A simulated differential-drive robot with the real safety layer in front of its wheels.

    Args:
        clock: the test's clock (a :class:`~marknav.core.clock.ManualClock`, usually).
        pose: start pose (world frame; default at the origin facing +y, θ = π/2).
        wheel_base_mm: distance between the wheels.
        max_wheel_mm_s: the safety layer's wheel limit (both wheels scaled together above it).
        command_timeout_s, sensor_timeout_s: the safety layer's watchdogs.
        wheel_scale: true wheel speed / commanded, per wheel (odometry does not see it).
        connect: connect the safety layer at once (state ``ready``).

    Injection: :meth:`bump`, :meth:`release_bump`, :meth:`set_sensors` (any
    :class:`~marknav.robot.safety.SafetyFlags` field: ``cliff_front_left=True`` latches a
    fault), :meth:`estop`, :meth:`lose_link`, :meth:`reset`, and :attr:`sensors_streaming`
    (``False`` stops the sensor stream, which trips the sensor watchdog).

    Records: :attr:`commands` (sink), :attr:`requests` (behaviours' calls), :attr:`trajectory`
    (true pose every 15 ms) and the safety layer's :attr:`events`.
    """

    def __init__(
        self,
        *,
        clock: Clock,
        pose: Pose | None = None,
        wheel_base_mm: float = 235.0,
        max_wheel_mm_s: int = 500,
        command_timeout_s: float = 0.3,
        sensor_timeout_s: float = 0.2,
        wheel_scale: tuple[float, float] = (1.0, 1.0),
        connect: bool = True,
    ) -> None:
        if not wheel_base_mm > 0:
            raise ValueError(f"wheel_base_mm must be positive, got {wheel_base_mm!r}")
        self.clock = clock
        self.wheel_base_mm = float(wheel_base_mm)
        self.wheel_scale = (float(wheel_scale[0]), float(wheel_scale[1]))
        start = pose if pose is not None else Pose(0.0, 0.0, math.pi / 2)
        self._odometry = start
        self._true = start
        self._wheels = (0, 0)
        self._sensors = SafetyFlags()
        self.sensors_streaming = True
        self.commands: list[WheelCommand] = []
        self.requests: list[DriveRequest] = []
        self.trajectory: list[tuple[float, Pose]] = [(clock.now(), start)]
        # The layer's own clock follows the test's clock in sensor-period steps (see module doc).
        self._t = clock.now()
        self._layer_clock = ManualClock(self._t)
        self._next_frame_t = self._t + SENSOR_PERIOD_S
        self.safety = SafetyLayer(_Sink(self), clock=self._layer_clock,
                                  command_timeout_s=command_timeout_s,
                                  sensor_timeout_s=sensor_timeout_s,
                                  max_wheel_mm_s=max_wheel_mm_s)
        if connect:
            self.connect()

    # -- the Robot protocol -------------------------------------------------------------------

    def drive(self, *, left: float, right: float) -> bool:
        self.sync()
        ok = self.safety.command(left=left, right=right)
        self.requests.append(DriveRequest(self._t, "drive", left, right, ok))
        return ok

    def backoff(self, *, left: float, right: float) -> bool:
        self.sync()
        ok = self.safety.backoff(left=left, right=right)
        self.requests.append(DriveRequest(self._t, "backoff", left, right, ok))
        return ok

    def stop(self) -> None:
        self.sync()
        self.safety.stop()
        self.requests.append(DriveRequest(self._t, "stop", 0.0, 0.0, True))

    def pose(self) -> Pose:
        """Odometry pose (world frame, mm, rad)."""
        self.sync()
        return self._odometry

    @property
    def safety_state(self) -> str:
        self.sync()
        return self.safety.state.value

    @property
    def fault_reason(self) -> str | None:
        self.sync()
        return self.safety.fault_reason

    # -- more for tests ------------------------------------------------------------------------

    @property
    def true_pose(self) -> Pose:
        """Where the robot really is (differs from odometry when ``wheel_scale`` is not 1)."""
        self.sync()
        return self._true

    @property
    def wheels(self) -> tuple[int, int]:
        """(left, right) mm/s the wheels are turning at now."""
        self.sync()
        return self._wheels

    @property
    def events(self) -> list[SafetyEvent]:
        """The safety layer's recorded transitions."""
        return self.safety.events

    def connect(self) -> None:
        """Connect the safety layer (``ready``) and deliver a first sensor frame."""
        self.sync()
        self.safety.connect()
        self._frame()

    def bump(self, *, left: bool = True, right: bool = True) -> None:
        """Press the bumper(s): a sensor frame with the bump is delivered now."""
        self.set_sensors(bump_left=left, bump_right=right)

    def release_bump(self) -> None:
        """Release both bumpers (delivered now)."""
        self.set_sensors(bump_left=False, bump_right=False)

    def set_sensors(self, **flags: bool | int) -> None:
        """Change sensor flags (``SafetyFlags`` fields); they hold in every following frame and a
        frame is delivered now."""
        self.sync()
        self._sensors = replace(self._sensors, **flags)  # type: ignore[arg-type]
        self._frame()

    def estop(self, reason: str = "test") -> None:
        """Emergency stop through the safety layer (latched until :meth:`reset`)."""
        self.sync()
        self.safety.estop(reason)

    def lose_link(self, message: str = "device disconnected") -> None:
        """The serial link fails: the safety layer latches ``fault``."""
        self.sync()
        self.safety.on_link_lost(message)

    def reset(self) -> bool:
        """Leave fault / e-stop once the condition is gone (clear the flags first)."""
        self.sync()
        return self.safety.reset()

    def sync(self) -> None:
        """Catch up with the clock: integrate, deliver sensor frames, run the watchdogs."""
        now = self.clock.now()
        while self._next_frame_t <= now:
            self._advance_to(self._next_frame_t)
            self._next_frame_t += SENSOR_PERIOD_S
            if self.sensors_streaming:
                self._frame()
            else:
                self.safety.poll()
        if now > self._t:
            self._advance_to(now)
            self.safety.poll()

    # -- internals -----------------------------------------------------------------------------

    def _advance_to(self, t: float) -> None:
        dt = t - self._t
        if dt > 0.0:
            left, right = self._wheels
            self._odometry = integrate_pose(self._odometry, left=left, right=right, dt=dt,
                                            wheel_base_mm=self.wheel_base_mm)
            self._true = integrate_pose(self._true, left=left * self.wheel_scale[0],
                                        right=right * self.wheel_scale[1], dt=dt,
                                        wheel_base_mm=self.wheel_base_mm)
            self._t = t
            self.trajectory.append((t, self._true))
        self._layer_clock.set(max(t, self._layer_clock.now()))

    def _frame(self) -> None:
        self.safety.on_sensors(self._sensors)

    def _on_wheels(self, left: int, right: int) -> None:
        self._wheels = (left, right)
        self.commands.append(WheelCommand(self._t, left, right))
