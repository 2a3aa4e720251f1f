"""Following a planned path: closed-loop pure pursuit, and the paper's open-loop stepping.

- :class:`PurePursuit` — closed loop on the robot's pose estimate (odometry): each cycle it takes
  the path point one look-ahead distance beyond the robot's closest point and drives the arc
  tangent to the heading through it (κ = 2·y_r / (x_r² + y_r²), the well-posed replacement for
  the paper's eqs. 31–36), slowing down over the last stretch.
- :func:`open_loop_wheel_steps` — the paper's stepping (§4.6: divide t ∈ [0, 1] into steps
  Δt, drive from each curve point to the next, eqs. 24 and 35–39), with the exact arc step of
  :func:`~marknav.planning.kinematics.arc_step` instead of eqs. 35–36. Nothing measured feeds
  back, so wheel mismatch and slip accumulate; it exists to be compared with pure pursuit.

No I/O, no clock: callers pass poses and elapsed times.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from marknav.planning.bezier import BypassPlan, QuadraticBezier, Vec2, sample_curves
from marknav.planning.kinematics import (
    ArcStep,
    Pose,
    WheelSpeeds,
    arc_curvature,
    arc_step,
    integrate_pose,
    to_robot_frame,
    wheel_speeds_for_curvature,
)

__all__ = [
    "PathLike",
    "PurePursuit",
    "open_loop_command",
    "open_loop_wheel_steps",
    "path_polyline",
]

FloatArray = npt.NDArray[np.float64]
#: A path to follow: a bypass plan, a chain of quadratic Béziers or an ``(n, 2)`` polyline (mm).
PathLike = BypassPlan | Sequence[QuadraticBezier] | FloatArray

_STOP = WheelSpeeds(left=0.0, right=0.0)


def path_polyline(path: PathLike, step_mm: float = 5.0) -> FloatArray:
    """The path as an ``(n, 2)`` polyline with consecutive points about ``step_mm`` apart.

    Curves are sampled evenly in arc length; a polyline is used as given, less repeated points.
    """
    if isinstance(path, BypassPlan):
        return path.sample(step_mm)
    if isinstance(path, np.ndarray):
        pts = np.asarray(path, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] != 2:
            raise ValueError(f"a polyline must be an (n, 2) array, got shape {pts.shape}")
        keep = np.concatenate(([True], np.any(np.diff(pts, axis=0) != 0.0, axis=1)))
        pts = pts[keep]
    else:
        pts = sample_curves(list(path), step_mm)
    if pts.shape[0] < 2:
        raise ValueError("a path needs at least two distinct points")
    return pts


class PurePursuit:
    """Closed-loop pure-pursuit follower of a planned path, fed with the pose from odometry.

    ``command(pose)`` returns the wheel speeds for this control cycle and advances the tracker's
    progress along the path (it never goes backwards); ``finished(pose)`` tells whether the end
    is reached. Past the end the path is extended along its end tangent, so the robot settles on
    the end's direction instead of circling the end point.

    Args:
        path: a :class:`BypassPlan`, a chain of :class:`QuadraticBezier`, or an ``(n, 2)``
            polyline (world frame, mm).
        lookahead_mm: look-ahead distance along the path (mm).
        speed_mm_s: cruising speed of the robot centre (mm/s).
        wheel_base_mm: distance between the wheels (mm).
        max_wheel_mm_s: wheel speed limit; both wheels are scaled together above it.
        goal_tolerance_mm: the end counts as reached within this distance (mm).
        slowdown_mm: over the last ``slowdown_mm`` of path the speed ramps down linearly
            (default: twice the look-ahead).
        min_speed_mm_s: speed floor of the ramp, so the end is actually reached
            (default: 20 % of ``speed_mm_s``).
    """

    def __init__(
        self,
        path: PathLike,
        *,
        lookahead_mm: float = 150.0,
        speed_mm_s: float,
        wheel_base_mm: float,
        max_wheel_mm_s: float,
        goal_tolerance_mm: float = 5.0,
        slowdown_mm: float | None = None,
        min_speed_mm_s: float | None = None,
    ) -> None:
        for name, value in (
            ("lookahead_mm", lookahead_mm), ("speed_mm_s", speed_mm_s),
            ("wheel_base_mm", wheel_base_mm), ("max_wheel_mm_s", max_wheel_mm_s),
            ("goal_tolerance_mm", goal_tolerance_mm),
        ):
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be a positive number, got {value}")
        self.lookahead_mm = float(lookahead_mm)
        self.speed_mm_s = float(speed_mm_s)
        self.wheel_base_mm = float(wheel_base_mm)
        self.max_wheel_mm_s = float(max_wheel_mm_s)
        self.goal_tolerance_mm = float(goal_tolerance_mm)
        self.slowdown_mm = 2.0 * self.lookahead_mm if slowdown_mm is None else float(slowdown_mm)
        self.min_speed_mm_s = (
            0.2 * self.speed_mm_s if min_speed_mm_s is None else float(min_speed_mm_s)
        )
        if not 0.0 < self.min_speed_mm_s <= self.speed_mm_s:
            raise ValueError(
                f"min_speed_mm_s must be in (0, speed_mm_s], got {self.min_speed_mm_s}"
            )
        if self.slowdown_mm < 0.0:
            raise ValueError(f"slowdown_mm must not be negative, got {self.slowdown_mm}")

        self.points = path_polyline(path)
        seg = np.diff(self.points, axis=0)
        self._seg = seg
        self._seg_len = np.hypot(seg[:, 0], seg[:, 1])
        self._seg_len2 = self._seg_len ** 2
        self._cum = np.concatenate(([0.0], np.cumsum(self._seg_len)))
        self._cum_list: list[float] = self._cum.tolist()  # bisect beats searchsorted on scalars
        self.length_mm = float(self._cum[-1])
        end_dir = seg[-1] / self._seg_len[-1]
        self.end: Vec2 = (float(self.points[-1, 0]), float(self.points[-1, 1]))
        self.end_direction: Vec2 = (float(end_dir[0]), float(end_dir[1]))
        self.progress_mm = 0.0

    # -- geometry --------------------------------------------------------------------------

    def _closest(self, xy: Vec2, lo_mm: float, hi_mm: float) -> float:
        """Arc length of the path point closest to ``xy`` among segments in [lo_mm, hi_mm].

        Called every control cycle: few NumPy calls, in place where possible (the same
        arithmetic, so the same result, as the plain expressions)."""
        first = max(0, bisect.bisect_right(self._cum_list, lo_mm) - 1)
        last = min(len(self._seg), bisect.bisect_right(self._cum_list, hi_mm))
        last = max(last, first + 1)
        starts = self.points[first:last]
        seg = self._seg[first:last]
        p = np.array(xy, dtype=float)
        u = np.einsum("ij,ij->i", p - starts, seg)
        u /= self._seg_len2[first:last]
        # np.clip(u, 0, 1, out=u), without np.clip's Python-level wrapper (~3 µs a call): the
        # same max-then-min per element (u is never NaN: no segment has zero length).
        np.maximum(u, 0.0, out=u)
        np.minimum(u, 1.0, out=u)
        d = u[:, None] * seg  # foot of the perpendicular − xy: starts + u·seg − xy
        d += starts
        d -= p
        k = int(np.einsum("ij,ij->i", d, d).argmin())
        return float(self._cum_list[first + k] + u[k] * self._seg_len[first + k])

    def point_at(self, s_mm: float) -> Vec2:
        """The path point at arc length ``s_mm``; beyond the end, on the end tangent's extension."""
        if s_mm >= self.length_mm:
            extra = s_mm - self.length_mm
            return (self.end[0] + extra * self.end_direction[0],
                    self.end[1] + extra * self.end_direction[1])
        s = max(0.0, s_mm)
        i = min(bisect.bisect_right(self._cum_list, s) - 1, len(self._seg) - 1)
        # On Python floats (.item(): the same float64 values, and the same arithmetic as the
        # arrays' element-wise ops) without NumPy's cost per scalar operation: every cycle.
        # (Lists made once per path would cost ~35 µs in the tick that plans the bypass.)
        points, seg = self.points, self._seg
        u = (s - self._cum_list[i]) / self._seg_len.item(i)
        return (points.item(i, 0) + u * seg.item(i, 0), points.item(i, 1) + u * seg.item(i, 1))

    def distance_to_end_line(self, pose: Pose) -> float:
        """Signed distance (mm) from the pose to the end's normal line, positive before it."""
        return ((self.end[0] - pose.x) * self.end_direction[0]
                + (self.end[1] - pose.y) * self.end_direction[1])

    # -- control ---------------------------------------------------------------------------

    def finished(self, pose: Pose) -> bool:
        """The end is reached: within ``goal_tolerance_mm`` of it, or past its normal line
        while the nearest path point is within one look-ahead of the end. Does not change state.
        """
        if math.hypot(pose.x - self.end[0], pose.y - self.end[1]) <= self.goal_tolerance_mm:
            return True
        if self.distance_to_end_line(pose) > 0.0:
            return False
        near_end = self._closest(pose.xy, 0.0, self.length_mm)
        return near_end >= self.length_mm - self.lookahead_mm

    def lookahead_point(self, pose: Pose) -> Vec2:
        """The point one look-ahead beyond the robot's progress (advances the progress)."""
        window = max(3.0 * self.lookahead_mm, 300.0)
        s = self._closest(pose.xy, self.progress_mm, self.progress_mm + window)
        self.progress_mm = max(self.progress_mm, s)
        return self.point_at(self.progress_mm + self.lookahead_mm)

    def target_speed(self, pose: Pose) -> float:
        """Centre speed for this cycle: cruising, ramped down linearly over the last stretch."""
        remaining = max(self.length_mm - self.progress_mm, 0.0)
        remaining = min(remaining, max(self.distance_to_end_line(pose), 0.0))
        if self.slowdown_mm == 0.0 or remaining >= self.slowdown_mm:
            return self.speed_mm_s
        return max(self.min_speed_mm_s, self.speed_mm_s * remaining / self.slowdown_mm)

    def command(self, pose: Pose) -> WheelSpeeds:
        """Wheel speeds for this cycle from the pose estimate; zero once :meth:`finished`."""
        if self.finished(pose):
            return _STOP
        target = self.lookahead_point(pose)
        robot_frame = to_robot_frame(pose, target)
        if robot_frame == (0.0, 0.0):
            return _STOP
        return wheel_speeds_for_curvature(
            self.target_speed(pose),
            arc_curvature(robot_frame),
            wheel_base_mm=self.wheel_base_mm,
            max_wheel_mm_s=self.max_wheel_mm_s,
        )


def open_loop_wheel_steps(
    path: BypassPlan | Sequence[QuadraticBezier],
    start: Pose,
    *,
    speed_mm_s: float,
    wheel_base_mm: float,
    max_wheel_mm_s: float,
    steps_per_curve: int = 20,
) -> list[ArcStep]:
    """The paper's open-loop stepping along the curves, with exact arc steps.

    Each curve's parameter range is cut into ``steps_per_curve`` equal steps Δt (§4.6); each step
    drives the arc tangent to the *believed* heading through the next curve point C(t + Δt), for
    the time the arc takes at ``speed_mm_s`` (eq. 24 with the arc length). The believed pose is
    then advanced with the same speeds (eqs. 37–39, integrated exactly), never measured. Returns
    the steps to play back in order; with perfect wheels they end exactly on the curve's end.
    """
    if steps_per_curve < 1:
        raise ValueError(f"steps_per_curve must be at least 1, got {steps_per_curve}")
    curves = list(path.curves) if isinstance(path, BypassPlan) else list(path)
    believed = start
    steps: list[ArcStep] = []
    for curve in curves:
        for k in range(1, steps_per_curve + 1):
            target = curve.point(k / steps_per_curve)
            step = arc_step(
                believed, target, speed_mm_s=speed_mm_s,
                wheel_base_mm=wheel_base_mm, max_wheel_mm_s=max_wheel_mm_s,
            )
            if step.duration_s == 0.0:
                continue
            steps.append(step)
            believed = integrate_pose(
                believed, left=step.speeds.left, right=step.speeds.right,
                dt=step.duration_s, wheel_base_mm=wheel_base_mm,
            )
    return steps


def open_loop_command(steps: Sequence[ArcStep], elapsed_s: float) -> WheelSpeeds | None:
    """Speeds to hold ``elapsed_s`` seconds after starting to play ``steps``; ``None`` when done.

    Lets a fixed-rate control loop play back :func:`open_loop_wheel_steps` by the clock.
    """
    t = 0.0
    for step in steps:
        t += step.duration_s
        if elapsed_s < t:
            return step.speeds
    return None
