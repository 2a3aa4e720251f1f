"""The blackboard contract: every key marknav's behaviours share, and the values stored there.

All keys live under ``/marknav/`` on py_trees' process-global blackboard. Values are frozen
dataclasses or tuples of them; a writer replaces a value, it never mutates one, so a reader may
keep what it read.

======================  ============================  ========================================
key                     value                         written by
======================  ============================  ========================================
``/marknav/frame``      :class:`FrameInfo`            Perception, each processed frame
``/marknav/marks``      ``tuple[SeenMark, ...]``      Perception: the marks of the latest frame
``/marknav/last_seen``  ``dict[str, SeenMark]``       Perception: latest sighting per colour
``/marknav/target``     :class:`Target` or ``None``   SelectTarget; Perception refreshes its
                                                      sighting; BezierBypass locks it
``/marknav/passed``     ``tuple[PassedWaypoint, …]``  BezierBypass, in the order passed
``/marknav/plans``      ``tuple[PlanRecord, ...]``    BezierBypass: every plan and re-plan
``/marknav/driver``     :class:`Driver` or ``None``   the behaviour driving the wheels
``/marknav/recovery``   :class:`Recovery`             BackOff (bump recoveries)
======================  ============================  ========================================

Frames and units follow ``docs/architecture.md``: robot frame x forward / y left, world frame
x east / y north, millimetres, radians, seconds of the mission clock.

Because the blackboard outlives a tree, a program that runs several missions in one process must
call :func:`reset` before each run (the ``blackboard`` pytest fixture clears it for tests).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import py_trees

from marknav.planning.bezier import BypassPlan

__all__ = [
    "ALL_KEYS",
    "DRIVER",
    "FRAME",
    "KNOWN",
    "LAST_SEEN",
    "MARKS",
    "NAMESPACE",
    "PASSED",
    "PLANS",
    "RECOVERY",
    "TARGET",
    "Driver",
    "FrameInfo",
    "KnownMark",
    "PassedWaypoint",
    "PlanRecord",
    "Recovery",
    "SeenMark",
    "Side",
    "Target",
    "centre_outside_image",
    "cut_by_image_side",
    "image_centre",
    "read",
    "reset",
    "snapshot",
    "unseen_s",
]

Side = Literal["left", "right"]

NAMESPACE = "/marknav"
FRAME = f"{NAMESPACE}/frame"
MARKS = f"{NAMESPACE}/marks"
LAST_SEEN = f"{NAMESPACE}/last_seen"
TARGET = f"{NAMESPACE}/target"
PASSED = f"{NAMESPACE}/passed"
PLANS = f"{NAMESPACE}/plans"
DRIVER = f"{NAMESPACE}/driver"
RECOVERY = f"{NAMESPACE}/recovery"
KNOWN = f"{NAMESPACE}/known"

#: Every key above, for clients that read them all and for :func:`reset`.
ALL_KEYS: tuple[str, ...] = (FRAME, MARKS, LAST_SEEN, TARGET, PASSED, PLANS, DRIVER, RECOVERY,
                             KNOWN)


@dataclass(frozen=True, init=False)
class SeenMark:
    """One mark seen in one frame: robot frame (at the time of the tick), world frame, pixels.

    ``forward_mm``/``left_mm`` are the estimate relative to the robot *when the frame was
    captured* (eqs. 19/2 and 21), ``world_x``/``world_y`` the same point placed with the robot's
    odometry pose at that time. ``x_px`` is the image column of the mark's centre and
    ``radius_px`` its semi-major axis in a frame ``image_width`` pixels wide; ``t`` is the
    frame's capture time (mission clock). Where the robot is now, the mark is at
    ``to_robot_frame(pose_now, world)``, not at ``forward_mm``/``left_mm``.

    Made for every mark of every frame: the constructor fills the instance's dict in one step
    (a frozen dataclass's own ``__init__`` sets each field through ``object.__setattr__``,
    ~3× slower); the dataclass still makes it frozen, compared and printed by its fields.
    """

    colour: str
    forward_mm: float
    left_mm: float
    world_x: float
    world_y: float
    x_px: float
    radius_px: float
    image_width: int
    t: float
    #: Straight-line distance from the robot to the mark centre (mm), computed once.
    range_mm: float = field(init=False, repr=False, compare=False)

    def __init__(self, colour: str, forward_mm: float, left_mm: float, world_x: float,
                 world_y: float, x_px: float, radius_px: float, image_width: int,
                 t: float) -> None:
        self.__dict__.update(colour=colour, forward_mm=forward_mm, left_mm=left_mm,
                             world_x=world_x, world_y=world_y, x_px=x_px, radius_px=radius_px,
                             image_width=image_width, t=t,
                             range_mm=math.hypot(forward_mm, left_mm))

    @property
    def bearing_rad(self) -> float:
        """Direction of the mark from the robot's heading, positive to the left (rad)."""
        return math.atan2(self.left_mm, self.forward_mm)

    @property
    def world(self) -> tuple[float, float]:
        """``(world_x, world_y)``."""
        return (self.world_x, self.world_y)

    @property
    def pixel_error(self) -> float:
        """Column of the mark centre relative to the image centre, positive to the right (px).

        Pixel centres sit at integer columns, so the centre of a W-pixel row is (W − 1) / 2.
        """
        return self.x_px - image_centre(self.image_width)


def cut_by_image_side(seen: SeenMark) -> bool:
    """Whether the mark's disc reaches the left or right edge of the image. The detector then
    fits only the part in view, and its radius, hence its range, can be far off (a mark leaving
    the frame during its bypass reads a few hundred millimetres near; one entering the frame
    after a bypass can read a third short)."""
    return seen.x_px - seen.radius_px < 2.0 or seen.x_px + seen.radius_px > seen.image_width - 3.0


def centre_outside_image(seen: SeenMark) -> bool:
    """Whether the mark's fitted centre lies beyond the image's left or right edge: less than
    half of it is in view, and its range is of that part (random missions 91 and 119: 1.07 m
    for 1.57 m, 0.85 m for 0.97 m). A disc only grazing the edge usually reads true."""
    return seen.x_px < 0.0 or seen.x_px > seen.image_width - 1.0


def unseen_s(seen: SeenMark, frame: FrameInfo | None, now: float) -> float:
    """How long the camera has been looking without seeing ``seen``'s mark again: from its
    capture time to the newest frame's (``now`` when no frame was processed yet). Capture
    times on both sides, so a camera's latency does not count as the mark being out of view;
    a camera that stops delivering is Perception's to judge."""
    newest = frame.t if frame is not None else now
    return max(0.0, newest - seen.t)


def image_centre(width: int) -> float:
    """Column of the image centre for a row ``width`` pixels wide (pixel centres at integers)."""
    return 0.5 * (width - 1)


@dataclass(frozen=True, init=False)
class FrameInfo:
    """The latest frame perception processed: source index, its capture time (mission clock),
    size, number of marks found, ``range_sigma``: while the range law is being learnt
    (``camera.learn_range``), the σ of its scale (of ln d, ≈ the relative error of a range); 0
    when the law is fixed; and ``latency_s``: the frame's age when it was processed (capture
    to the tick). (Made every frame: one-step constructor, as :class:`SeenMark`'s.)"""

    index: int
    t: float
    width: int
    height: int
    marks: int
    range_sigma: float = 0.0
    latency_s: float = 0.0

    def __init__(self, index: int, t: float, width: int, height: int, marks: int,
                 range_sigma: float = 0.0, latency_s: float = 0.0) -> None:
        self.__dict__.update(index=index, t=t, width=width, height=height, marks=marks,
                             range_sigma=range_sigma, latency_s=latency_s)


@dataclass(frozen=True, init=False)
class Target:
    """The mark the robot is heading for: the current waypoint's mark.

    ``waypoint`` is its index in the route (0-based; −1 when the waypoint was built without one)
    and ``waypoint_id`` the identity of the Waypoint subtree that selected it. ``side`` is the pass
    side (``left``: the robot passes on the mark's left, with the mark on its right).
    ``sighting`` is the latest sighting of *this* mark (``None``: not seen yet) and
    ``world_x``/``world_y`` the best estimate of its world position. Once ``locked`` (the bypass
    has started) the mark is followed by world position, never swapped for another mark of the
    same colour.
    """

    waypoint: int
    waypoint_id: str
    colour: str
    side: Side
    sighting: SeenMark | None = None
    world_x: float | None = None
    world_y: float | None = None
    locked: bool = False
    #: Chosen from the mark memory (seen before, out of view now): followed by world position
    #: until it is seen again, not swapped for a farther mark of its colour that is in view.
    remembered: bool = False

    def __init__(self, waypoint: int, waypoint_id: str, colour: str, side: Side,
                 sighting: SeenMark | None = None, world_x: float | None = None,
                 world_y: float | None = None, locked: bool = False,
                 remembered: bool = False) -> None:
        # Refreshed with every sighting: one-step constructor, as SeenMark's.
        self.__dict__.update(waypoint=waypoint, waypoint_id=waypoint_id, colour=colour,
                             side=side, sighting=sighting, world_x=world_x, world_y=world_y,
                             locked=locked, remembered=remembered)

    @property
    def world(self) -> tuple[float, float] | None:
        """The estimated world position, or ``None`` when the mark was never seen."""
        if self.world_x is None or self.world_y is None:
            return None
        return (self.world_x, self.world_y)

    @property
    def label(self) -> str:
        """``red #2`` (1-based waypoint number), for feedback messages."""
        return f"{self.colour} #{self.waypoint + 1}" if self.waypoint >= 0 else self.colour


@dataclass(frozen=True, init=False)
class KnownMark:
    """A mark remembered from earlier frames (``/marknav/known``): its colour, its latest world
    position estimate (odometry frame), when it was last seen and from how far. (Made for
    every mark of every frame: one-step constructor, as :class:`SeenMark`'s.)"""

    colour: str
    world_x: float
    world_y: float
    t: float
    range_mm: float
    #: Frames that saw it, and frames since that should have (in view, near) but did not.
    seen: int = 1
    missed: int = 0

    def __init__(self, colour: str, world_x: float, world_y: float, t: float, range_mm: float,
                 seen: int = 1, missed: int = 0) -> None:
        self.__dict__.update(colour=colour, world_x=world_x, world_y=world_y, t=t,
                             range_mm=range_mm, seen=seen, missed=missed)

    @property
    def world(self) -> tuple[float, float]:
        return (self.world_x, self.world_y)


@dataclass(frozen=True)
class PassedWaypoint:
    """A waypoint whose mark was passed: when, on which side, where the robot believed it was,
    and ``doubt``: why the robot's own evidence (its sightings against the path it drove) does
    not confirm the pass (``None``: it does), and ``check``: what looking back at it decided."""

    waypoint: int
    waypoint_id: str
    colour: str
    side: Side
    t: float
    mark_x: float
    mark_y: float
    doubt: str | None = None
    #: A doubtful pass checked by looking back (:mod:`marknav.behaviours.verify`):
    #: ``"confirmed"``, ``"refuted"`` or ``"unverified"``; ``None``: not checked (no doubt, or
    #: not yet).
    check: str | None = None


@dataclass(frozen=True)
class PlanRecord:
    """A bypass plan as it was made: for the run plot and the event log.

    ``reason`` is ``"initial"``, ``"re-plan"`` (a closer sighting) or ``"resumed"`` (planned
    again from the current pose after an interruption, e.g. a bump recovery); ``plan.curves`` are
    the two quadratic Béziers (world frame), ``plan.sample(step_mm)`` gives points to draw.
    """

    waypoint: int
    colour: str
    side: Side
    t: float
    reason: str
    plan: BypassPlan


@dataclass(frozen=True)
class Driver:
    """The behaviour that last commanded the wheels (by py_trees id), and since when.

    A behaviour's ``terminate()`` stops the wheels only while it is the driver, so a preempted
    behaviour never cancels the command of the one that preempted it.
    """

    id: str
    name: str
    since: float


@dataclass(frozen=True)
class Recovery:
    """Bump recoveries so far in this mission, and whether one is under way."""

    count: int = 0
    active: bool = False
    started_t: float | None = None


def read(client: py_trees.blackboard.Client, key: str, default: Any = None) -> Any:
    """``client.get(key)``, or ``default`` while the key is not set yet."""
    try:
        return client.get(key)
    except KeyError:
        return default


def snapshot() -> dict[str, Any]:
    """Every ``/marknav/`` key that is set, with its value (for logs, plots and tests)."""
    out: dict[str, Any] = {}
    for key in ALL_KEYS:
        if py_trees.blackboard.Blackboard.exists(key):
            out[key] = py_trees.blackboard.Blackboard.get(key)
    return out


def reset() -> None:
    """Unset every ``/marknav/`` key: route progress, target, plans, recoveries.

    Call it before each run when several missions run in one process; the blackboard is global.
    Registered clients keep their access rights.
    """
    for key in ALL_KEYS:
        py_trees.blackboard.Blackboard.unset(key)
