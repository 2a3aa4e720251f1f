"""The tree's view of the safety layer: abort on a fault, back off after a bump.

The safety layer (:mod:`marknav.robot.safety`) already stops the wheels on a bump, a cliff, a
wheel drop, an overcurrent, a lost sensor stream or an e-stop, and refuses forward commands until
the condition clears; these behaviours decide what the *mission* does about it, reading
``robot.safety_state`` (one of :data:`marknav.robot.robot.SAFETY_STATES`):

- :class:`SafetyGuard` — FAILURE at once on ``fault`` or ``estopped`` (feedback: the layer's
  ``fault_reason``) or ``disconnected``; SUCCESS otherwise. First in the reactive root, so the
  mission aborts on the tick the fault is seen and the running behaviour is terminated (wheels
  stopped).
- :class:`NotBumped` (``NotBumped?``) — SUCCESS unless the robot is bumped or a recovery is under
  way.
- :class:`BackOff` — the recovery: reverse ``distance_mm`` (150 mm) at ``speed_mm_s`` or for at
  most ``max_duration_s`` (1.5 s) through ``robot.backoff`` (the one motion the layer allows while
  bumped), then SUCCESS so the route resumes (and searches again if the mark is out of view). The
  recovery count is kept in ``/marknav/recovery``; the bump after ``max_bump_recoveries``
  recoveries aborts the mission ("bumped N times").
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.base import DrivingBehaviour, MarknavBehaviour, check_positive, pick
from marknav.planning.kinematics import Pose
from marknav.robot.robot import BUMPED, DISCONNECTED, ESTOPPED, FAULT

__all__ = ["BackOff", "NotBumped", "SafetyGuard"]


class SafetyGuard(MarknavBehaviour):
    """FAILURE (mission aborted) on a fault, an e-stop or a disconnected robot, else SUCCESS."""

    ABORTS: ClassVar[bool] = True

    def __init__(self, name: str = "SafetyGuard") -> None:
        super().__init__(name)

    def update(self) -> Status:
        state = self.robot.safety_state
        if state in (FAULT, ESTOPPED):
            self.feedback_message = self.robot.fault_reason or state
            return Status.FAILURE
        if state == DISCONNECTED:
            self.feedback_message = "robot disconnected"
            return Status.FAILURE
        self.feedback_message = state
        return Status.SUCCESS


class NotBumped(MarknavBehaviour):
    """``NotBumped?``: SUCCESS unless the robot is bumped or a bump recovery is under way."""

    READS: ClassVar[tuple[str, ...]] = (keys.RECOVERY,)

    def __init__(self, name: str = "NotBumped?") -> None:
        super().__init__(name)

    def update(self) -> Status:
        if self.robot.safety_state == BUMPED:
            self.feedback_message = "bumped"
            return Status.FAILURE
        recovery: keys.Recovery = self.read(keys.RECOVERY, keys.Recovery())
        if recovery.active:
            self.feedback_message = "recovery under way"
            return Status.FAILURE
        self.feedback_message = "clear"
        return Status.SUCCESS


class BackOff(DrivingBehaviour):
    """Reverse away from what the bumper hit, counting recoveries; abort after too many.

    Args:
        distance_mm: how far to reverse (odometry).
        speed_mm_s: reversing speed (both wheels).
        max_duration_s: stop reversing after this long even if the distance was not reached.
        max_recoveries: default: the mission's ``safety.max_bump_recoveries``.

    When it starts while the robot is neither bumped nor recovering there is nothing to do: SUCCESS.
    """

    READS: ClassVar[tuple[str, ...]] = (keys.RECOVERY,)
    WRITES: ClassVar[tuple[str, ...]] = (keys.DRIVER, keys.RECOVERY)
    ABORTS: ClassVar[bool] = True

    def __init__(
        self,
        name: str = "BackOff",
        *,
        distance_mm: float = 150.0,
        speed_mm_s: float = 150.0,
        max_duration_s: float = 1.5,
        max_recoveries: int | None = None,
    ) -> None:
        super().__init__(name)
        check_positive(distance_mm, "distance_mm")
        check_positive(speed_mm_s, "speed_mm_s")
        check_positive(max_duration_s, "max_duration_s")
        if max_recoveries is not None and max_recoveries < 0:
            raise ValueError(f"max_recoveries must be >= 0, got {max_recoveries!r}")
        self.distance_mm = float(distance_mm)
        self.speed_mm_s = float(speed_mm_s)
        self.max_duration_s = float(max_duration_s)
        self._max_override = max_recoveries
        self.max_recoveries: int | None = max_recoveries
        self._mode = "idle"  # "noop" | "abort" | "reverse"
        self._count = 0
        self._start: Pose | None = None
        self._t0 = 0.0

    def configure(self, **kwargs: Any) -> None:
        m = self.mission
        self.max_recoveries = pick(self._max_override,
                                   m.safety.max_bump_recoveries if m else None,
                                   owner=self._owner, what="max_bump_recoveries")

    def initialise(self) -> None:
        recovery: keys.Recovery = self.read(keys.RECOVERY, keys.Recovery())
        if self.robot.safety_state != BUMPED and not recovery.active:
            self._mode = "noop"
            return
        self._count = recovery.count + 1
        self._t0 = self.now()
        self._start = self.robot.pose()
        self.write(keys.RECOVERY, keys.Recovery(count=self._count, active=True,
                                                started_t=self._t0))
        limit = self.max_recoveries if self.max_recoveries is not None else 0
        self._mode = "abort" if self._count > limit else "reverse"

    def update(self) -> Status:
        if self._mode == "noop":
            self.feedback_message = "not bumped: nothing to recover from"
            return Status.SUCCESS
        if self._mode == "abort":
            self._finish()
            return self.fail(f"bumped {self._count} times "
                             f"(max_bump_recoveries {self.max_recoveries})")
        assert self._start is not None
        pose = self.robot.pose()
        travelled = math.hypot(pose.x - self._start.x, pose.y - self._start.y)
        elapsed = self.now() - self._t0
        if travelled >= self.distance_mm or elapsed >= self.max_duration_s:
            self._finish()
            self.feedback_message = (f"backed off {travelled:.0f} mm in {elapsed:.1f} s "
                                     f"(recovery {self._count} of {self.max_recoveries})")
            return Status.SUCCESS
        accepted = self.backoff(left=-self.speed_mm_s, right=-self.speed_mm_s)
        state = "" if accepted else f", refused ({self.robot.safety_state})"
        self.feedback_message = (f"backing off: {travelled:.0f}/{self.distance_mm:.0f} mm "
                                 f"(recovery {self._count} of {self.max_recoveries}){state}")
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        super().terminate(new_status)
        if new_status == Status.INVALID and self._mode == "reverse":
            self._finish()  # interrupted (e.g. by a fault): the recovery is over either way
        self._mode = "idle"

    def _finish(self) -> None:
        recovery: keys.Recovery = self.read(keys.RECOVERY, keys.Recovery())
        if recovery.active:
            self.write(keys.RECOVERY, keys.Recovery(count=recovery.count, active=False,
                                                    started_t=recovery.started_t))
