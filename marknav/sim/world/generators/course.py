"""The course of a generated world (``course``): marks in route order that the route can be
driven through, drawn from the world's main random stream (after the image/wheel conditions).

Marks go along the start's heading (+y from the default pose), each ``course.spacing`` after the
previous one (``course.first_mark`` for the first), offset sideways by ``course.lateral_offset``
(ranges of :mod:`marknav.sim.randomisation`) with alternating signs. A draw is kept only if
(a) the first mark is in full view from the start, (b) from where each bypass ends — beside the
mark at the clearance on the side to pass (both sides when the sides are not given), heading as
when the bypass began — the next mark is at least the bypass distance plus
:data:`REACQUIRE_MARGIN_MM` away and within the field of view plus :data:`MAX_SEARCH_TURN_DEG`.
After :data:`GENERATION_TRIES` failed draws the offset's side flips; after as many again the mark
goes on the axis, at the longest spacing. Randomised worlds turn each mark by up to the engine's
``*.mark_yaw`` range from the line of sight of where the robot looks for it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from marknav.planning.kinematics import Pose, wrap_angle
from marknav.sim.randomisation import bounds
from marknav.sim.world.generators.registry import Draft, Request, register
from marknav.sim.world.schema import MarkSpec

__all__ = [
    "DEFAULT_HALF_FOV_DEG",
    "FIRST_MARK_FOV_MARGIN_DEG",
    "GENERATION_TRIES",
    "MAX_SEARCH_TURN_DEG",
    "REACQUIRE_MARGIN_MM",
]

#: Half the horizontal field of view of the default camera (640 px wide, f = 590 px).
DEFAULT_HALF_FOV_DEG = math.degrees(math.atan(320.0 / 590.0))
#: After a bypass, the next mark must be at least ``bypass_distance_mm`` plus this far away,
#: so the robot sees it and approaches before its own bypass starts.
REACQUIRE_MARGIN_MM = 300.0
#: The next mark may lie this far outside the field of view at the end of a bypass (a short
#: search turn finds it).
MAX_SEARCH_TURN_DEG = 15.0
#: The first mark is this far inside the field of view from the start pose.
FIRST_MARK_FOV_MARGIN_DEG = 8.0
#: Random draws per mark on the alternating side (then as many on the other side) before falling
#: back to a mark on the course's axis.
GENERATION_TRIES = 200

#: Where the robot can be when it starts looking for the next mark, with its heading then.
_Origin = tuple[tuple[float, float], float]


def _bearing(frm: tuple[float, float], heading: float, to: tuple[float, float]) -> float:
    return wrap_angle(math.atan2(to[1] - frm[1], to[0] - frm[0]) - heading)


@dataclass(frozen=True)
class _Frame:
    """The course's geometry: its start pose and axes, and the limits the draws keep to."""

    p0: Pose
    fwd: tuple[float, float]
    left: tuple[float, float]
    half_fov: float
    reacquire: float
    first: tuple[float, float]
    spacing: tuple[float, float]
    radius_mm: float

    @classmethod
    def of(cls, req: Request, p0: Pose) -> _Frame:
        reacquire = req.bypass_distance_mm + REACQUIRE_MARGIN_MM
        spacing_range, first_range = bounds("course.spacing"), bounds("course.first_mark")
        spacing_lo = max(spacing_range[0], reacquire + req.clearance_mm)
        first_lo = max(first_range[0], reacquire)
        fwd = (math.cos(p0.theta), math.sin(p0.theta))
        return cls(p0=p0, fwd=fwd, left=(-fwd[1], fwd[0]),
                   half_fov=math.radians(req.half_fov_deg), reacquire=reacquire,
                   first=(first_lo, max(first_range[1], first_lo + 200.0)),
                   spacing=(spacing_lo, max(spacing_range[1], spacing_lo + 200.0)),
                   radius_mm=req.radius_mm)

    def point(self, along: float, off: float) -> tuple[float, float]:
        return (self.p0.x + along * self.fwd[0] + off * self.left[0],
                self.p0.y + along * self.fwd[1] + off * self.left[1])

    def in_view(self, m: tuple[float, float], origins: list[_Origin], first: bool) -> bool:
        """Whether a mark at ``m`` is far enough from, and in view of, every origin."""
        for o_xy, o_heading in origins:
            dist = math.dist(o_xy, m)
            angular_r = math.asin(min(1.0, self.radius_mm / dist))
            limit = (self.half_fov - math.radians(FIRST_MARK_FOV_MARGIN_DEG) - angular_r if first
                     else self.half_fov + math.radians(MAX_SEARCH_TURN_DEG))
            if dist < self.reacquire or abs(_bearing(o_xy, o_heading, m)) > limit:
                return False
        return True


def _place(rng: np.random.Generator, frame: _Frame, origins: list[_Origin], along: float,
           sign: float, first: bool) -> tuple[float, float]:
    """(along, offset) of the next mark: drawn on the alternating side, then the other, else
    straight down the axis at the longest step (in view from the origins by construction)."""
    lo, hi = frame.first if first else frame.spacing
    lateral = bounds("course.lateral_offset")
    for attempt in range(2 * GENERATION_TRIES):
        side_sign = sign if attempt < GENERATION_TRIES else -sign
        step = round(float(rng.uniform(lo, hi)), 1)
        off = round(side_sign * float(rng.uniform(*lateral)), 1)
        if frame.in_view(frame.point(along + step, off), origins, first):
            return along + step, off
    return along + hi, 0.0


def _yaw(rng: np.random.Generator, req: Request, frame: _Frame, m: tuple[float, float],
         origins: list[_Origin], first: bool) -> float:
    """The mark's yaw: facing the course's start direction (the first mark, default worlds), or
    turned by a drawn angle from the line of sight of where the robot will look for it."""
    # One draw in [-1, 1) scaled by the engine's limit: both engines' courses are the same.
    yaw_max = bounds("mujoco.mark_yaw" if req.engine == "mujoco" else "builtin.mark_yaw")[1]
    yaw = float(rng.uniform(-1.0, 1.0)) * yaw_max if req.randomised else 0.0
    if first or not req.randomised:
        return yaw + math.degrees(frame.p0.theta - math.pi / 2.0)  # face the start direction
    # Turned relative to the line of sight from where the robot will look for it (the previous
    # bypass ends), so the drawn yaw is the angle the camera sees it at: a yaw drawn against the
    # course could leave the mark edge-on, a sliver no camera finds.
    sx = sum(m[0] - o[0][0] for o in origins)
    sy = sum(m[1] - o[0][1] for o in origins)
    return yaw + math.degrees(math.atan2(-sx, sy))  # normal (sin yaw, -cos yaw) toward them


def _bypass_ends(m: tuple[float, float], origins: list[_Origin], wanted: list[str],
                 clearance_mm: float) -> list[_Origin]:
    """Where the bypasses of the mark at ``m`` end: the bypass begins where the robot, coming
    from an origin, heads at the mark, and ends beside it at the clearance, heading unchanged.
    Only the extreme ends are kept: they are the binding ones."""
    ends: list[_Origin] = []
    for o_xy, _o_heading in origins:
        h = math.atan2(m[1] - o_xy[1], m[0] - o_xy[0])
        n = (-math.sin(h), math.cos(h))
        for side in wanted:
            s = 1.0 if side == "left" else -1.0  # pass on the mark's left: robot on its left
            ends.append(((m[0] + s * clearance_mm * n[0], m[1] + s * clearance_mm * n[1]), h))
    return ends[:4] if len(ends) <= 4 else [ends[0], ends[1], ends[-2], ends[-1]]


@register("course")
def course(draft: Draft) -> None:
    """The marks of the route, in order, from the main stream (see the module docstring)."""
    req, rng = draft.request, draft.rng
    frame = _Frame.of(req, draft.robot.pose())
    sign = 1.0 if rng.random() < 0.5 else -1.0
    origins: list[_Origin] = [((frame.p0.x, frame.p0.y), frame.p0.theta)]
    along = 0.0
    for i, colour in enumerate(req.route):
        along, off = _place(rng, frame, origins, along, sign, i == 0)
        if off != 0.0:
            sign = math.copysign(1.0, off)
        m = frame.point(along, off)
        yaw = _yaw(rng, req, frame, m, origins, i == 0)
        draft.marks.append(MarkSpec(colour=colour, x_mm=round(m[0], 1), y_mm=round(m[1], 1),
                                    yaw_deg=round(yaw, 2), radius_mm=req.radius_mm))
        wanted: list[str] = [req.sides[i]] if req.sides is not None else ["left", "right"]
        origins = _bypass_ends(m, origins, wanted, req.clearance_mm)
        sign = -sign
