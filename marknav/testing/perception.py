"""Mocked perception: scripted marks instead of a camera, published exactly like the real thing.

:class:`FakePerception` is a drop-in for :class:`marknav.behaviours.perception.Perception` (same
default name, same blackboard writes, same "camera lost" timeout). Each tick it produces one
frame's marks from

- ``world``: marks at fixed world positions (:class:`WorldMark`), seen from the robot's *true*
  pose (``robot.true_pose`` when the robot has one, as :class:`~marknav.testing.FakeRobot` does,
  else ``robot.pose()``) through a pinhole camera at the robot's centre — f = 590 px, 640 px wide
  by default; a mark is visible when it is in front and its whole disc fits in the image; and/or
- ``script``: per tick, marks in the robot frame (:class:`RobotMark`), as a list (one entry per
  tick; ``None`` means no frame that tick; after the list, no scripted marks) or a callable
  ``script(tick, t)``.

Pixels are synthesised with the pinhole model (radius r = f·R / forward, column
x = c_x − f·left / forward), so steering on the pixel error works; the estimate is the exact
robot-frame position, placed in the world with the robot's *odometry* as the real perception
does. ``camera_on = False`` stops the frames (the camera is lost after ``camera_timeout_s``).
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

from marknav.behaviours import keys
from marknav.behaviours.perception import DEFAULT_CAMERA_TIMEOUT_S, Observation, PerceptionBase
from marknav.planning.kinematics import Pose

__all__ = ["FakePerception", "RobotMark", "Script", "WorldMark", "pinhole_pixels"]

_RANGE = operator.attrgetter("range_mm")


@dataclass(frozen=True)
class WorldMark:
    """A mark at a fixed world position (mm)."""

    colour: str
    x_mm: float
    y_mm: float


@dataclass(frozen=True)
class RobotMark:
    """A mark as the camera sees it this tick, in the robot frame (mm; x forward, y left)."""

    colour: str
    forward_mm: float
    left_mm: float


Script = Sequence[Sequence[RobotMark] | None] | Callable[[int, float], Sequence[RobotMark] | None]


def pinhole_pixels(forward_mm: float, left_mm: float, *, focal_px: float, radius_mm: float,
                   image_width: int) -> tuple[float, float]:
    """``(x_px, radius_px)`` of a mark facing the camera: r = f·R / forward (eq. 2),
    x = c_x − f·left / forward (eq. 21 inverted), c_x = (width − 1) / 2."""
    if forward_mm <= 0.0:
        raise ValueError(f"a mark must be in front of the camera, got forward_mm={forward_mm}")
    radius_px = focal_px * radius_mm / forward_mm
    x_px = keys.image_centre(image_width) - focal_px * left_mm / forward_mm
    return x_px, radius_px


class FakePerception(PerceptionBase):
    """Writes scripted or world-placed marks to the blackboard each tick (see module docstring).

    Args:
        world: marks at world positions.
        script: robot-frame marks per tick (list or callable).
        focal_px, image_width, image_height: the pinhole camera.
        mark_radius_mm: default: the mission's ``marks.radius_mm``, else 100.
        min_radius_px: smaller marks are not seen (too far).
        camera_timeout_s: no frame this long → FAILURE "camera lost".
    """

    def __init__(
        self,
        name: str = "Perception",
        *,
        world: Iterable[WorldMark] = (),
        script: Script | None = None,
        focal_px: float = 590.0,
        image_width: int = 640,
        image_height: int = 480,
        mark_radius_mm: float | None = None,
        min_radius_px: float = 4.0,
        camera_timeout_s: float = DEFAULT_CAMERA_TIMEOUT_S,
    ) -> None:
        super().__init__(name, camera_timeout_s=camera_timeout_s)
        self.world: list[WorldMark] = list(world)
        self.script = script
        self.focal_px = float(focal_px)
        self.image_width = int(image_width)
        self.image_height = int(image_height)
        self._radius_override = mark_radius_mm
        self.mark_radius_mm = float(mark_radius_mm) if mark_radius_mm is not None else 100.0
        self.min_radius_px = float(min_radius_px)
        self.camera_on = True
        self.ticks = 0
        self._world_key: tuple[WorldMark, ...] | None = None
        self._world_xy: list[tuple[str, float, float]] = []

    def configure(self, **kwargs: Any) -> None:
        if self._radius_override is None and self.mission is not None:
            self.mark_radius_mm = self.mission.marks.radius_mm

    def place(self, colour: str, *, x_mm: float, y_mm: float) -> WorldMark:
        """Add a mark at a world position; returns it (remove it from :attr:`world` to hide it)."""
        mark = WorldMark(colour, float(x_mm), float(y_mm))
        self.world.append(mark)
        return mark

    def visible(self, forward_mm: float, left_mm: float) -> bool:
        """Whether a mark there is in view: in front, large enough, the whole disc in the image."""
        if forward_mm <= self.mark_radius_mm:
            return False
        x_px, r_px = pinhole_pixels(forward_mm, left_mm, focal_px=self.focal_px,
                                    radius_mm=self.mark_radius_mm, image_width=self.image_width)
        return self._fits(x_px, r_px)

    def _fits(self, x_px: float, r_px: float) -> bool:
        """Large enough, and the whole disc inside the image."""
        return (r_px >= self.min_radius_px and x_px - r_px >= 0.0
                and x_px + r_px <= self.image_width - 1
                and 2.0 * r_px <= self.image_height - 1)

    def _view_pose(self) -> Pose:
        true_pose = getattr(self.robot, "true_pose", None)
        return true_pose if isinstance(true_pose, Pose) else self.robot.pose()

    def _scripted(self, tick: int, t: float) -> tuple[bool, Sequence[RobotMark]]:
        """(frame available, scripted marks) for this tick."""
        if self.script is None:
            return True, ()
        if callable(self.script):
            marks = self.script(tick, t)
        elif tick < len(self.script):
            marks = self.script[tick]
        else:
            return True, ()
        return (marks is not None), (marks or ())

    def observe(self) -> Observation | None:
        tick = self.ticks
        self.ticks += 1
        if not self.camera_on:
            return None
        t = self.now()
        available, scripted = self._scripted(tick, t)
        if not available:
            return None
        relative: list[tuple[str, float, float, float, float]] = [
            (m.colour, m.forward_mm, m.left_mm,
             *pinhole_pixels(m.forward_mm, m.left_mm, focal_px=self.focal_px,
                             radius_mm=self.mark_radius_mm, image_width=self.image_width))
            for m in scripted]
        if self.world:
            relative.extend(self._in_view(self._view_pose()))
        marks = []
        odometry = self.robot.pose() if relative else None  # where the robot believes it is
        if odometry is not None:
            # seen_mark's placement (to_world_frame), with one cos/sin for the frame's marks
            ox, oy = odometry.x, odometry.y
            c, s = math.cos(odometry.theta), math.sin(odometry.theta)
            width = self.image_width
            for colour, forward, left, x_px, r_px in relative:
                # SeenMark(colour, forward_mm, left_mm, world_x, world_y, x_px, radius_px,
                # image_width, t), positionally: made for every mark of every tick
                marks.append(keys.SeenMark(colour, forward, left, ox + c * forward - s * left,
                                           oy + s * forward + c * left, x_px, r_px, width, t))
        marks.sort(key=_RANGE)
        info = keys.FrameInfo(index=tick, t=t, width=self.image_width,
                              height=self.image_height, marks=len(marks))
        return Observation(frame=info, marks=tuple(marks), pose=odometry)

    def _in_view(self, pose: Pose) -> list[tuple[str, float, float, float, float]]:
        """``(colour, forward, left, x_px, radius_px)`` of the world marks in view from
        ``pose``: a cheap cull (in front, near enough to look large enough, inside a slightly
        widened field of view) before the exact test of :meth:`visible`, so a long course costs
        little per tick."""
        c, s = math.cos(pose.theta), math.sin(pose.theta)
        px, py = pose.x, pose.y
        radius = self.mark_radius_mm
        focal = self.focal_px
        min_r = self.min_radius_px
        far = focal * radius / min_r + 1.0
        half = 0.5 * self.image_width / focal
        # pinhole_pixels and _fits inlined (the same expressions, so the same floats): this loop
        # runs for every world mark every tick.
        centre = keys.image_centre(self.image_width)
        right_edge = self.image_width - 1
        bottom = self.image_height - 1
        out = []
        marks = tuple(self.world)
        if marks != self._world_key:  # (colour, x, y) of each mark, made when the world changes
            self._world_key = marks
            self._world_xy = [(w.colour, w.x_mm, w.y_mm) for w in marks]
        for colour, x_mm, y_mm in self._world_xy:
            dx, dy = x_mm - px, y_mm - py
            forward = c * dx + s * dy
            if forward <= radius or forward > far:
                continue
            left = c * dy - s * dx
            if abs(left) > forward * half + radius + 1.0:
                continue
            r_px = focal * radius / forward
            x_px = centre - focal * left / forward
            if (r_px >= min_r and x_px - r_px >= 0.0 and x_px + r_px <= right_edge
                    and 2.0 * r_px <= bottom):
                out.append((colour, forward, left, x_px, r_px))
        return out


def hfov_rad(focal_px: float, image_width: int) -> float:
    """Horizontal field of view of the pinhole camera (rad)."""
    return 2.0 * math.atan(image_width / (2.0 * focal_px))
