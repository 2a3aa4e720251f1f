"""The robot as the behaviour tree sees it: one small protocol.

The serial Create driver, the simulator's robot and :class:`marknav.testing.FakeRobot` all
satisfy :class:`Robot`, so a behaviour cannot tell them apart. Every wheel command goes through
the safety layer: :meth:`Robot.drive` returns ``False`` when the layer refuses it (bumped, fault,
e-stop).
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

from marknav.planning.kinematics import Pose

#: Safety states, as strings the behaviours compare against (``Robot.safety_state``).
DISCONNECTED = "disconnected"
READY = "ready"
DRIVING = "driving"
BUMPED = "bumped"
FAULT = "fault"
ESTOPPED = "estopped"
SAFETY_STATES = (DISCONNECTED, READY, DRIVING, BUMPED, FAULT, ESTOPPED)


@runtime_checkable
class Robot(Protocol):
    """What a behaviour may do with the robot."""

    def drive(self, *, left: float, right: float) -> bool:
        """Command wheel speeds (mm/s) through the safety layer; ``False`` if refused."""
        ...

    def backoff(self, *, left: float, right: float) -> bool:
        """Reverse (both speeds ≤ 0) — the one motion allowed while bumped."""
        ...

    def stop(self) -> None:
        """Stop both wheels (always allowed)."""
        ...

    def pose(self) -> Pose:
        """Odometry pose in the world frame (mm, rad)."""
        ...

    @property
    def safety_state(self) -> str:
        """One of :data:`SAFETY_STATES`."""
        ...

    @property
    def fault_reason(self) -> str | None:
        """Why the robot is in fault or e-stop, else ``None``."""
        ...


@runtime_checkable
class WheelCalibratable(Protocol):
    """A robot whose odometry can be calibrated from sightings (the Create driver).

    Optional: behaviours check ``isinstance(robot, WheelCalibratable)`` before using it.
    """

    def odometry_snapshot(self) -> tuple[Pose, tuple[float, float, float]]:
        """The pose and ∂pose/∂(right wheel scale) since the last calibration step."""
        ...

    def scale_right_wheel(self, factor: float) -> None:
        """Count the right wheel's travel ``factor`` times more from now on (and re-anchor)."""
        ...

    def anchor_odometry(self) -> None:
        """Restart the sensitivity from zero at the current pose."""
        ...

    @property
    def right_wheel_scale(self) -> float:
        """The right wheel's odometry scale (1 until calibrated)."""
        ...
