"""Contact physics: the robot's disc against marks, walls and boxes, and the bumper bits.

The robot is a disc (Create: 330 mm); a mark is a thin disc standing on the floor, treated in the
top view as a circle of its radius around its centre (conservative); walls are segments, boxes
rectangles. :func:`contacts` gives each touching obstacle with the contact angle relative to the
heading and the bumper bits it presses (left half of the front, right half, both when nearly
straight ahead; no bit behind the bumper's arc); :func:`push_out` moves the robot clear.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

from marknav.planning.kinematics import Pose, wrap_angle
from marknav.sim.world.schema import CREATE_RADIUS_MM, World

__all__ = [
    "BOTH_BUMPS_HALF_ANGLE_DEG",
    "BUMPER_HALF_ARC_DEG",
    "Bumps",
    "Contact",
    "bumper_sides",
    "bumps",
    "contacts",
    "push_out",
]

#: The bumper covers the front half of the robot: contacts within ±90° of the heading press it.
BUMPER_HALF_ARC_DEG = 90.0
#: A contact within ±10° of straight ahead presses both halves.
BOTH_BUMPS_HALF_ANGLE_DEG = 10.0


def bumper_sides(angle_rad: float) -> tuple[bool, bool]:
    """(left, right): which bumper switches a contact at ``angle_rad`` from the heading (left
    positive) presses: each side's arc of :data:`BUMPER_HALF_ARC_DEG`, both within
    :data:`BOTH_BUMPS_HALF_ANGLE_DEG` of straight ahead."""
    a = math.degrees(angle_rad)
    return (-BOTH_BUMPS_HALF_ANGLE_DEG <= a <= BUMPER_HALF_ARC_DEG,
            -BUMPER_HALF_ARC_DEG <= a <= BOTH_BUMPS_HALF_ANGLE_DEG)


@dataclass(frozen=True)
class Contact:
    """The robot touching an obstacle.

    ``kind`` and ``index`` name it (``world.marks[index]``, ``walls[index]``, ``boxes[index]``);
    (x_mm, y_mm) is the contact point on the robot's rim; ``angle_rad`` is its direction from the
    robot's centre relative to the heading, positive to the left, in (−π, π]; ``depth_mm`` is how
    far the obstacle reaches inside the robot's disc (0 when just touching).
    """

    kind: Literal["mark", "wall", "box"]
    index: int
    x_mm: float
    y_mm: float
    angle_rad: float
    depth_mm: float

    @property
    def bump_left(self) -> bool:
        return bumper_sides(self.angle_rad)[0]

    @property
    def bump_right(self) -> bool:
        return bumper_sides(self.angle_rad)[1]


@dataclass(frozen=True)
class Bumps:
    """The bumper bits a set of contacts presses (OI packet 7 bits 1 and 0)."""

    left: bool
    right: bool


def _closest_on_segment(
    p: tuple[float, float], a: tuple[float, float], b: tuple[float, float]
) -> tuple[float, float]:
    abx, aby = b[0] - a[0], b[1] - a[1]
    t = ((p[0] - a[0]) * abx + (p[1] - a[1]) * aby) / (abx * abx + aby * aby)
    t = min(1.0, max(0.0, t))
    return (a[0] + t * abx, a[1] + t * aby)


def _contact(
    pose: Pose, kind: Literal["mark", "wall", "box"], index: int, towards: tuple[float, float],
    depth: float, robot_radius_mm: float,
) -> Contact:
    dx, dy = towards[0] - pose.x, towards[1] - pose.y
    direction = math.atan2(dy, dx) if (dx or dy) else pose.theta
    return Contact(
        kind=kind,
        index=index,
        x_mm=pose.x + robot_radius_mm * math.cos(direction),
        y_mm=pose.y + robot_radius_mm * math.sin(direction),
        angle_rad=wrap_angle(direction - pose.theta),
        depth_mm=max(0.0, depth),
    )


def contacts(
    world: World, pose: Pose, *, robot_radius_mm: float = CREATE_RADIUS_MM
) -> list[Contact]:
    """Every mark, wall and box the robot (a disc of ``robot_radius_mm`` at ``pose``) touches."""
    out: list[Contact] = []
    p = (pose.x, pose.y)
    for i, m in enumerate(world.marks):
        reach = robot_radius_mm + m.radius()
        d = math.dist(p, m.xy)
        if d <= reach:
            out.append(_contact(pose, "mark", i, m.xy, reach - d, robot_radius_mm))
    for i, w in enumerate(world.walls):
        q = _closest_on_segment(p, *w.segment())
        d = math.dist(p, q)
        if d <= robot_radius_mm:
            out.append(_contact(pose, "wall", i, q, robot_radius_mm - d, robot_radius_mm))
    for i, box in enumerate(world.boxes):
        corners = box.corners()
        best: tuple[float, float] | None = None
        for k in range(4):
            q = _closest_on_segment(p, corners[k], corners[(k + 1) % 4])
            if best is None or math.dist(p, q) < math.dist(p, best):
                best = q
        assert best is not None
        inside = box.contains(*p)
        d = math.dist(p, best)
        if inside or d <= robot_radius_mm:
            towards = (box.x_mm, box.y_mm) if inside else best
            depth = robot_radius_mm + d if inside else robot_radius_mm - d
            out.append(_contact(pose, "box", i, towards, depth, robot_radius_mm))
    return out


def bumps(found: Sequence[Contact]) -> Bumps:
    """The bumper bits pressed by ``found`` (contacts behind the bumper's arc press none)."""
    return Bumps(left=any(c.bump_left for c in found), right=any(c.bump_right for c in found))


def push_out(
    world: World, pose: Pose, *, robot_radius_mm: float = CREATE_RADIUS_MM, iterations: int = 8
) -> Pose:
    """The nearest pose (same heading) where the robot no longer overlaps anything: each contact
    pushes the centre away from it by its depth; a few rounds settle corners."""
    x, y = pose.x, pose.y
    for _ in range(iterations):
        found = contacts(world, Pose(x, y, pose.theta), robot_radius_mm=robot_radius_mm)
        moved = False
        for c in found:
            if c.depth_mm <= 1e-9:
                continue
            direction = pose.theta + c.angle_rad
            x -= (c.depth_mm + 1e-6) * math.cos(direction)
            y -= (c.depth_mm + 1e-6) * math.sin(direction)
            moved = True
        if not moved:
            break
    return Pose(x, y, pose.theta)
