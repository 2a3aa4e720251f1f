"""Confirm a doubtful pass by looking back at the mark (``Verify``, after ``Bypass``).

The bypass records every pass with its own verdict (:func:`marknav.behaviours.bypass.
verify_pass`): ``doubt`` is ``None`` when what the robot saw during the bypass agrees with what
it drove. A pass without doubt is done at once. A doubtful one is checked:

1. the robot turns to face where it believes the mark is (behind it, on the pass side), then on
   through the course line behind it to the mirror image of that point across the driven line
   (where the mark would be, had it passed on the wrong side);
2. every frame, the nearest mark of the target's colour to the believed position — within twice
   its offset from the driven line plus the association gate, so that a mark on the wrong side
   still counts, and never a mark another waypoint passed — is placed across the course line
   through the pose the look began at (the bypass's run-out ends on that line). Once
   ``navigation.verify_pass.min_sightings`` whole sightings are in (a disc cut by the image's
   edge gives the range of a part), their median offset decides:

   - at least the mark's radius on the pass side: **confirmed**; the waypoint is ``passed``;
   - at least the mark's radius on the other side: **refuted**; FAILURE, the mark was passed
     on its wrong side;
   - in between (on the line driven: the robot would have touched it): no decision yet;

3. no decision by the end of the sweep or ``navigation.verify_pass.timeout_s``: **unverified**;
   the route goes on, the waypoint is reported ``unverified`` and the run's outcome with it.

After a decision other than refuted the robot turns back to the course heading (within the
time left), so the next waypoint starts as it would have without the look back. The verdict is
written to the waypoint's :class:`~marknav.behaviours.keys.PassedWaypoint` (``check``); the
default tree's ``Passed?`` waits for it (``wait_for_check``), so an interruption resumes the
check, not the next waypoint.
"""

from __future__ import annotations

import math
import statistics
from dataclasses import replace
from typing import Any, ClassVar

from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.base import DrivingBehaviour, SetupError, pick
from marknav.behaviours.bypass import lateral_of
from marknav.behaviours.search import LEFT, RIGHT
from marknav.behaviours.target import sighting_gate_mm
from marknav.planning.kinematics import Pose, wrap_angle

__all__ = ["CONFIRMED", "REFUTED", "UNVERIFIED", "VerifyPass", "decide_side"]

CONFIRMED = "confirmed"
REFUTED = "refuted"
UNVERIFIED = "unverified"

#: A heading counts as reached within this (deg): a 57° view holds the point well inside.
AIM_TOLERANCE_DEG = 5.0


def decide_side(offsets_mm: list[float], mark_radius_mm: float) -> str | None:
    """The verdict of the look back from the sightings' offsets to the pass side of the course
    line (mm, positive: on the side the mark should be): their median at least
    ``mark_radius_mm`` on the pass side is :data:`CONFIRMED`, on the other :data:`REFUTED`;
    nearer the line, ``None`` (undecided). Pure function."""
    if not offsets_mm:
        return None
    median = statistics.median(offsets_mm)
    if median >= mark_radius_mm:
        return CONFIRMED
    if median <= -mark_radius_mm:
        return REFUTED
    return None


class VerifyPass(DrivingBehaviour):
    """Check the waypoint's pass when the bypass doubted it (see the module docstring).

    Setup: ``robot``, ``clock``, ``mission`` (``navigation.verify_pass``, the search's turn
    rate, wheel base, mark radius).
    """

    READS: ClassVar[tuple[str, ...]] = (keys.TARGET, keys.PASSED, keys.PLANS, keys.MARKS,
                                        keys.FRAME)
    WRITES: ClassVar[tuple[str, ...]] = (keys.DRIVER, keys.PASSED)

    def __init__(self, name: str = "Verify") -> None:
        super().__init__(name)
        self.settings: dict[str, float] = {}
        self.look_back = True
        self.record: keys.PassedWaypoint | None = None
        self.offsets: list[float] = []
        self.verdict: str | None = None
        self.phase = "done"
        self._aims: list[float] = []
        self._course = 0.0
        self._origin: Pose | None = None
        self._search_radius = 0.0
        self._t0 = 0.0
        self._last_frame = -1

    def configure(self, **kwargs: Any) -> None:
        m = self.mission
        own = self._owner
        self.look_back = m.navigation.verify_pass.look_back if m is not None else True
        self.settings = {
            "timeout_s": pick(None, m.navigation.verify_pass.timeout_s if m else None,
                              owner=own, what="verify_pass.timeout_s"),
            "min_sightings": pick(None, m.navigation.verify_pass.min_sightings if m else None,
                                  owner=own, what="verify_pass.min_sightings"),
            "turn_speed_deg_s": pick(None, m.navigation.search.turn_speed_deg_s if m else None,
                                     owner=own, what="search turn speed"),
            "wheel_base_mm": pick(None, m.robot.wheel_base_mm if m else None, owner=own,
                                  what="robot.wheel_base_mm"),
            "mark_radius_mm": pick(None, m.marks.radius_mm if m else None, owner=own,
                                   what="marks.radius_mm"),
        }

    def _own_record(self) -> keys.PassedWaypoint | None:
        target = self.target()
        passed: tuple[keys.PassedWaypoint, ...] = self.read(keys.PASSED, ())
        if target is None:
            return None
        return next((p for p in passed if p.waypoint_id == target.waypoint_id), None)

    def initialise(self) -> None:
        if not self.settings:
            raise SetupError(f"{self._owner}: not set up (tree.setup(mission=...))")
        self.offsets = []
        self.verdict = None
        self._t0 = self.now()
        self._last_frame = -1
        self.record = self._own_record()
        record = self.record
        if record is None or record.doubt is None or record.check is not None:
            self.phase = "done"
            return
        if not self.look_back:
            self._write(UNVERIFIED)
            self.phase = "done"
            return
        pose = self.robot.pose()
        plans: tuple[keys.PlanRecord, ...] = self.read(keys.PLANS, ())
        own = [p for p in plans if p.waypoint == record.waypoint]
        self._course = own[-1].plan.course if own else pose.theta
        self._origin = pose
        mark = (record.mark_x, record.mark_y)
        offset = lateral_of(pose, mark, self._course)
        # the mirror image of the believed mark across the line driven
        n = (-math.sin(self._course), math.cos(self._course))
        mirror = (mark[0] - 2.0 * offset * n[0], mark[1] - 2.0 * offset * n[1])
        self._search_radius = 2.0 * abs(offset)
        self._aims = [self._bearing(pose, mark), self._bearing(pose, mirror), self._course]
        self.phase = "look"

    @staticmethod
    def _bearing(pose: Pose, point: tuple[float, float]) -> float:
        return math.atan2(point[1] - pose.y, point[0] - pose.x)

    def update(self) -> Status:
        record = self.record
        if self.phase == "done" or record is None:
            return self._finished(record)
        if self.verdict is None:
            self._gather(record)
            self.verdict = decide_side(self.offsets, self.settings["mark_radius_mm"]) \
                if len(self.offsets) >= self.settings["min_sightings"] else None
            if self.verdict is not None:
                self._write(self.verdict)
                if self.verdict == REFUTED:
                    return self.fail(self._refuted_message(record))
                self._aims = self._aims[-1:]  # decided: turn back to the course
        if self.now() - self._t0 > self.settings["timeout_s"]:
            return self._time_up()
        pose = self.robot.pose()
        while self._aims:
            error = wrap_angle(self._aims[0] - pose.theta)
            if abs(error) > math.radians(AIM_TOLERANCE_DEG):
                self._turn(LEFT if error > 0.0 else RIGHT)
                what = "looking back at" if self.verdict is None else "turning back from"
                self.feedback_message = (f"{what} {record.colour} #{record.waypoint + 1}: "
                                         f"{len(self.offsets)} sightings")
                return Status.RUNNING
            self._aims.pop(0)
            if len(self._aims) == 1 and self.verdict is None:
                self.verdict = UNVERIFIED  # swept both places the mark could be: no decision
                self._write(UNVERIFIED)
        self.phase = "done"
        return self._finished(self.record)

    def _turn(self, direction: int) -> None:
        omega = direction * math.radians(self.settings["turn_speed_deg_s"])
        half = 0.5 * self.settings["wheel_base_mm"]
        self.drive(left=-omega * half, right=omega * half)

    def _gather(self, record: keys.PassedWaypoint) -> None:
        """This frame's sighting of the mark, as its offset to the pass side of the course line
        through the look's first pose."""
        frame: keys.FrameInfo | None = self.read(keys.FRAME)
        if frame is None or frame.index == self._last_frame or frame.t < self._t0:
            return
        self._last_frame = frame.index
        assert self._origin is not None
        marks: tuple[keys.SeenMark, ...] = self.read(keys.MARKS, ())
        passed: tuple[keys.PassedWaypoint, ...] = self.read(keys.PASSED, ())
        others = [p for p in passed if p.waypoint_id != record.waypoint_id
                  and p.colour == record.colour]
        best: keys.SeenMark | None = None
        best_d = math.inf
        for m in marks:
            if m.colour != record.colour or keys.cut_by_image_side(m):
                continue
            gate = sighting_gate_mm(m)
            if any(math.hypot(m.world_x - p.mark_x, m.world_y - p.mark_y) <= gate
                   for p in others):
                continue
            d = math.hypot(m.world_x - record.mark_x, m.world_y - record.mark_y)
            if d <= self._search_radius + gate and d < best_d:
                best, best_d = m, d
        if best is not None:
            sigma = -1.0 if record.side == "left" else 1.0  # the mark's side, left positive
            self.offsets.append(sigma * lateral_of(self._origin, best.world, self._course))

    def _write(self, check: str) -> None:
        passed: tuple[keys.PassedWaypoint, ...] = self.read(keys.PASSED, ())
        assert self.record is not None
        wid = self.record.waypoint_id
        self.record = replace(self.record, check=check)
        self.write(keys.PASSED, tuple(self.record if p.waypoint_id == wid else p
                                      for p in passed))

    def _median(self) -> str:
        return f"{statistics.median(self.offsets):+.0f} mm" if self.offsets else "none"

    def _refuted_message(self, record: keys.PassedWaypoint) -> str:
        self.robot.stop()
        return (f"{record.colour} #{record.waypoint + 1} passed on its wrong side: looking back, "
                f"{len(self.offsets)} sightings put it {self._median()} to its {record.side} "
                f"side of the course (doubt was: {record.doubt})")

    def _time_up(self) -> Status:
        if self.verdict is None:
            self.verdict = UNVERIFIED
            self._write(UNVERIFIED)
        self.phase = "done"
        return self._finished(self.record)

    def _finished(self, record: keys.PassedWaypoint | None) -> Status:
        self.release_wheels()
        if record is None:
            return self.fail("no pass recorded for the target")
        label = f"{record.colour} #{record.waypoint + 1}"
        if record.check == REFUTED:
            return self.fail(f"{label} passed on its wrong side (found looking back)")
        if record.doubt is None:
            # nothing to check: no message, so the bypass's stands for the waypoint's result
            self.feedback_message = ""
        elif record.check == CONFIRMED:
            self.feedback_message = (f"{label}: pass confirmed looking back ({len(self.offsets)} "
                                     f"sightings, median {self._median()} on its side)")
        else:
            self.feedback_message = (f"{label}: unverified ({len(self.offsets)} sightings, "
                                     f"median {self._median()}); doubt: {record.doubt}")
        return Status.SUCCESS
