"""The later steps of a search, after a full turn on the spot found nothing.

The search is a Selector (memory) of three steps, each a leaf of the tree
(:func:`marknav.behaviours.route.search_strategy`)::

    Search        Selector(memory=True)
    ├── Spin      SearchWhenLost: a full turn on the spot toward where the target should be
    ├── Return    ReturnToSighting: face where it was last seen (or is predicted), drive to the
    │             range it was seen from, turn once more
    └── Advance   AdvanceAlongCourse: drive on along the course, turn once more

The parent ``Seen?|Search`` Selector has no memory, so the first tick the target is seen again
(``Seen?`` SUCCESS) halts whichever step is running; each step also returns SUCCESS itself
when it sees the target. A step that cannot run (nothing to return to, its distance set to 0)
fails at once and the next takes over. Every step is bounded: its leg by a distance
(``navigation.search.return_distance_mm``, ``advance_distance_mm``) and the time that distance
takes at twice the drive speed's duration, its closing turn by a full turn or
``navigation.search.timeout_s``. When the last step gives up, its message tells the whole
search (:class:`SearchLog`): the run's reason names every step and what it did.

Where the steps drive:

- **Return**: the place the target was last seen from is its world estimate at the range of
  its last sighting, on the line from the estimate to the robot (the robot moved on since: a
  mark lost beside or behind it is faced, then the robot backs away to that range; a mark lost
  far ahead is driven toward). A remembered mark (no sighting of this target) is looked at from
  ``look_from_mm``. A mark never seen is predicted by the route's geometry: the last passed mark
  plus the step from the one before it (a course of evenly spaced marks); with fewer than two
  passed marks nothing is predicted and the step fails.
- **Advance**: the course is the last bypass's course (the line it was planned along); before
  the first bypass, the heading the search began with.

Both legs stop short of every remembered or passed mark (robot radius + mark radius +
:data:`BLOCK_MARGIN_MM`) that lies in the direction of travel: the search never drives into a
mark it knows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.base import DrivingBehaviour, SetupError, check_positive, pick
from marknav.behaviours.search import LEFT, RIGHT, SearchLog, search_direction
from marknav.planning.kinematics import Pose, wrap_angle

__all__ = ["BLOCK_MARGIN_MM", "AdvanceAlongCourse", "Leg", "ReturnToSighting", "predicted_mark"]

#: A leg stops when a known mark ahead in the direction of travel is this much farther than
#: touching (robot radius + mark radius), mm: the robot's braking distance at 150 mm/s with
#: 0.1 s of command delay and 500 mm/s² is under 40 mm; the rest covers the mark estimate's scatter.
BLOCK_MARGIN_MM = 100.0
#: The heading counts as faced within this (deg): the closing turn sweeps the rest, and the
#: 57° view holds a mark 5° off-centre well inside it.
FACE_TOLERANCE_DEG = 5.0
#: Heading hold while driving a leg: turn rate per radian of heading error (1/s).
HEADING_GAIN_PER_S = 2.0
#: A leg may take this many times its length / drive speed before the step gives up (−):
#: turning to face, slowing and the heading hold lengthen it.
LEG_TIME_FACTOR = 2.0
#: Passed marks a prediction of the next needs: two give the route's step.
PREDICT_FROM_MARKS = 2
#: Time allowed to face the leg's heading (s) on top of half a turn at the turn rate.
FACE_SLACK_S = 1.0


@dataclass(frozen=True)
class Leg:
    """A step's leg: face ``point`` (or hold ``heading`` when ``point`` is None), then drive
    ``distance_mm`` (negative: reverse, still facing it); ``what`` names it for messages."""

    what: str
    distance_mm: float
    point: tuple[float, float] | None = None
    heading: float = 0.0

    def heading_at(self, pose: Pose) -> float:
        if self.point is None:
            return self.heading
        return math.atan2(self.point[1] - pose.y, self.point[0] - pose.x)


def predicted_mark(passed: tuple[keys.PassedWaypoint, ...]) -> tuple[float, float] | None:
    """Where the route's geometry puts the next mark: the last passed mark plus the step from
    the one before it; ``None`` with fewer than two passed."""
    if len(passed) < PREDICT_FROM_MARKS:
        return None
    a, b = passed[-2], passed[-1]
    return (2.0 * b.mark_x - a.mark_x, 2.0 * b.mark_y - a.mark_y)


class _SearchStep(DrivingBehaviour):
    """Face a heading, drive a leg holding it, then turn a full circle looking; SUCCESS as soon
    as the target is seen, FAILURE when the turn (or the time) is spent."""

    READS: ClassVar[tuple[str, ...]] = (keys.TARGET, keys.PASSED, keys.PLANS, keys.KNOWN)
    WRITES: ClassVar[tuple[str, ...]] = (keys.DRIVER,)
    #: The mission setting that bounds the leg, for messages.
    DISTANCE_SETTING: ClassVar[str] = ""

    def __init__(self, name: str, *, distance_mm: float | None = None,
                 speed_mm_s: float | None = None, log: SearchLog | None = None) -> None:
        super().__init__(name)
        if distance_mm is not None and not (math.isfinite(distance_mm) and distance_mm >= 0):
            raise ValueError(f"distance_mm must be >= 0, got {distance_mm!r}")
        self._distance_override = distance_mm
        self._speed_override = check_positive(speed_mm_s, "speed_mm_s")
        self.log = log if log is not None else SearchLog()
        self.settings: dict[str, float] = {}
        self.leg: Leg | None = None
        self.phase = "face"
        self._t0 = 0.0
        self._seen_t0 = -math.inf
        self._deadline = math.inf
        self._start: Pose | None = None
        self._last_theta = 0.0
        self.turned_rad = 0.0
        self.driven_mm = 0.0
        self._why_stopped = ""
        self._error: str | None = None

    def configure(self, **kwargs: Any) -> None:
        m = self.mission
        search = m.navigation.search if m is not None else None
        own = self._owner
        self.settings = {
            "distance_mm": pick(self._distance_override,
                                getattr(search, self.DISTANCE_SETTING) if search else None,
                                owner=own, what=f"search {self.DISTANCE_SETTING}"),
            "speed_mm_s": pick(self._speed_override, search.drive_speed_mm_s if search else None,
                               owner=own, what="search drive speed"),
            "turn_speed_deg_s": pick(None, search.turn_speed_deg_s if search else None,
                                     owner=own, what="search turn speed"),
            "timeout_s": pick(None, search.timeout_s if search else None, owner=own,
                              what="search timeout"),
            "look_from_mm": pick(None, search.look_from_mm if search else None, owner=own,
                                 what="search look_from_mm"),
            "wheel_base_mm": pick(None, m.robot.wheel_base_mm if m else None, owner=own,
                                  what="robot.wheel_base_mm"),
            "touch_mm": pick(None, m.robot.radius_mm + m.marks.radius_mm if m else None,
                             owner=own, what="robot.radius_mm"),
        }

    # -- what a step does ----------------------------------------------------------------------

    def plan_leg(self, target: keys.Target, pose: Pose) -> Leg | str:
        """The leg, or why this step cannot run."""
        raise NotImplementedError

    # -- lifecycle -----------------------------------------------------------------------------

    def initialise(self) -> None:
        if not self.settings:
            raise SetupError(f"{self._owner}: not set up (tree.setup(mission=...))")
        self._t0 = self.now()
        self.phase = "face"
        self.turned_rad = 0.0
        self.driven_mm = 0.0
        self._why_stopped = ""
        self._start = None
        self._error = None
        self.leg = None
        target = self.target()
        self._seen_t0 = (target.sighting.t if target is not None and target.sighting is not None
                         else -math.inf)
        pose = self.robot.pose()
        self._last_theta = pose.theta
        if target is None:
            self._error = "no target selected"
            return
        if self.settings["distance_mm"] <= 0.0:
            self._error = f"left out ({self.DISTANCE_SETTING} 0)"
            return
        leg = self.plan_leg(target, pose)
        if isinstance(leg, str):
            self._error = leg
            return
        self.leg = leg
        s = self.settings
        omega = math.radians(s["turn_speed_deg_s"])
        self._deadline = (self._t0 + math.pi / omega + FACE_SLACK_S
                          + LEG_TIME_FACTOR * abs(leg.distance_mm) / s["speed_mm_s"]
                          + s["timeout_s"])

    def update(self) -> Status:
        target = self.target()
        if self._error is not None or target is None or self.leg is None:
            return self._give_up(self._error or "no target selected")
        seen = target.sighting
        if seen is not None and (seen.t > self._seen_t0 or seen.t >= self._t0):
            self.feedback_message = (f"found {target.label} ({self.phase}, "
                                     f"{self.driven_mm:.0f} mm driven)")
            self.log.add(f"{self.name.lower()}: found it")
            return Status.SUCCESS
        if self.now() > self._deadline:
            return self._give_up(f"out of time ({self.now() - self._t0:.1f} s) while "
                                 f"{'driving' if self.phase != 'turn' else 'turning'}")
        pose = self.robot.pose()
        if self.phase == "face":
            return self._face(pose)
        if self.phase == "drive":
            return self._drive(pose, target)
        return self._turn(pose, target)

    # -- phases --------------------------------------------------------------------------------

    def _wheels_turn(self, direction: float) -> None:
        omega = direction * math.radians(self.settings["turn_speed_deg_s"])
        half = 0.5 * self.settings["wheel_base_mm"]
        self.drive(left=-omega * half, right=omega * half)

    def _face(self, pose: Pose) -> Status:
        assert self.leg is not None
        error = wrap_angle(self.leg.heading_at(pose) - pose.theta)
        if abs(error) <= math.radians(FACE_TOLERANCE_DEG):
            self.phase = "drive"
            self._start = pose
            return self._drive(pose, None)
        self._wheels_turn(LEFT if error > 0.0 else RIGHT)
        self.feedback_message = f"{self.leg.what}: turning to face it, {math.degrees(error):+.0f}°"
        return Status.RUNNING

    def _drive(self, pose: Pose, target: keys.Target | None) -> Status:
        assert self.leg is not None and self._start is not None
        leg = self.leg
        self.driven_mm = math.hypot(pose.x - self._start.x, pose.y - self._start.y)
        forward = 1.0 if leg.distance_mm >= 0.0 else -1.0
        blocked = self._blocked(pose, forward)
        if self.driven_mm >= abs(leg.distance_mm) or blocked:
            self._why_stopped = blocked
            self.phase = "turn"
            self._last_theta = pose.theta
            self.robot.stop()
            self.feedback_message = f"{leg.what}: {self.driven_mm:.0f} mm driven, looking"
            return Status.RUNNING
        s = self.settings
        error = wrap_angle(leg.heading_at(pose) - pose.theta)
        omega = max(-math.radians(s["turn_speed_deg_s"]),
                    min(math.radians(s["turn_speed_deg_s"]), HEADING_GAIN_PER_S * error))
        v = forward * s["speed_mm_s"]
        half = 0.5 * s["wheel_base_mm"]
        self.drive(left=v - omega * half, right=v + omega * half)
        self.feedback_message = (f"{leg.what}: {self.driven_mm:.0f}/{abs(leg.distance_mm):.0f} mm "
                                 f"{'ahead' if forward > 0 else 'back'}")
        return Status.RUNNING

    def _turn(self, pose: Pose, target: keys.Target) -> Status:
        self.turned_rad += abs(wrap_angle(pose.theta - self._last_theta))
        self._last_theta = pose.theta
        if self.turned_rad >= math.tau:
            return self._give_up(f"not seen in a full turn after driving "
                                 f"{self.driven_mm:.0f} mm" + (f" ({self._why_stopped})"
                                                               if self._why_stopped else ""))
        passed: tuple[keys.PassedWaypoint, ...] = self.read(keys.PASSED, ())
        self._wheels_turn(search_direction(target, pose, passed[-1] if passed else None))
        self.feedback_message = (f"looking for {target.label}: "
                                 f"{math.degrees(self.turned_rad):.0f}° turned")
        return Status.RUNNING

    def _blocked(self, pose: Pose, forward: float) -> str:
        """Why the leg must stop here: a known mark close ahead in the direction of travel."""
        reach = self.settings["touch_mm"] + BLOCK_MARGIN_MM
        c, s = math.cos(pose.theta), math.sin(pose.theta)
        known: tuple[keys.KnownMark, ...] = self.read(keys.KNOWN, ())
        passed: tuple[keys.PassedWaypoint, ...] = self.read(keys.PASSED, ())
        points = [k.world for k in known] + [(p.mark_x, p.mark_y) for p in passed]
        for x, y in points:
            dx, dy = x - pose.x, y - pose.y
            if forward * (c * dx + s * dy) > 0.0 and math.hypot(dx, dy) < reach:
                return f"stopped {math.hypot(dx, dy):.0f} mm from a mark at ({x:.0f}, {y:.0f})"
        return ""

    def _give_up(self, why: str) -> Status:
        self.log.add(f"{self.name.lower()}: {why}")
        target = self.target()
        label = target.label if target is not None else "the target"
        return self.fail(f"{label} not found; gave up after {self.log.summary()}")


class ReturnToSighting(_SearchStep):
    """Go back to where the target was last seen from (or is predicted), facing it; turn there.

    Args (``None`` takes the mission's ``navigation.search``): ``distance_mm`` (the farthest
    it drives, ``return_distance_mm``), ``speed_mm_s`` (``drive_speed_mm_s``), ``log`` (the
    search's :class:`SearchLog`, shared by its steps).
    """

    DISTANCE_SETTING: ClassVar[str] = "return_distance_mm"

    def __init__(self, name: str = "Return", *, distance_mm: float | None = None,
                 speed_mm_s: float | None = None, log: SearchLog | None = None) -> None:
        super().__init__(name, distance_mm=distance_mm, speed_mm_s=speed_mm_s, log=log)

    def plan_leg(self, target: keys.Target, pose: Pose) -> Leg | str:
        passed: tuple[keys.PassedWaypoint, ...] = self.read(keys.PASSED, ())
        if target.world is not None:
            mark = target.world
            if target.sighting is not None:
                look_from, what = target.sighting.range_mm, "back to where it was last seen"
            else:
                look_from, what = self.settings["look_from_mm"], "to where it is remembered"
        else:
            predicted = predicted_mark(passed)
            if predicted is None:
                return "never seen, and fewer than two marks passed to predict it from"
            mark, look_from = predicted, self.settings["look_from_mm"]
            what = "toward the prediction"
        away = math.hypot(mark[0] - pose.x, mark[1] - pose.y)
        limit = self.settings["distance_mm"]
        distance = max(-limit, min(limit, away - look_from))
        return Leg(what=f"return {what}", distance_mm=distance, point=mark)


class AdvanceAlongCourse(_SearchStep):
    """Drive on along the course (the last bypass's, else the search's starting heading), then
    turn once more.

    Args as :class:`ReturnToSighting` (``distance_mm``: ``advance_distance_mm``).
    """

    DISTANCE_SETTING: ClassVar[str] = "advance_distance_mm"

    def __init__(self, name: str = "Advance", *, distance_mm: float | None = None,
                 speed_mm_s: float | None = None, log: SearchLog | None = None) -> None:
        super().__init__(name, distance_mm=distance_mm, speed_mm_s=speed_mm_s, log=log)

    def plan_leg(self, target: keys.Target, pose: Pose) -> Leg | str:
        plans: tuple[keys.PlanRecord, ...] = self.read(keys.PLANS, ())
        if plans:
            heading, what = plans[-1].plan.course, "the last bypass's course"
        elif self.log.start_heading is not None:
            heading, what = self.log.start_heading, "the heading the search began with"
        else:
            heading, what = pose.theta, "the current heading"
        return Leg(what=f"advance along {what}", distance_mm=self.settings["distance_mm"],
                   heading=heading)
