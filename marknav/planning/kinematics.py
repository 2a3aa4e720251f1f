"""Differential-drive kinematics (paper §4.6, eqs. 25–30 and 35–36), as pure functions.

Frames and units follow ``docs/architecture.md``: world frame x east, y north, heading θ
counter-clockwise from +x; robot frame x forward, y to the left; millimetres, radians, seconds.
``d`` in the paper is *half* the wheel base (eq. 27: v_φ = (v_R − v_L) / 2d).

- :func:`body_velocity` — eqs. 25–27 (centre speed and turn rate from the wheel speeds).
- :func:`integrate_pose` — eqs. 28–30 integrated exactly over a step with constant wheel speeds
  (a circular arc), not the paper's first-order Euler step.
- :func:`arc_curvature` / :func:`wheel_speeds_for_curvature` / :func:`wheel_speeds_to_point` —
  the well-posed replacement for eqs. 31–36: the arc tangent to the heading through the next point,
  κ = 2·y_r / (x_r² + y_r²), v_L = v(1 − κd), v_R = v(1 + κd).
- :func:`arc_step` — one exact open-loop step to a point: wheel speeds and duration.
- :func:`paper_wheel_speeds` — eqs. 24, 31, 35, 36 exactly as printed (ill-posed: divides by
  cos φ0, which is 0 at the paper's own start heading φ0 = π/2). Kept for comparison only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = [
    "ArcStep",
    "Pose",
    "WheelSpeeds",
    "arc_curvature",
    "arc_step",
    "body_velocity",
    "integrate_pose",
    "paper_wheel_speeds",
    "scale_to_limit",
    "to_robot_frame",
    "to_world_frame",
    "wheel_speeds_for_curvature",
    "wheel_speeds_to_point",
    "wrap_angle",
]

#: Below this bearing (rad) an arc step is treated as straight (α/sin α = 1 to 1e-18).
_STRAIGHT_EPS = 1e-9


@dataclass(frozen=True)
class Pose:
    """Robot pose in the world frame: position (mm) and heading θ (rad, CCW from +x)."""

    x: float
    y: float
    theta: float

    @property
    def xy(self) -> tuple[float, float]:
        """The position as an ``(x, y)`` tuple (mm)."""
        return (self.x, self.y)

    @property
    def heading(self) -> tuple[float, float]:
        """Unit vector of the heading, h = (cos θ, sin θ)."""
        return (math.cos(self.theta), math.sin(self.theta))

    @property
    def left_normal(self) -> tuple[float, float]:
        """Unit vector to the robot's left, n = (−sin θ, cos θ)."""
        return (-math.sin(self.theta), math.cos(self.theta))


@dataclass(frozen=True, kw_only=True)
class WheelSpeeds:
    """Wheel speeds in mm/s, positive forward. Keyword-only: ``WheelSpeeds(left=…, right=…)``."""

    left: float
    right: float

    @property
    def linear(self) -> float:
        """Speed of the robot centre, (v_L + v_R) / 2 (eqs. 25–26), mm/s."""
        return 0.5 * (self.left + self.right)

    @property
    def max_abs(self) -> float:
        """The larger wheel speed magnitude, mm/s."""
        return max(abs(self.left), abs(self.right))

    def scaled(self, factor: float) -> WheelSpeeds:
        """Both wheels multiplied by one factor (the driven curvature is unchanged)."""
        return WheelSpeeds(left=self.left * factor, right=self.right * factor)


@dataclass(frozen=True)
class ArcStep:
    """One open-loop step: constant wheel speeds held for ``duration_s`` seconds."""

    speeds: WheelSpeeds
    duration_s: float


def wrap_angle(angle: float) -> float:
    """Wrap an angle (rad) to the half-open interval (−π, π]."""
    wrapped = math.remainder(angle, math.tau)  # in [−π, π]
    if wrapped <= -math.pi:
        wrapped += math.tau
    return wrapped


def body_velocity(*, left: float, right: float, wheel_base_mm: float) -> tuple[float, float]:
    """Centre speed v (mm/s) and turn rate ω (rad/s) from wheel speeds (eqs. 25–27).

    v = (v_L + v_R) / 2, ω = (v_R − v_L) / 2d with d = wheel_base_mm / 2.
    """
    _check_wheel_base(wheel_base_mm)
    return 0.5 * (left + right), (right - left) / wheel_base_mm


def integrate_pose(
    pose: Pose, *, left: float, right: float, dt: float, wheel_base_mm: float
) -> Pose:
    """Pose after holding the wheel speeds for ``dt`` seconds: eqs. 25–30 integrated exactly.

    With constant wheel speeds the robot drives a circular arc (or a straight line, or spins in
    place). With Δθ = ω·dt the exact displacement is v·dt·sinc(Δθ/2) along the mean heading
    θ + Δθ/2, which reduces to eqs. 28–29 when Δθ → 0.
    """
    if dt < 0.0:
        raise ValueError(f"dt must be non-negative, got {dt}")
    v, omega = body_velocity(left=left, right=right, wheel_base_mm=wheel_base_mm)
    dtheta = omega * dt
    half = 0.5 * dtheta
    # chord = v·dt·sin(half)/half; series below the threshold avoids 0/0.
    sinc = 1.0 - half * half / 6.0 if abs(half) < 1e-4 else math.sin(half) / half
    chord = v * dt * sinc
    mean_heading = pose.theta + half
    return Pose(
        pose.x + chord * math.cos(mean_heading),
        pose.y + chord * math.sin(mean_heading),
        wrap_angle(pose.theta + dtheta),
    )


def to_robot_frame(pose: Pose, point: tuple[float, float]) -> tuple[float, float]:
    """World point → robot frame ``(forward, left)`` in mm (REP 103: x forward, y left)."""
    dx = point[0] - pose.x
    dy = point[1] - pose.y
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    return (c * dx + s * dy, -s * dx + c * dy)


def to_world_frame(pose: Pose, point: tuple[float, float]) -> tuple[float, float]:
    """Robot-frame ``(forward, left)`` (mm) → world ``(x, y)``: inverse of ``to_robot_frame``."""
    forward, left = point
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    return (pose.x + c * forward - s * left, pose.y + s * forward + c * left)


def arc_curvature(point_robot: tuple[float, float]) -> float:
    """Curvature (1/mm, positive = left turn) of the arc tangent to the heading through a point.

    κ = 2·y_r / (x_r² + y_r²) for the point (x_r, y_r) in the robot frame: the circle through the
    robot, tangent to its heading, with its centre on the robot's y axis. Well-posed for every
    heading (it replaces eqs. 31–36). Raises ``ValueError`` for the robot's own position.
    """
    x_r, y_r = point_robot
    r2 = x_r * x_r + y_r * y_r
    if r2 == 0.0:
        raise ValueError("the target point is the robot's own position: no arc through it")
    return 2.0 * y_r / r2


def scale_to_limit(speeds: WheelSpeeds, max_wheel_mm_s: float) -> WheelSpeeds:
    """Scale both wheels by one factor so that neither exceeds ``max_wheel_mm_s``.

    Clamping one wheel alone would change the curve being driven; a common factor keeps the
    curvature (v_R − v_L) / (d·(v_L + v_R)) unchanged.
    """
    if not max_wheel_mm_s > 0.0:
        raise ValueError(f"max_wheel_mm_s must be positive, got {max_wheel_mm_s}")
    peak = speeds.max_abs
    if peak <= max_wheel_mm_s:
        return speeds
    return speeds.scaled(max_wheel_mm_s / peak)


def wheel_speeds_for_curvature(
    speed_mm_s: float, curvature: float, *, wheel_base_mm: float, max_wheel_mm_s: float
) -> WheelSpeeds:
    """Wheel speeds that drive curvature κ at centre speed v: v_L = v(1 − κd), v_R = v(1 + κd).

    d = wheel_base_mm / 2 (eq. 27). If a wheel would exceed ``max_wheel_mm_s`` both are scaled by
    one factor (:func:`scale_to_limit`), so the curvature is kept and only the speed drops.
    """
    half_base = 0.5 * _check_wheel_base(wheel_base_mm)
    raw = WheelSpeeds(
        left=speed_mm_s * (1.0 - curvature * half_base),
        right=speed_mm_s * (1.0 + curvature * half_base),
    )
    return scale_to_limit(raw, max_wheel_mm_s)


def wheel_speeds_to_point(
    pose: Pose,
    target: tuple[float, float],
    *,
    speed_mm_s: float,
    wheel_base_mm: float,
    max_wheel_mm_s: float,
) -> WheelSpeeds:
    """Wheel speeds that drive the arc tangent to the heading through a world ``target``.

    The well-posed form of eqs. 31–36: target in the robot frame, κ from :func:`arc_curvature`,
    wheels from :func:`wheel_speeds_for_curvature`. Finite at every heading, including π/2.
    """
    kappa = arc_curvature(to_robot_frame(pose, target))
    return wheel_speeds_for_curvature(
        speed_mm_s, kappa, wheel_base_mm=wheel_base_mm, max_wheel_mm_s=max_wheel_mm_s
    )


def arc_step(
    pose: Pose,
    target: tuple[float, float],
    *,
    speed_mm_s: float,
    wheel_base_mm: float,
    max_wheel_mm_s: float,
) -> ArcStep:
    """One exact step to ``target``: the arc tangent to the heading, its wheel speeds and duration.

    The arc through the target turns the heading by 2α (α = bearing of the target), not α as
    eq. 31 assumes; its length is s = chord·α / sin α (eq. 24 with the arc instead of the chord).
    The duration is s / v where v is the centre speed after wheel-limit scaling, so holding
    ``speeds`` for ``duration_s`` (:func:`integrate_pose`) lands exactly on the target.
    Raises ``ValueError`` for a target behind the robot (|α| ≥ π/2: the arc would loop back).
    """
    if not speed_mm_s > 0.0:
        raise ValueError(f"speed_mm_s must be positive, got {speed_mm_s}")
    x_r, y_r = to_robot_frame(pose, target)
    chord = math.hypot(x_r, y_r)
    if chord == 0.0:
        return ArcStep(WheelSpeeds(left=0.0, right=0.0), 0.0)
    alpha = math.atan2(y_r, x_r)
    if abs(alpha) >= 0.5 * math.pi:
        raise ValueError(
            f"target is not ahead of the robot (bearing {math.degrees(alpha):.1f} deg): "
            "an arc step needs |bearing| < 90 deg"
        )
    arc_len = chord if abs(alpha) < _STRAIGHT_EPS else chord * alpha / math.sin(alpha)
    speeds = wheel_speeds_for_curvature(
        speed_mm_s, arc_curvature((x_r, y_r)),
        wheel_base_mm=wheel_base_mm, max_wheel_mm_s=max_wheel_mm_s,
    )
    return ArcStep(speeds, arc_len / speeds.linear)


def paper_wheel_speeds(
    pose: Pose, target: tuple[float, float], *, v_max_mm_s: float, wheel_base_mm: float
) -> WheelSpeeds:
    """The paper's wheel speeds for one step, eqs. 24, 31, 35, 36 *exactly as printed*.

    Δt_r = chord / v_max (24); φ_T = atan2(y_T − y_0, x_T − x_0) (31);
    v_L = [(x_T − x_0)/cos φ0 − d(φ_T − φ0)] / Δt_r (35); v_R = 2d(φ_T − φ0)/Δt_r + v_L (36).

    Ill-posed: eq. 35 divides by cos φ0, which is 0 at the paper's start heading φ0 = π/2. In
    floating point cos(π/2) ≈ 6.1e-17, so a step with any sideways component commands wheel
    speeds of order 1e16 mm/s (or inf/nan) instead of failing. Eq. 31 also takes the chord's
    direction as the new heading, while an arc through the point turns the heading by twice that.
    Kept only to document and test the failure; use :func:`wheel_speeds_to_point`.
    """
    d = 0.5 * _check_wheel_base(wheel_base_mm)
    dx = target[0] - pose.x
    dy = target[1] - pose.y
    dt_r = math.hypot(dx, dy) / v_max_mm_s  # eq. 24
    phi_t = math.atan2(dy, dx)  # eq. 31
    dphi = phi_t - pose.theta
    with_inf = _ieee_div  # keep IEEE semantics (inf/nan) instead of ZeroDivisionError
    v_left = with_inf(with_inf(dx, math.cos(pose.theta)) - d * dphi, dt_r)  # eq. 35
    v_right = with_inf(2.0 * d * dphi, dt_r) + v_left  # eq. 36
    return WheelSpeeds(left=v_left, right=v_right)


def _ieee_div(num: float, den: float) -> float:
    """num / den with IEEE-754 results for a zero denominator (±inf, nan) instead of raising."""
    if den != 0.0:
        return num / den
    if num == 0.0 or math.isnan(num):
        return math.nan
    return math.copysign(math.inf, num) * math.copysign(1.0, den)


def _check_wheel_base(wheel_base_mm: float) -> float:
    if not wheel_base_mm > 0.0:
        raise ValueError(f"wheel_base_mm must be positive, got {wheel_base_mm}")
    return wheel_base_mm
