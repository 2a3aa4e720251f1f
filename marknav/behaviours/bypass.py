"""Pass the target on its side along a planned Bézier bypass (paper §4.6, eqs. 22–23).

On ``initialise`` the bypass is planned from the robot's odometry pose to beside the mark's world
estimate (its latest sighting placed with odometry), on the colour's side, at ``clearance_mm``
(:func:`marknav.planning.bezier.plan_bypass`: two tangent-joined quadratics that keep the clearance
exactly). The target is then *locked*: later sightings are associated by world position. The plan
is tracked closed-loop from odometry with pure pursuit (:class:`marknav.planning.tracking.
PurePursuit`, at a constant speed: the next waypoint takes over at the end) instead of the
paper's open-loop stepping (eqs. 24, 35–39), which drifts.

Re-planning: when the camera re-sees the mark with a closer estimate (range at most
``replan_ratio`` times the range the current plan was made from) that moves the mark by more than
``replan_min_shift_mm``, the bypass is planned again from the current pose, keeping the original
course. A sighting whose disc reaches the image's side edge is not used
(:func:`~marknav.behaviours.keys.cut_by_image_side`): its radius is the fit of a part. A
re-plan that is not feasible (:class:`~marknav.planning.bezier.PlanningError`) is skipped and
the current plan kept.

SUCCESS when the mark is beside or behind the robot along the plan's course (or the tracker reached
the end of the plan) on the required side: the waypoint is then recorded in ``/marknav/passed``,
with the robot's own verdict on it (:func:`verify_pass`): the pass is *doubtful* — recorded with the
reason, reported as ``doubtful``, never silently as passed — when what the robot saw disagrees with
what it drove: a sighting of the mark (each placed with the odometry pose at its capture time) lies
on the wrong side of the driven path or on it, the mark left the view across the wrong side of the
image, or the mark was not seen at all since the bypass began (the pass then rests on an estimate
older than the bypass). FAILURE when the bypass cannot be planned, when the mark ends up on the
wrong side, or when the bypass takes more than ``3 × length / speed + 5 s`` (stuck). Every plan is
appended to ``/marknav/plans`` for the run plot. The wheels are stopped when the bypass ends.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np
from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.approach import THRESHOLD_SPEED_FRACTION
from marknav.behaviours.base import DrivingBehaviour, SetupError, check_positive, pick
from marknav.behaviours.keys import cut_by_image_side
from marknav.behaviours.track import lock
from marknav.planning.bezier import BypassPlan, PlanningError, plan_bypass
from marknav.planning.kinematics import Pose
from marknav.planning.tracking import PurePursuit

__all__ = ["EXIT_MARGIN_MM", "RECOVERY_WIDENING_MM", "BezierBypass", "behind_of",
           "cut_by_image_side", "lateral_of", "verify_pass"]

log = logging.getLogger(__name__)

#: Extra run-out beyond robot radius + mark radius before a bypass counts as done (mm).
EXIT_MARGIN_MM = 60.0
#: How much wider each bump recovery makes later bypasses (mm).
RECOVERY_WIDENING_MM = 60.0


def lateral_of(pose: Pose, mark_xy: tuple[float, float], course: float) -> float:
    """The mark's offset to the left of the robot across ``course`` (mm): (M − P)·n."""
    return (-(mark_xy[0] - pose.x) * math.sin(course)
            + (mark_xy[1] - pose.y) * math.cos(course))


def behind_of(pose: Pose, mark_xy: tuple[float, float], course: float) -> float:
    """How far the mark is behind the robot along ``course`` (mm): (P − M)·h."""
    return ((pose.x - mark_xy[0]) * math.cos(course)
            + (pose.y - mark_xy[1]) * math.sin(course))


def _abeam(path: Sequence[Pose], mark_xy: tuple[float, float], course: float) -> Pose:
    """The pose of ``path`` where the mark was most nearly abeam (along ``course``)."""
    return min(path, key=lambda p: abs(behind_of(p, mark_xy, course)))


def verify_pass(path: Sequence[Pose], sightings: Sequence[keys.SeenMark], *, course: float,
                side: keys.Side, mark_radius_mm: float, since_t: float) -> str | None:
    """Whether the robot's own evidence confirms a pass: ``None`` if it does, else why not.

    ``path``: the odometry poses the bypass drove (in order); ``sightings``: the target's
    sightings from the bypass's start on (each placed with the odometry pose at its capture
    time); ``since_t``: the capture time of the frame the bypass was planned from; sightings
    captured after it are the bypass's own. Doubts, in order:

    - no sighting captured after ``since_t``: the pass rests on the estimate it was planned
      from alone;
    - a sighting (whole in the image: a cut disc's range is of a part) that places the mark's
      centre less than ``mark_radius_mm`` from the driven path on the required side, or beyond
      it on the other: by that sighting the robot passed on the wrong side or over the mark;
    - the last sighting is a disc cut by the image's side edge on the wrong side: a mark
      passed on its left leaves the view across the image's right edge, and vice versa.

    Pure function."""
    if not path:
        return "no path driven"
    recent = [s for s in sightings if s.t > since_t]
    if not recent:
        return "not seen since the bypass began"
    sigma = -1.0 if side == "left" else 1.0  # the mark's side of the robot (left positive)
    for s in recent:
        if keys.cut_by_image_side(s):
            continue
        at = _abeam(path, s.world, course)
        lateral = sigma * lateral_of(at, s.world, course)
        if lateral < mark_radius_mm:
            where = "on the wrong side of" if lateral < 0.0 else "on"
            return (f"a sighting at t={s.t:.2f} s ({s.range_mm:.0f} mm away) puts the mark "
                    f"{where} the driven path ({lateral:+.0f} mm on its pass side)")
    last = recent[-1]
    if keys.cut_by_image_side(last):
        right_half = last.pixel_error > 0.0
        if right_half != (side == "left"):
            return (f"it left the view across the image's {'right' if right_half else 'left'} "
                    f"edge (a pass on its {side} takes it out on the "
                    f"{'right' if side == 'left' else 'left'})")
    return None


class BezierBypass(DrivingBehaviour):
    """Plan and track the bypass of the current target; record the waypoint as passed.

    Args (``None`` takes the mission's value):
        clearance_mm: robot centre to mark centre while passing (``navigation.clearance_mm``).
        speed_mm_s: cruising speed along the curve (default: 0.8 × the approach speed, the speed
            the approach slows to at the threshold).
        lookahead_mm: pure-pursuit look-ahead (``navigation.lookahead_mm``).
        replan_ratio: re-plan on a sighting at most this fraction of the planning range.
        replan_min_shift_mm: ... that moves the mark estimate by more than this.

    Setup: ``robot``, ``clock``, ``mission`` (also wheel base, speed limit, mark radius).
    """

    READS: ClassVar[tuple[str, ...]] = (keys.TARGET, keys.PASSED, keys.PLANS, keys.RECOVERY,
                                        keys.FRAME)
    WRITES: ClassVar[tuple[str, ...]] = (keys.DRIVER, keys.TARGET, keys.PASSED, keys.PLANS)

    def __init__(
        self,
        name: str = "Bypass",
        *,
        clearance_mm: float | None = None,
        speed_mm_s: float | None = None,
        lookahead_mm: float | None = None,
        replan_ratio: float = 0.9,
        replan_min_shift_mm: float = 10.0,
        exit_mm: float | None = None,
        margin_mm: float | None = None,
    ) -> None:
        super().__init__(name)
        self._margin = None if margin_mm is None else float(margin_mm)
        self._exit = None if exit_mm is None else float(exit_mm)
        if self._exit is not None and not (math.isfinite(self._exit) and self._exit >= 0):
            raise ValueError(f"exit_mm must be >= 0, got {exit_mm!r}")
        self._clearance = check_positive(clearance_mm, "clearance_mm")
        self._speed = check_positive(speed_mm_s, "speed_mm_s")
        self._lookahead = check_positive(lookahead_mm, "lookahead_mm")
        if not 0.0 < replan_ratio <= 1.0:
            raise ValueError(f"replan_ratio must be in (0, 1], got {replan_ratio!r}")
        if not (math.isfinite(replan_min_shift_mm) and replan_min_shift_mm >= 0):
            raise ValueError(f"replan_min_shift_mm must be >= 0, got {replan_min_shift_mm!r}")
        self.replan_ratio = float(replan_ratio)
        self.replan_min_shift_mm = float(replan_min_shift_mm)
        self.settings: dict[str, float] = {}
        self.plan: BypassPlan | None = None
        self.replans = 0
        self._tracker: PurePursuit | None = None
        self._target: keys.Target | None = None
        self._error: str | None = None
        self._already_passed = False
        self._plan_range = math.inf
        self._last_sighting_t = -math.inf
        self._t0 = 0.0
        self._deadline = math.inf
        #: The evidence of this bypass: the odometry poses driven and the target's sightings.
        self.path: list[Pose] = []
        self.sightings: list[keys.SeenMark] = []
        self._evidence_t = -math.inf
        self._since_t = 0.0

    def configure(self, **kwargs: Any) -> None:
        m = self.mission
        owner = self._owner
        self.settings = {
            "clearance_mm": pick(self._clearance, m.navigation.clearance_mm if m else None,
                                 owner=owner, what="clearance_mm"),
            "margin_mm": (self._margin if self._margin is not None
                          else m.navigation.bypass_margin_mm if m is not None else 0.0),
            "speed_mm_s": pick(self._speed,
                               THRESHOLD_SPEED_FRACTION * m.navigation.approach_speed_mm_s
                               if m else None, owner=owner, what="bypass speed"),
            "lookahead_mm": pick(self._lookahead, m.navigation.lookahead_mm if m else None,
                                 owner=owner, what="lookahead_mm"),
            "mark_radius_mm": pick(None, m.marks.radius_mm if m else None, owner=owner,
                                   what="marks.radius_mm"),
            # After the curve, run on straight until the mark is this far behind the robot's
            # centre: then no turn toward the next mark can sweep the robot's disc into it.
            "exit_mm": pick(self._exit, m.robot.radius_mm + m.marks.radius_mm + EXIT_MARGIN_MM
                            if m else None, owner=owner, what="exit run-out"),
            "wheel_base_mm": pick(None, m.robot.wheel_base_mm if m else None, owner=owner,
                                  what="robot.wheel_base_mm"),
            "max_wheel_mm_s": pick(None, m.robot.max_speed_mm_s if m else None, owner=owner,
                                   what="robot.max_speed_mm_s"),
        }

    # -- lifecycle -----------------------------------------------------------------------------

    def initialise(self) -> None:
        if not self.settings:
            raise SetupError(f"{self._owner}: not set up (tree.setup(mission=...))")
        self.plan = None
        self._tracker = None
        self._error = None
        self._already_passed = False
        self.replans = 0
        self._t0 = self.now()
        self._deadline = math.inf
        self.path = []
        self.sightings = []
        self._evidence_t = -math.inf
        target = self.target()
        frame: keys.FrameInfo | None = self.read(keys.FRAME)
        # A sighting counts as made during the bypass from the newest frame's capture on.
        self._since_t = frame.t if frame is not None else self._t0
        self._target = target
        if target is None:
            self._error = "no target selected"
            return
        if target.world is None:
            self._error = f"no position estimate of {target.label}"
            return
        pose = self.robot.pose()
        self._last_sighting_t = target.sighting.t if target.sighting is not None else -math.inf
        self._plan_range = math.hypot(target.world[0] - pose.x, target.world[1] - pose.y)
        try:
            plan = self._plan(pose, target.world, course=None)
        except PlanningError as exc:
            if self._is_passed(pose, target.world, pose.theta, target.side):
                self._already_passed = True  # e.g. resumed after a recovery beside the mark
            else:
                self._error = f"cannot bypass {target.label}: {exc}"
            return
        self.write(keys.TARGET, lock(target))  # the track: FOLLOWING/REMEMBERED -> LOCKED
        self._adopt(plan, "resumed" if target.locked else "initial")

    def update(self) -> Status:
        target = self._target
        if self._error is not None or target is None:
            return self.fail(self._error or "no target selected")
        pose = self.robot.pose()
        if self._already_passed:
            return self._succeed(target, target.world or (math.nan, math.nan), pose)
        self._gather(pose)
        assert self.plan is not None and self._tracker is not None
        self._maybe_replan(pose)
        plan = self.plan
        clear = behind_of(pose, plan.mark_xy, plan.course) >= self.settings["exit_mm"] - 10.0
        if clear or self._tracker.finished(pose):
            if not self._is_passed(pose, plan.mark_xy, plan.course, target.side, strict=False):
                lateral = lateral_of(pose, plan.mark_xy, plan.course)
                return self.fail(f"{target.label} ended up on the wrong side "
                                 f"({lateral:+.0f} mm to the left)")
            return self._succeed(target, plan.mark_xy, pose)
        if self.now() > self._deadline:
            return self.fail(f"bypass of {target.label} did not finish in "
                             f"{self.now() - self._t0:.1f} s")
        cmd = self._tracker.command(pose)
        self.drive(left=cmd.left, right=cmd.right)
        to_go = max(self._tracker.length_mm - self._tracker.progress_mm, 0.0)
        again = f", re-planned {self.replans}×" if self.replans else ""
        self.feedback_message = (f"passing {target.label} on its {target.side}: "
                                 f"{to_go / 1000.0:.2f} m to go{again}")
        return Status.RUNNING

    # -- helpers -------------------------------------------------------------------------------

    def planned_clearance_mm(self) -> float:
        """The clearance planned: ``clearance_mm`` + ``bypass_margin_mm``, widened by
        :data:`RECOVERY_WIDENING_MM` for each bump recovery so far (a bump says the mark is
        nearer than odometry believes)."""
        recovery: keys.Recovery = self.read(keys.RECOVERY, keys.Recovery())
        s = self.settings
        return s["clearance_mm"] + s["margin_mm"] + RECOVERY_WIDENING_MM * recovery.count

    def _plan(self, pose: Pose, mark: tuple[float, float], *, course: float | None) -> BypassPlan:
        """Plan at :meth:`planned_clearance_mm`; when that is not feasible from here (e.g. the
        robot backed off from a bump to inside the widened clearance), fall back to the
        clearance plus margin, then to the bare clearance."""
        assert self._target is not None
        s = self.settings
        wanted = self.planned_clearance_mm()
        tries = sorted({wanted, s["clearance_mm"] + s["margin_mm"], s["clearance_mm"]},
                       reverse=True)
        error: PlanningError | None = None
        for clearance in tries:
            try:
                return plan_bypass(pose, mark, mark_radius_mm=s["mark_radius_mm"],
                                   clearance_mm=clearance, side=self._target.side,
                                   course=course)
            except PlanningError as exc:
                error = exc
        assert error is not None
        raise error

    def _adopt(self, plan: BypassPlan, reason: str) -> None:
        assert self._target is not None
        s = self.settings
        self.plan = plan
        # The curves, then a straight run-out along the course until the mark is exit_mm
        # behind: turning toward the next mark from beside this one would clip it.
        end = plan.end_pose
        run_out = np.array([[end.x + k * math.cos(plan.course), end.y + k * math.sin(plan.course)]
                            for k in np.linspace(10.0, s["exit_mm"], 8)])
        path = np.vstack([plan.sample(5.0), run_out])
        self._tracker = PurePursuit(path, lookahead_mm=s["lookahead_mm"],
                                    speed_mm_s=s["speed_mm_s"], wheel_base_mm=s["wheel_base_mm"],
                                    max_wheel_mm_s=s["max_wheel_mm_s"], slowdown_mm=0.0)
        self._deadline = self.now() + 3.0 * plan.length_mm / s["speed_mm_s"] + 5.0
        plans: tuple[keys.PlanRecord, ...] = self.read(keys.PLANS, ())
        record = keys.PlanRecord(waypoint=self._target.waypoint, colour=self._target.colour,
                                 side=self._target.side, t=self.now(), reason=reason, plan=plan)
        self.write(keys.PLANS, (*plans, record))

    def _gather(self, pose: Pose) -> None:
        """Keep this tick's evidence: the pose driven, a new sighting of the target."""
        self.path.append(pose)
        target = self.target()
        if (target is None or self._target is None
                or target.waypoint_id != self._target.waypoint_id):
            return
        seen = target.sighting
        if seen is not None and seen.t > self._evidence_t:
            self._evidence_t = seen.t
            self.sightings.append(seen)

    def _maybe_replan(self, pose: Pose) -> None:
        assert self.plan is not None and self._target is not None
        target = self.target()
        if target is None or target.waypoint_id != self._target.waypoint_id:
            return
        seen = target.sighting
        if seen is None or seen.t <= self._last_sighting_t:
            return
        self._last_sighting_t = seen.t
        if cut_by_image_side(seen):
            return  # its radius, hence its range, is not the mark's: keep the whole mark's
        if seen.range_mm > self.replan_ratio * self._plan_range:
            return
        shift = math.hypot(seen.world_x - self.plan.mark_xy[0],
                           seen.world_y - self.plan.mark_xy[1])
        if shift <= self.replan_min_shift_mm:
            self._plan_range = seen.range_mm  # confirmed: no need to re-plan
            return
        try:
            plan = self._plan(pose, seen.world, course=self.plan.course)
        except PlanningError:
            return  # keep the current plan
        self._plan_range = seen.range_mm
        self.replans += 1
        self._adopt(plan, "re-plan")

    @staticmethod
    def _is_passed(pose: Pose, mark: tuple[float, float], course: float, side: keys.Side,
                   *, strict: bool = True) -> bool:
        """The mark is beside/behind along ``course`` (if ``strict``) on the side required."""
        along = (mark[0] - pose.x) * math.cos(course) + (mark[1] - pose.y) * math.sin(course)
        if strict and along > 0.0:
            return False
        lateral = lateral_of(pose, mark, course)
        # Passing on the mark's left leaves the mark on the robot's right (lateral < 0).
        return lateral < 0.0 if side == "left" else lateral > 0.0

    def _succeed(self, target: keys.Target, mark: tuple[float, float], pose: Pose) -> Status:
        passed: tuple[keys.PassedWaypoint, ...] = self.read(keys.PASSED, ())
        course = self.plan.course if self.plan is not None else pose.theta
        doubt = None
        if not self._already_passed:  # resumed beside the mark: nothing seen or driven here
            doubt = verify_pass(self.path, self.sightings, course=course, side=target.side,
                                mark_radius_mm=self.settings["mark_radius_mm"],
                                since_t=self._since_t)
        if not any(p.waypoint_id == target.waypoint_id for p in passed):
            record = keys.PassedWaypoint(waypoint=target.waypoint,
                                         waypoint_id=target.waypoint_id, colour=target.colour,
                                         side=target.side, t=self.now(), mark_x=mark[0],
                                         mark_y=mark[1], doubt=doubt)
            self.write(keys.PASSED, (*passed, record))
            if doubt is not None:
                log.warning("%s: passed on its %s by odometry, but doubtful: %s",
                            target.label, target.side, doubt)
        gap = abs(lateral_of(pose, mark, course))
        self.feedback_message = (f"passed {target.label} on its {target.side} "
                                 f"({gap:.0f} mm beside it)"
                                 + (f"; doubtful: {doubt}" if doubt is not None else ""))
        return Status.SUCCESS
