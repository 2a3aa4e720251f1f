"""Which mark is the target, and is it in view: target selection and association (paper §4.6).

The paper drives toward "the nearest mark". With a route of colours the target is the next
route colour's nearest visible mark, with two refinements:

- marks already passed (their world position within :func:`gate_mm` of a passed waypoint's mark
  of the same colour) are never selected again, so a route ``red, green, red`` does not turn back
  to the first red when it comes into view;
- once the bypass has started the target is *locked*: later sightings are associated by world
  position (nearest to the last estimate, within the gate), never swapped for another mark of the
  same colour that happens to be nearer;
- marks seen within :data:`MEMORY_RANGE_MM` are remembered (``/marknav/known``, :func:`remember`).
  When the nearest unpassed mark of the route colour is a remembered one out of view — a bypass
  turned the robot away from it — and it is clearly nearer than any in view, it is the target
  (*remembered*: followed by world position until seen again, so the search turns toward it),
  not a farther mark of that colour down the course.

The target's track is a small state machine (:mod:`marknav.behaviours.track`: UNSEEN,
FOLLOWING, REMEMBERED, LOCKED, its transitions, and the association gate derived from the range
estimate's errors). :func:`associate` is the pure rule, one function per state; Perception
applies it every frame to refresh ``/marknav/target``. The behaviours here: :class:`SelectTarget`
(sets the target of a waypoint),
:class:`TargetSeen` (``Seen?``: the target was seen within ``lost_after_s``),
:class:`TargetLocked` (``Bypassing?``: this waypoint's bypass already started) and
:class:`WaypointPassed` (``Passed?``: route progress, which survives a recovery interrupting the
route).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Any, ClassVar

from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.base import MarknavBehaviour, SetupError, check_positive, pick
from marknav.behaviours.track import DEFAULT_GATE, TrackState, state_of
from marknav.planning.kinematics import Pose

if TYPE_CHECKING:
    from marknav.missions.schema import Mission

__all__ = [
    "MEMORY_RANGE_MM",
    "SelectTarget",
    "TargetLocked",
    "TargetSeen",
    "WaypointPassed",
    "associate",
    "choose_target",
    "describe_target",
    "excluded_passes",
    "gate_mm",
    "is_passed_mark",
    "memory_gone",
    "nearest_of_colour",
    "remember",
    "remembered_target",
    "reselect",
    "sighting_gate_mm",
    "waypoint_id_for",
]

#: Marks seen this near are remembered (farther estimates are too coarse to steer by).
MEMORY_RANGE_MM = 4000.0
#: A remembered mark is preferred to one in view only when nearer by at least this (mm).
MEMORY_PREFERENCE_MM = 500.0
#: A remembered mark counts once seen in this many frames (one-frame false detections do not).
MEMORY_MIN_SEEN = 3
#: Forgotten after this many frames that should have seen it and did not — or as many as it was
#: seen in, if more: the evidence for a mark confirmed in many frames outweighs a few misses (a
#: mark turned toward edge-on as the robot closes in beside it falls under the detector's axis
#: ratio and goes unseen while still there), and a one-frame false detection is still dropped.
MEMORY_MAX_MISSES = 3
#: A remembered target is recognised within this many association gates of its position...
REMEMBERED_GATE_FACTOR = 2.5
#: ... once its remembered position is within this angle of the heading (degrees).
REMEMBERED_CENTRE_DEG = 8.0


def gate_mm(range_mm: float) -> float:
    """Association gate for an estimate ``range_mm`` away whose image radius is not known
    (a remembered mark): max(250 mm, 20 % of the range) (:class:`~.track.RangeGate`)."""
    return DEFAULT_GATE.gate_mm(range_mm)


def sighting_gate_mm(mark: keys.SeenMark) -> float:
    """Association gate for a sighting: the range law's error and its radius's
    (:class:`~.track.RangeGate`)."""
    return DEFAULT_GATE.gate_mm(mark.range_mm, mark.radius_px)


def waypoint_id_for(index: int, colour: str) -> str:
    """The identity of the route's waypoint ``index`` (0-based): ``"waypoint-1-red"``."""
    return f"waypoint-{index}-{colour}"


def is_passed_mark(mark: keys.SeenMark, passed: Iterable[keys.PassedWaypoint]) -> bool:
    """Whether ``mark`` is (within the gate) a mark of its colour that was already passed."""
    gate = sighting_gate_mm(mark)
    return any(
        p.colour == mark.colour
        and math.hypot(mark.world_x - p.mark_x, mark.world_y - p.mark_y) <= gate
        for p in passed
    )


def _near(a: tuple[float, float], b: tuple[float, float], gate: float) -> bool:
    return math.hypot(a[0] - b[0], a[1] - b[1]) <= gate


def _clearly_nearer(memory: keys.KnownMark, seen: keys.SeenMark, pose: Pose) -> bool:
    """Whether a remembered mark is nearer the robot than one in view by at least
    :data:`MEMORY_PREFERENCE_MM` (then the memory is preferred)."""
    return not math.hypot(memory.world_x - pose.x, memory.world_y - pose.y) \
        > seen.range_mm - MEMORY_PREFERENCE_MM


def _near_passed(colour: str, xy: tuple[float, float], range_mm: float,
                 passed: Iterable[keys.PassedWaypoint]) -> bool:
    gate = gate_mm(range_mm)
    return any(p.colour == colour and math.hypot(xy[0] - p.mark_x, xy[1] - p.mark_y) <= gate
               for p in passed)


def remember(known: Sequence[keys.KnownMark], marks: Sequence[keys.SeenMark], *,
             max_range_mm: float = MEMORY_RANGE_MM, pose: Pose | None = None,
             half_fov_rad: float | None = None) -> tuple[keys.KnownMark, ...]:
    """``known`` updated with one frame's ``marks``: a sighting within ``max_range_mm`` updates
    the remembered mark of its colour within the gate (latest position and time, one more
    ``seen``) or adds one. With ``pose`` and ``half_fov_rad``, a remembered mark well inside the
    view and near enough that this frame should have seen it, but did not, counts a ``missed``
    frame; after :data:`MEMORY_MAX_MISSES` such frames, or as many as it was seen in if more, it
    is forgotten (a false detection, or a mark that was moved)."""
    out = list(known)
    matched: set[int] = set()
    for m in marks:
        if m.range_mm > max_range_mm:
            continue
        gate = sighting_gate_mm(m)
        best, best_d = -1, math.inf
        for i, k in enumerate(out):
            if k.colour != m.colour:
                continue
            d = math.hypot(k.world_x - m.world_x, k.world_y - m.world_y)
            if d <= gate and d < best_d:
                best, best_d = i, d
        if best >= 0:
            out[best] = keys.KnownMark(m.colour, m.world_x, m.world_y, m.t, m.range_mm,
                                       seen=out[best].seen + 1, missed=0)
            matched.add(best)
        else:
            out.append(keys.KnownMark(m.colour, m.world_x, m.world_y, m.t, m.range_mm))
            matched.add(len(out) - 1)
    if pose is None or half_fov_rad is None:
        return tuple(out)
    kept = []
    near = 0.75 * max_range_mm
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    tan_half = math.tan(0.75 * half_fov_rad)
    for i, k in enumerate(out):
        if i not in matched:
            dx, dy = k.world_x - pose.x, k.world_y - pose.y
            forward = c * dx + s * dy
            if 300.0 < forward < near and abs(c * dy - s * dx) < forward * tan_half:
                k = replace(k, missed=k.missed + 1)
                if k.missed >= max(MEMORY_MAX_MISSES, k.seen):
                    continue
        kept.append(k)
    return tuple(kept)


def remembered_target(known: Sequence[keys.KnownMark], colour: str,
                      passed: Sequence[keys.PassedWaypoint], pose_xy: tuple[float, float],
                      marks: Sequence[keys.SeenMark]) -> keys.KnownMark | None:
    """The nearest remembered mark of ``colour`` that is neither passed nor in view now."""
    best: keys.KnownMark | None = None
    best_d = math.inf
    for k in known:
        if k.colour != colour or k.seen < MEMORY_MIN_SEEN or \
                _near_passed(colour, k.world, k.range_mm, passed):
            continue
        if any(m.colour == colour and math.hypot(m.world_x - k.world_x, m.world_y - k.world_y)
               <= sighting_gate_mm(m) for m in marks):
            continue  # in view: the sighting speaks for it
        d = math.hypot(k.world_x - pose_xy[0], k.world_y - pose_xy[1])
        if d < best_d:
            best, best_d = k, d
    return best


def excluded_passes(
    passed: Sequence[keys.PassedWaypoint], mission: Mission | None
) -> tuple[keys.PassedWaypoint, ...]:
    """The passed waypoints whose marks may not be targeted again: all of them, or with
    ``navigation.revisit_marks`` (a figure-eight) only the one passed last."""
    if mission is not None and mission.navigation.revisit_marks:
        return tuple(passed[-1:])
    return tuple(passed)


def nearest_of_colour(
    marks: Sequence[keys.SeenMark],
    colour: str,
    passed: Iterable[keys.PassedWaypoint] = (),
) -> keys.SeenMark | None:
    """The nearest mark of ``colour`` that is not an already passed one, or ``None``."""
    done = tuple(passed)
    candidates = [m for m in marks if m.colour == colour and not is_passed_mark(m, done)]
    return min(candidates, key=lambda m: m.range_mm, default=None)


def associate(
    marks: Sequence[keys.SeenMark],
    target: keys.Target,
    passed: Iterable[keys.PassedWaypoint] = (),
    pose: Pose | None = None,
    known: Sequence[keys.KnownMark] = (),
) -> keys.SeenMark | None:
    """The sighting of ``target`` among ``marks`` (one frame), or ``None`` if it is not there:
    the rule of the target's track state (:func:`~.track.state_of`)."""
    state = state_of(target)
    done = tuple(passed)
    if state is TrackState.LOCKED:
        return associate_locked(marks, target)
    if state is TrackState.REMEMBERED:
        return associate_remembered(marks, target, done, pose)
    return associate_following(marks, target, done, pose, known)


def associate_following(
    marks: Sequence[keys.SeenMark],
    target: keys.Target,
    passed: tuple[keys.PassedWaypoint, ...],
    pose: Pose | None,
    known: Sequence[keys.KnownMark],
) -> keys.SeenMark | None:
    """UNSEEN and FOLLOWING: the nearest not-yet-passed mark of the target's colour — unless,
    with the robot's ``pose`` and the memory (``known``), the target's own mark is remembered
    out of view and clearly nearer (by :data:`MEMORY_PREFERENCE_MM`) than that one: the target
    left the view (an approach from far off its axis, a turn) and a mark of its colour farther
    down the course is no sighting of it."""
    seen = nearest_of_colour(marks, target.colour, passed)
    if seen is None or pose is None or not known or target.world is None or \
            _near(target.world, (seen.world_x, seen.world_y), sighting_gate_mm(seen)):
        return seen
    own = remembered_target(known, target.colour, passed, (pose.x, pose.y), marks)
    if own is not None and _near(own.world, target.world, gate_mm(own.range_mm)) and \
            _clearly_nearer(own, seen, pose):
        return None  # the target's mark is out of view, not the farther one in view
    return seen


def associate_remembered(
    marks: Sequence[keys.SeenMark],
    target: keys.Target,
    passed: tuple[keys.PassedWaypoint, ...],
    pose: Pose | None,
) -> keys.SeenMark | None:
    """REMEMBERED (chosen from the memory, out of view): the mark of its colour nearest the
    remembered position, within :data:`REMEMBERED_GATE_FACTOR` gates (the position was
    estimated from farther away and odometry has drifted since), passed marks excluded; with
    the robot's ``pose``, only once that position is within :data:`REMEMBERED_CENTRE_DEG` of
    the heading: a search turning toward it sees every mark near it before choosing the
    nearest to it, not the first of its colour to enter the view."""
    assert target.world is not None
    tx, ty = target.world
    if pose is not None:
        off = math.remainder(math.atan2(ty - pose.y, tx - pose.x) - pose.theta, math.tau)
        if abs(off) > math.radians(REMEMBERED_CENTRE_DEG):
            return None
    candidates = [m for m in marks if m.colour == target.colour and not is_passed_mark(m, passed)]
    return _nearest_within(candidates, (tx, ty), REMEMBERED_GATE_FACTOR)


def associate_locked(marks: Sequence[keys.SeenMark],
                     target: keys.Target) -> keys.SeenMark | None:
    """LOCKED (bypass under way): the mark of the target's colour nearest its world estimate,
    within the gate; never another mark of the colour that happens to be nearer the robot."""
    assert target.world is not None
    return _nearest_within([m for m in marks if m.colour == target.colour], target.world, 1.0)


def _nearest_within(marks: Sequence[keys.SeenMark], xy: tuple[float, float],
                    widen: float) -> keys.SeenMark | None:
    best: keys.SeenMark | None = None
    best_d = math.inf
    for m in marks:
        d = math.hypot(m.world_x - xy[0], m.world_y - xy[1])
        if d <= widen * sighting_gate_mm(m) and d < best_d:
            best, best_d = m, d
    return best


def choose_target(
    base: keys.Target,
    marks: Sequence[keys.SeenMark],
    known: Sequence[keys.KnownMark],
    passed: Sequence[keys.PassedWaypoint],
    pose: Pose | None,
) -> tuple[keys.Target, keys.KnownMark | None]:
    """The waypoint's mark for ``base`` (its waypoint, colour and side): a remembered mark out of
    view when it is clearly nearer (by :data:`MEMORY_PREFERENCE_MM`) than the nearest unpassed
    one of its colour in view, else that one; with neither, ``base`` unseen. Also returns the
    memory it was taken from. ``pose`` ``None``: the memory is not consulted."""
    seen = nearest_of_colour(marks, base.colour, passed)
    memory = None
    if known and pose is not None:
        memory = remembered_target(known, base.colour, passed, (pose.x, pose.y), marks)
        if memory is not None and seen is not None and not _clearly_nearer(memory, seen, pose):
            memory = None  # the one in view is as near: take it
    if memory is not None:
        return replace(base, world_x=memory.world_x, world_y=memory.world_y,
                       remembered=True), memory
    if seen is not None:
        return with_sighting(base, seen), None
    return base, None


def memory_gone(target: keys.Target, known: Sequence[keys.KnownMark]) -> bool:
    """Whether ``target`` was taken from the memory (remembered, not locked) and the memory no
    longer holds a mark of its colour there: it was looked at where it should be and not seen
    (:func:`remember` forgot it), so it was a false or misplaced sighting and the target must be
    chosen again."""
    if not target.remembered or target.locked or target.world is None:
        return False
    tx, ty = target.world
    return not any(k.colour == target.colour
                   and math.hypot(k.world_x - tx, k.world_y - ty) <= gate_mm(k.range_mm)
                   for k in known)


def reselect(target: keys.Target, marks: Sequence[keys.SeenMark],
             known: Sequence[keys.KnownMark], passed: Sequence[keys.PassedWaypoint],
             pose: Pose) -> keys.Target:
    """``target`` chosen again (:func:`choose_target`) for its waypoint, colour and side."""
    base = keys.Target(waypoint=target.waypoint, waypoint_id=target.waypoint_id,
                       colour=target.colour, side=target.side)
    return choose_target(base, marks, known, passed, pose)[0]


def with_sighting(target: keys.Target, sighting: keys.SeenMark) -> keys.Target:
    """``target`` updated with a new sighting of its mark (and its world position)."""
    # dataclasses.replace, spelt out: this runs every frame the target is seen
    return keys.Target(target.waypoint, target.waypoint_id, target.colour, target.side,
                       sighting, sighting.world_x, sighting.world_y, target.locked, False)


def describe(mark: keys.SeenMark | None) -> str:
    """``1.52 m, 4° right`` for feedback messages."""
    if mark is None:
        return "not in view"
    deg = math.degrees(mark.bearing_rad)
    side = "left" if deg > 0 else "right"
    return f"{mark.range_mm / 1000.0:.2f} m, {abs(deg):.0f}° {side}"


def describe_target(target: keys.Target, sighting: keys.SeenMark | None,
                    marks: Sequence[keys.SeenMark]) -> str:
    """What a frame showed of ``target`` (:func:`describe` of its ``sighting``), and when it
    has none while a mark of its colour is in view, why that mark is not taken: a remembered
    target is recognised only once the turn brings its remembered place near the heading
    (:func:`associate_remembered`); a locked one only within the gate of its estimate."""
    if sighting is not None or not any(m.colour == target.colour for m in marks):
        return describe(sighting)
    state = state_of(target)
    if state is TrackState.REMEMBERED:
        return (f"not taken yet: the {target.colour} in view is checked once the turn brings "
                f"the remembered place within {REMEMBERED_CENTRE_DEG:g}° of the heading")
    if state is TrackState.LOCKED:
        return f"not in view (the {target.colour} in view is too far from its estimate)"
    return f"not in view (the {target.colour} in view is another mark)"


class SelectTarget(MarknavBehaviour):
    """Make the waypoint's mark the target: its colour, pass side and nearest visible mark.

    Always SUCCESS (the mark may be out of view: then ``Seen?`` fails and the robot searches).
    If this waypoint's bypass already started (target locked), the locked target is kept, so a
    waypoint interrupted by a bump recovery resumes with the same physical mark.

    Args:
        colour: the route colour.
        side: ``left``/``right``; default: the mission's side for the colour.
        waypoint: index of the waypoint in the route (0-based), for messages and the report.
        waypoint_id: identity shared with the waypoint's ``Passed?``; default from
            ``waypoint`` and ``colour``.
    """

    READS: ClassVar[tuple[str, ...]] = (keys.MARKS, keys.PASSED, keys.KNOWN)
    WRITES: ClassVar[tuple[str, ...]] = (keys.TARGET,)

    def __init__(
        self,
        name: str = "SelectTarget",
        *,
        colour: str,
        side: keys.Side | None = None,
        waypoint: int = -1,
        waypoint_id: str | None = None,
    ) -> None:
        super().__init__(name)
        if side not in (None, "left", "right"):
            raise ValueError(f"side must be 'left' or 'right', got {side!r}")
        self.colour = colour
        self.waypoint = waypoint
        self.waypoint_id = waypoint_id or waypoint_id_for(waypoint, colour)
        self._side_override = side
        self.side: keys.Side | None = side

    def configure(self, **kwargs: Any) -> None:
        from_mission: keys.Side | None = None
        if self.mission is not None and self._side_override is None:
            try:
                from_mission = self.mission.side_of(self.colour)
            except KeyError as exc:
                raise SetupError(f"{self._owner}: {exc.args[0]}") from None
        self.side = pick(self._side_override, from_mission, owner=self._owner,
                         what=f"pass side for {self.colour!r}")

    def update(self) -> Status:
        if self.side is None:
            raise SetupError(f"{self._owner}: not set up (no pass side)")
        current = self.target()
        if current is not None and current.waypoint_id == self.waypoint_id and current.locked:
            self.feedback_message = f"{current.label} (locked, bypass under way)"
            return Status.SUCCESS
        marks: tuple[keys.SeenMark, ...] = self.read(keys.MARKS, ())
        passed = excluded_passes(self.read(keys.PASSED, ()), self.mission)
        base = keys.Target(waypoint=self.waypoint, waypoint_id=self.waypoint_id,
                           colour=self.colour, side=self.side)
        known: tuple[keys.KnownMark, ...] = self.read(keys.KNOWN, ())
        mine = current is not None and current.waypoint_id == self.waypoint_id
        seen = nearest_of_colour(marks, self.colour, passed)
        pose = self.robot.pose() if known and not (seen is None and mine) else None
        target, memory = choose_target(base, marks, known if pose is not None else (), passed,
                                       pose)
        if memory is None and seen is None and mine:
            assert current is not None
            target = current  # out of view now: keep what was seen of it so far
        self.write(keys.TARGET, target)
        if memory is not None:
            self.feedback_message = (f"{target.label}, pass on its {self.side}: out of view, "
                                     f"remembered from t={memory.t:.1f} s")
        else:
            self.feedback_message = f"{target.label}, pass on its {self.side}: {describe(seen)}"
        return Status.SUCCESS


class TargetSeen(MarknavBehaviour):
    """``Seen?``: SUCCESS while the target was seen within ``lost_after_s``, else FAILURE.

    Args:
        lost_after_s: default: the mission's ``navigation.lost_after_s``.
    """

    READS: ClassVar[tuple[str, ...]] = (keys.TARGET, keys.FRAME)

    def __init__(self, name: str = "Seen?", *, lost_after_s: float | None = None) -> None:
        super().__init__(name)
        self._lost_override = check_positive(lost_after_s, "lost_after_s")
        self.lost_after_s: float | None = lost_after_s

    def configure(self, **kwargs: Any) -> None:
        nav = self.mission.navigation.lost_after_s if self.mission is not None else None
        self.lost_after_s = pick(self._lost_override, nav, owner=self._owner, what="lost_after_s")

    def update(self) -> Status:
        if self.lost_after_s is None:
            raise SetupError(f"{self._owner}: not set up (no lost_after_s)")
        target = self.target()
        if target is None:
            self.feedback_message = "no target selected"
            return Status.FAILURE
        if target.sighting is None:
            self.feedback_message = (f"{target.label} remembered, not seen again yet"
                                     if target.remembered else f"{target.label} not seen yet")
            return Status.FAILURE
        age = keys.unseen_s(target.sighting, self.read(keys.FRAME), self.now())
        if age > self.lost_after_s:
            self.feedback_message = f"{target.label} unseen for {age:.2f} s"
            return Status.FAILURE
        self.feedback_message = f"{target.label} seen {age:.2f} s ago"
        return Status.SUCCESS


class WaypointPassed(MarknavBehaviour):
    """``Passed?``: SUCCESS once ``/marknav/passed`` records this waypoint, else FAILURE."""

    READS: ClassVar[tuple[str, ...]] = (keys.PASSED,)

    def __init__(self, name: str = "Passed?", *, waypoint_id: str) -> None:
        super().__init__(name)
        self.waypoint_id = waypoint_id

    def update(self) -> Status:
        passed: tuple[keys.PassedWaypoint, ...] = self.read(keys.PASSED, ())
        for record in passed:
            if record.waypoint_id == self.waypoint_id:
                self.feedback_message = f"passed on its {record.side} at t={record.t:.1f} s"
                return Status.SUCCESS
        self.feedback_message = "not yet"
        return Status.FAILURE


class TargetLocked(MarknavBehaviour):
    """``Bypassing?``: SUCCESS when this waypoint's bypass has already started (target locked).

    Lets a waypoint interrupted mid-bypass (a bump recovery) resume the bypass of the same mark
    instead of approaching and searching for it again.
    """

    READS: ClassVar[tuple[str, ...]] = (keys.TARGET,)

    def __init__(self, name: str = "Bypassing?", *, waypoint_id: str | None = None) -> None:
        super().__init__(name)
        self.waypoint_id = waypoint_id

    def update(self) -> Status:
        target = self.target()
        mine = target is not None and (self.waypoint_id is None
                                       or target.waypoint_id == self.waypoint_id)
        if target is not None and mine and target.locked:
            self.feedback_message = f"{target.label}: bypass under way"
            return Status.SUCCESS
        self.feedback_message = "no bypass under way"
        return Status.FAILURE
