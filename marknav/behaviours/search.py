"""Turn on the spot until the target is in view again (the lost-target branch of the route).

Which way to turn:

1. toward where the target was last seen: its world estimate, put in the robot frame with the
   current odometry pose, is on the left (turn counter-clockwise) or on the right (clockwise);
2. when it was never seen, toward the mark passed last: its bypass ended beside the course on that
   mark's far side, so the course and the next mark lie toward it (in a slalom, after passing a
   mark with it on the right, the next one is ahead-right);
3. at the first waypoint, toward where the route says it should be. A mark to be passed on its
   **left** is one the robot will drive by with the mark on its **right**: a course laid for that
   has the mark ahead-right of the robot's path, so turn **right** (clockwise). A mark to be passed
   on its right lies ahead-left: turn left.

The turn rate is ``navigation.search.turn_speed_deg_s`` (wheels ∓ω·b/2, eq. 27). SUCCESS as soon as
the target is seen after the search started; FAILURE after ``navigation.search.timeout_s`` or a
full turn (360° of heading change, summed from odometry), whichever comes first.

A *remembered* target (chosen from the mark memory, out of view) is recognised only near its
remembered position and range. When a full turn has not found it there, the memory was wrong
(an estimate from far away, odometry drift): the remembered mark is forgotten, the target is
chosen again as at the waypoint's start (another remembered mark of its colour when clearly
nearer than the nearest unpassed one in view, else that one; an ordinary target if neither), and
the search starts again, once, toward it, for another full turn and timeout. (Perception does the
same as soon as the remembered position is in view and nothing is seen there.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.base import DrivingBehaviour, SetupError, check_positive, pick
from marknav.behaviours.target import excluded_passes, gate_mm, reselect
from marknav.planning.kinematics import Pose, to_robot_frame, wrap_angle

__all__ = ["SearchLog", "SearchWhenLost", "search_direction"]

LEFT = 1  # counter-clockwise
RIGHT = -1  # clockwise


@dataclass
class SearchLog:
    """What a search's steps did, in order, for the message of the step that gives up. The first
    step (the spin) clears it when a search begins."""

    steps: list[str] = field(default_factory=list)
    #: The robot's heading when the search began (rad): the course before any bypass.
    start_heading: float | None = None

    def begin(self, heading: float) -> None:
        self.steps.clear()
        self.start_heading = heading

    def add(self, text: str) -> None:
        self.steps.append(text)

    def summary(self) -> str:
        return "; ".join(self.steps)


def search_direction(
    target: keys.Target, pose: Pose, previous: keys.PassedWaypoint | None = None
) -> int:
    """+1 (turn left, CCW) or −1 (turn right, CW): toward the last sighting; for a mark never
    seen, toward the mark passed last (the bypass left the robot beside the course, on that
    mark's far side, so the course — and the next mark — lies toward it); with neither, by the
    target's pass side."""
    for point in (target.world, (previous.mark_x, previous.mark_y) if previous else None):
        if point is None:
            continue
        _, left = to_robot_frame(pose, point)
        if left > 0.0:
            return LEFT
        if left < 0.0:
            return RIGHT
    return RIGHT if target.side == "left" else LEFT


class SearchWhenLost(DrivingBehaviour):
    """Turn in place toward where the target should be until it is seen again.

    Args (``None`` takes the mission's ``navigation.search``):
        turn_speed_deg_s: turn rate, degrees per second.
        timeout_s: FAILURE after this long.
        log: the :class:`SearchLog` of a search of several steps
            (:mod:`marknav.behaviours.search_steps`): this, the first step, begins it and adds
            what it did when it fails.

    Setup: ``robot``, ``clock``, ``mission`` (wheel base and the defaults above).
    """

    READS: ClassVar[tuple[str, ...]] = (keys.TARGET, keys.PASSED, keys.KNOWN, keys.MARKS)
    WRITES: ClassVar[tuple[str, ...]] = (keys.DRIVER, keys.TARGET, keys.KNOWN)

    def __init__(
        self,
        name: str = "Search",
        *,
        turn_speed_deg_s: float | None = None,
        timeout_s: float | None = None,
        log: SearchLog | None = None,
    ) -> None:
        super().__init__(name)
        self.log = log
        self._turn_override = check_positive(turn_speed_deg_s, "turn_speed_deg_s")
        self._timeout_override = check_positive(timeout_s, "timeout_s")
        self.turn_speed_deg_s: float | None = turn_speed_deg_s
        self.timeout_s: float | None = timeout_s
        self.wheel_base_mm: float | None = None
        self.direction = 0
        self._t0 = 0.0
        self._seen_t0 = -math.inf
        self._last_theta = 0.0
        self.turned_rad = 0.0
        self.forgot_memory = False

    def configure(self, **kwargs: Any) -> None:
        m = self.mission
        self.turn_speed_deg_s = pick(
            self._turn_override, m.navigation.search.turn_speed_deg_s if m else None,
            owner=self._owner, what="search turn speed")
        self.timeout_s = pick(self._timeout_override,
                              m.navigation.search.timeout_s if m else None,
                              owner=self._owner, what="search timeout")
        self.wheel_base_mm = pick(None, m.robot.wheel_base_mm if m else None,
                                  owner=self._owner, what="robot.wheel_base_mm")

    def initialise(self) -> None:
        self._t0 = self.now()
        start = self.target()
        # Found: a sighting captured since the start, or newer than the one there was then (a
        # late frame's sighting counts even when captured before the start).
        self._seen_t0 = (start.sighting.t if start is not None and start.sighting is not None
                         else -math.inf)
        pose = self.robot.pose()
        if self.log is not None:
            self.log.begin(pose.theta)
        self._last_theta = pose.theta
        self.turned_rad = 0.0
        self.forgot_memory = False
        target = self.target()
        passed: tuple[keys.PassedWaypoint, ...] = self.read(keys.PASSED, ())
        previous = passed[-1] if passed else None
        self.direction = search_direction(target, pose, previous) if target is not None else 0
        self.feedback_message = "starting"

    def update(self) -> Status:
        if self.turn_speed_deg_s is None or self.timeout_s is None or self.wheel_base_mm is None:
            raise SetupError(f"{self._owner}: not set up (tree.setup(mission=...))")
        target = self.target()
        if target is None or self.direction == 0:
            return self.fail("no target selected")
        elapsed = self.now() - self._t0
        seen = target.sighting
        if seen is not None and (seen.t > self._seen_t0 or seen.t >= self._t0):
            self.feedback_message = (f"found {target.label} after "
                                     f"{math.degrees(self.turned_rad):.0f}° ({elapsed:.1f} s)")
            return Status.SUCCESS
        theta = self.robot.pose().theta
        self.turned_rad += abs(wrap_angle(theta - self._last_theta))
        self._last_theta = theta
        if self.turned_rad >= math.tau and target.remembered and not target.locked \
                and not self.forgot_memory:
            self._forget(target)
            self.feedback_message = (f"{target.label} not where remembered: looking for the "
                                     f"nearest {target.colour} instead")
            return Status.RUNNING
        if self.turned_rad >= math.tau:
            return self._give_up(target, f"not found in a full turn ({elapsed:.1f} s)")
        if elapsed >= self.timeout_s:
            return self._give_up(target, f"not found in {self.timeout_s:g} s "
                                 f"(turned {math.degrees(self.turned_rad):.0f}°)")
        omega = self.direction * math.radians(self.turn_speed_deg_s)
        half = 0.5 * self.wheel_base_mm
        self.drive(left=-omega * half, right=omega * half)
        way = "left" if self.direction == LEFT else "right"
        self.feedback_message = (f"looking for {target.label}: turning {way}, "
                                 f"{math.degrees(self.turned_rad):.0f}°, "
                                 f"{elapsed:.1f}/{self.timeout_s:g} s")
        return Status.RUNNING

    def _give_up(self, target: keys.Target, why: str) -> Status:
        if self.log is not None:
            self.log.add(f"{self.name.lower()}: {why}")
        return self.fail(f"{target.label} {why}")

    def _forget(self, target: keys.Target) -> None:
        """Drop the remembered mark the target was taken from, choose the target again (another
        remembered mark of its colour, or the nearest in view; an ordinary one if neither) and
        start the turn again."""
        self.forgot_memory = True
        known: tuple[keys.KnownMark, ...] = self.read(keys.KNOWN, ())
        if target.world is not None:
            tx, ty = target.world
            known = tuple(k for k in known if not (k.colour == target.colour and math.hypot(
                k.world_x - tx, k.world_y - ty) <= gate_mm(k.range_mm)))
            self.write(keys.KNOWN, known)
        passed = excluded_passes(self.read(keys.PASSED, ()), self.mission)
        marks: tuple[keys.SeenMark, ...] = self.read(keys.MARKS, ())
        pose = self.robot.pose()
        chosen = reselect(target, marks, known, passed, pose)
        if chosen.world is None:
            chosen = replace(target, remembered=False)
        self.write(keys.TARGET, chosen)
        self.direction = search_direction(chosen, pose, passed[-1] if passed else None)
        self._t0 = self.now()
        self.turned_rad = 0.0
