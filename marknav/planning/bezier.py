"""Quadratic Bézier curves (paper §4.6, eqs. 22–23) and the bypass of a mark built from them.

The paper plans one quadratic Bézier C(t) = (1−t)²P0 + 2(1−t)t·P1 + t²P2 (eq. 22/23) whose end
lies beside the mark. A single quadratic that starts tangent to the heading and ends exactly
beside the mark comes closer than the clearance just before its end, so the bypass here is two
quadratics joined with a common tangent (G1, in fact C1):

    C1 = (P0, P0 + a1·h, Q),  C2 = (Q, W − a2·h, W),  Q = midpoint of P0 + a1·h and W − a2·h,
    W  = M + σ·D·n,

with h the robot's heading, n its left normal, M the mark, D the clearance (robot centre to mark
centre) and σ = +1 when the robot passes on the mark's LEFT (side ``"left"``: the mark ends on the
robot's right), −1 for ``"right"``. The plan starts at the robot tangent to its heading and ends at
W parallel to it, at exactly D from the mark on the required side. (When re-planning mid-bypass a
``course`` may replace h and n at the end, so the plan still ends parallel to the original
direction.) The control distances a1, a2 are searched as fractions of the along-course distance
to the mark: the lowest peak curvature that keeps the clearance wins (a1 = a2 ≈ L/4 when the
room allows; the field notes' a = 300 mm for a mark 1 m ahead is one such feasible choice).

The true minimum distance from a curve to the mark comes from the closest-point cubic: with
A = P1 − P0, B = P0 − 2P1 + P2 and M' = P0 − M, the stationary points of |C(t) − M|² solve
(B·B)t³ + 3(A·B)t² + (2A·A + M'·B)t + M'·A = 0; the minimum is over its real roots in [0, 1] and
both ends (B = 0 is a straight segment). No sampling is involved in planning.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Literal, NamedTuple

import numpy as np
import numpy.typing as npt

from marknav.planning.kinematics import Pose, wrap_angle

__all__ = [
    "BypassPlan",
    "ClosestPoint",
    "PlanningError",
    "QuadraticBezier",
    "Side",
    "Vec2",
    "closest_point",
    "curves_length",
    "min_distance",
    "passed",
    "plan_bypass",
    "sample_curves",
    "side_sign",
]

Vec2 = tuple[float, float]
Side = Literal["left", "right"]
FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


class PlanningError(ValueError):
    """The bypass geometry is impossible; the message says why (a ``ValueError``)."""


@dataclass(frozen=True)
class QuadraticBezier:
    """A quadratic Bézier curve C(t) = (1−t)²p0 + 2(1−t)t·p1 + t²p2, t ∈ [0, 1] (eq. 22/23)."""

    p0: Vec2
    p1: Vec2
    p2: Vec2

    def _arrays(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        return (np.asarray(self.p0, float), np.asarray(self.p1, float), np.asarray(self.p2, float))

    def point(self, t: float) -> Vec2:
        """C(t), eq. 23."""
        u = 1.0 - t
        a, b, c = u * u, 2.0 * u * t, t * t
        return (
            a * self.p0[0] + b * self.p1[0] + c * self.p2[0],
            a * self.p0[1] + b * self.p1[1] + c * self.p2[1],
        )

    def points(self, ts: npt.ArrayLike) -> FloatArray:
        """C(t) for an array of parameters: an ``(n, 2)`` array."""
        t = np.asarray(ts, float).reshape(-1, 1)
        p0, p1, p2 = self._arrays()
        u = 1.0 - t
        return np.asarray(u * u * p0 + 2.0 * u * t * p1 + t * t * p2, dtype=np.float64)

    def derivative(self, t: float) -> Vec2:
        """C'(t) = 2(1−t)(p1 − p0) + 2t(p2 − p1)."""
        u = 1.0 - t
        return (
            2.0 * (u * (self.p1[0] - self.p0[0]) + t * (self.p2[0] - self.p1[0])),
            2.0 * (u * (self.p1[1] - self.p0[1]) + t * (self.p2[1] - self.p1[1])),
        )

    def curvature(self, t: float) -> float:
        """Signed curvature at t (1/mm, positive = turning left): cross(C', C'') / |C'|³."""
        dx, dy = self.derivative(t)
        ddx, ddy = self._second_derivative()
        speed = math.hypot(dx, dy)
        if speed == 0.0:
            return math.inf if (ddx, ddy) != (0.0, 0.0) else 0.0
        return (dx * ddy - dy * ddx) / speed / speed / speed  # no underflow of speed³ to 0

    def max_abs_curvature(self) -> float:
        """Peak |curvature| over t ∈ [0, 1], exactly.

        cross(C', C'') = 4·cross(A, B) is constant on a quadratic, so |κ| peaks where |C'| is
        least: at t* = −(A·B)/(B·B) clamped to [0, 1].
        """
        ax, ay = self.p1[0] - self.p0[0], self.p1[1] - self.p0[1]
        bx = self.p0[0] - 2.0 * self.p1[0] + self.p2[0]
        by = self.p0[1] - 2.0 * self.p1[1] + self.p2[1]
        bb = bx * bx + by * by
        t_star = 0.0 if bb == 0.0 else min(1.0, max(0.0, -(ax * bx + ay * by) / bb))
        return abs(self.curvature(t_star))

    def _second_derivative(self) -> Vec2:
        return (
            2.0 * (self.p0[0] - 2.0 * self.p1[0] + self.p2[0]),
            2.0 * (self.p0[1] - 2.0 * self.p1[1] + self.p2[1]),
        )

    def length(self) -> float:
        """Arc length ∫₀¹|C'(t)|dt in closed form.

        C'(t) = 2(A + tB), so |C'| = 2|B|·sqrt(τ² + k) with τ = t + (A·B)/(B·B) and
        k = (A × B)² / (B·B)²; ∫ sqrt(τ² + k) dτ = ½[τ·sqrt(τ² + k) + k·asinh(τ/√k)]. Exact for
        cusps (k = 0) and backtracking curves; B = 0 is the straight segment 2|A|. A B that is
        rounding error beside A (|B| ≤ 1e-8·|A|: P1 at the chord's middle, computed in floats)
        is taken as 0 too: the closed form divides by B·B and would cancel catastrophically,
        while the straight segment is then exact to a part in 10¹⁶.
        """
        ax, ay = self.p1[0] - self.p0[0], self.p1[1] - self.p0[1]
        bx = self.p0[0] - 2.0 * self.p1[0] + self.p2[0]
        by = self.p0[1] - 2.0 * self.p1[1] + self.p2[1]
        bb = bx * bx + by * by
        if bb <= 1e-16 * (ax * ax + ay * ay):
            return 2.0 * math.hypot(ax, ay)
        shift = (ax * bx + ay * by) / bb
        k = ((ax * by - ay * bx) / bb) ** 2

        def antiderivative(tau: float) -> float:
            root = math.sqrt(tau * tau + k)
            return 0.5 * (tau * root + (k * math.asinh(tau / math.sqrt(k)) if k > 0.0 else 0.0))

        return 2.0 * math.sqrt(bb) * (antiderivative(1.0 + shift) - antiderivative(shift))

    def closest_point(self, point: Vec2) -> ClosestPoint:
        """The point of the curve nearest to ``point``: see :func:`closest_point`."""
        return closest_point(self, point)


class ClosestPoint(NamedTuple):
    """Result of :func:`closest_point`: the parameter, the curve point and its distance."""

    t: float
    point: Vec2
    distance: float


def closest_point(curve: QuadraticBezier, point: Vec2) -> ClosestPoint:
    """Nearest point of a quadratic Bézier to ``point`` from the closest-point cubic.

    With A = P1 − P0, B = P0 − 2P1 + P2, M' = P0 − M, d/dt |C(t) − M|² = 0 reads
    (B·B)t³ + 3(A·B)t² + (2A·A + M'·B)t + M'·A = 0. Candidates are both ends and every root
    (real part, clamped to [0, 1], plus one Newton polish). Each candidate is a point of the
    curve, so a spurious candidate can never undercut the minimum; the true minimiser is a real
    root or an end, so the result is exact to rounding. B = 0 (a straight, uniformly
    parametrised segment: the cubic drops to 2(A·A)t + M'·A = 0) and a degenerate curve (a
    single point) are handled explicitly.
    """
    p = np.asarray([curve.p0, curve.p1, curve.p2], float).reshape(1, 3, 2)
    t, dist = _closest_batch(p, np.asarray(point, float))
    t0 = float(t[0])
    return ClosestPoint(t0, curve.point(t0), float(dist[0]))


def _closest_batch(ctrl: FloatArray, point: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Closest-point cubic for many curves at once: ``ctrl`` is ``(n, 3, 2)``; returns (t, dist).

    Roots come from the eigenvalues of the cubic's companion matrices (what ``numpy.roots``
    does, batched). Rows whose B·B is negligible (B = 0 is a straight segment) solve the
    remaining quadratic or linear equation instead. Every candidate is polished once by Newton
    on the full cubic and evaluated on the curve, so extra candidates cannot undercut the minimum.
    """
    p0, p1, p2 = ctrl[:, 0], ctrl[:, 1], ctrl[:, 2]
    a = p1 - p0
    b = p0 - 2.0 * p1 + p2
    m = p0 - point
    c3 = np.einsum("ij,ij->i", b, b)
    c2 = 3.0 * np.einsum("ij,ij->i", a, b)
    c1 = 2.0 * np.einsum("ij,ij->i", a, a) + np.einsum("ij,ij->i", m, b)
    c0 = np.einsum("ij,ij->i", m, a)
    n = ctrl.shape[0]
    # A cubic whose leading coefficient is negligible has one root far outside [0, 1]; its
    # other roots are those of the remaining quadratic (then polished on the full cubic).
    cubic = c3 > 1e-12 * (np.abs(c2) + np.abs(c1) + np.abs(c0))
    roots = np.zeros((n, 3))
    with np.errstate(all="ignore"):
        if np.any(cubic):
            k = int(np.count_nonzero(cubic))
            comp = np.zeros((k, 3, 3))
            comp[:, 0, 0] = -c2[cubic] / c3[cubic]
            comp[:, 0, 1] = -c1[cubic] / c3[cubic]
            comp[:, 0, 2] = -c0[cubic] / c3[cubic]
            comp[:, 1, 0] = 1.0
            comp[:, 2, 1] = 1.0
            roots[cubic] = np.linalg.eigvals(comp).real
        flat = ~cubic
        if np.any(flat):
            q2, q1, q0 = c2[flat], c1[flat], c0[flat]
            disc = np.maximum(q1 * q1 - 4.0 * q2 * q0, 0.0)
            q = -0.5 * (q1 + np.copysign(np.sqrt(disc), q1))
            roots[flat] = np.column_stack([q / q2, q0 / q, -q1 / (2.0 * q2)])
        # Straight segments (B = 0): 2(A·A)t + M'·A = 0; a harmless extra candidate elsewhere.
        linear = np.where(c1 != 0.0, -c0 / c1, 0.0)
    raw = np.clip(np.nan_to_num(np.column_stack([roots, linear]), nan=0.0), 0.0, 1.0)
    # One Newton polish of every candidate (kept alongside the raw one).
    with np.errstate(all="ignore"):
        value = ((c3[:, None] * raw + c2[:, None]) * raw + c1[:, None]) * raw + c0[:, None]
        slope = (3.0 * c3[:, None] * raw + 2.0 * c2[:, None]) * raw + c1[:, None]
        polished = np.where(slope != 0.0, raw - value / slope, raw)
    polished = np.clip(np.nan_to_num(polished, nan=0.0), 0.0, 1.0)
    ts = np.column_stack([np.zeros(n), np.ones(n), raw, polished])  # (n, 10)
    u = 1.0 - ts
    pts = (
        (u * u)[:, :, None] * p0[:, None, :]
        + (2.0 * u * ts)[:, :, None] * p1[:, None, :]
        + (ts * ts)[:, :, None] * p2[:, None, :]
    )
    dist = np.hypot(pts[:, :, 0] - point[0], pts[:, :, 1] - point[1])
    best = np.argmin(dist, axis=1)
    rows = np.arange(n)
    return ts[rows, best], dist[rows, best]


def min_distance(curves: Iterable[QuadraticBezier], point: Vec2) -> float:
    """Exact minimum distance from ``point`` to a chain of quadratic Béziers."""
    return min(closest_point(c, point).distance for c in curves)


def curves_length(curves: Iterable[QuadraticBezier]) -> float:
    """Total arc length of a chain of curves (mm)."""
    return sum(c.length() for c in curves)


def sample_curves(curves: Sequence[QuadraticBezier], step_mm: float) -> FloatArray:
    """Points along a chain of curves about ``step_mm`` apart in arc length: an ``(n, 2)`` array.

    Each curve is sampled at parameters equally spaced in arc length (the speed |C'(t)| is
    integrated on a fine grid and inverted), the first point is the chain's start and the last
    its end. For drawing and for trackers; never used to check clearance.
    """
    if not step_mm > 0.0:
        raise ValueError(f"step_mm must be positive, got {step_mm}")
    if not curves:
        raise ValueError("no curves to sample")
    chunks: list[FloatArray] = [np.asarray([curves[0].p0], float)]
    for curve in curves:
        rough = curve.length()
        fine_t = np.linspace(0.0, 1.0, int(min(max(257, 64 * rough / step_mm + 1), 200_001)))
        fine = curve.points(fine_t)
        seg = np.hypot(*np.diff(fine, axis=0).T)
        cum = np.concatenate(([0.0], np.cumsum(seg)))
        n = max(1, math.ceil(cum[-1] / step_mm - 1e-9))
        targets = np.linspace(0.0, cum[-1], n + 1)[1:]
        ts = np.interp(targets, cum, fine_t) if cum[-1] > 0.0 else np.ones(1)
        ts[-1] = 1.0
        chunks.append(curve.points(ts))
    return np.vstack(chunks)


# --------------------------------------------------------------------------------------------
# The bypass plan
# --------------------------------------------------------------------------------------------

#: Coarse and fine grids of control distances, as fractions of the along-course distance L.
_COARSE_FRACTIONS = np.round(np.arange(0.05, 0.951, 0.05), 10)
_FINE_OFFSETS = np.round(np.arange(-0.04, 0.0401, 0.01), 10)
_MIN_FRACTION = 0.02
#: Relative rounding allowance when checking that a candidate keeps the clearance (the curve ends
#: at exactly D from the mark, so the check must not reject |W − M| = D ± a few ulps).
_CLEARANCE_RTOL = 1e-9
#: Rounding allowance of :func:`passed` (mm).
_BESIDE_TOL_MM = 1e-6


@dataclass(frozen=True)
class BypassPlan:
    """A planned bypass: two tangent-joined quadratic Béziers from the robot to beside the mark.

    ``curves`` run from ``start_pose`` (tangent to its heading) to ``end_pose`` (at distance
    ``clearance_mm`` from ``mark_xy`` on ``side``, heading along the course).
    ``control_distances_mm`` are the (a1, a2) used: C1 = (P0, P0 + a1·h, Q),
    C2 = (Q, W − a2·h_c, W). To re-plan from a new pose and a new mark estimate, call
    :func:`plan_bypass` again (pass ``course=plan.course`` to keep the original direction).
    """

    curves: tuple[QuadraticBezier, ...]
    start_pose: Pose
    end_pose: Pose
    mark_xy: Vec2
    clearance_mm: float
    side: Side
    control_distances_mm: tuple[float, float]

    @property
    def course(self) -> float:
        """Direction of travel the plan ends on (rad); the heading the bypass was planned for."""
        return self.end_pose.theta

    @property
    def length_mm(self) -> float:
        """Arc length of the whole plan (mm)."""
        return curves_length(self.curves)

    @property
    def min_clearance_mm(self) -> float:
        """Exact minimum distance from the plan to the mark centre (closest-point cubic)."""
        return self.min_distance_to(self.mark_xy)

    @property
    def max_curvature(self) -> float:
        """Peak |curvature| along the plan (1/mm)."""
        return max(c.max_abs_curvature() for c in self.curves)

    def min_distance_to(self, point: Vec2) -> float:
        """Exact minimum distance from ``point`` to the plan (mm)."""
        return min_distance(self.curves, point)

    def sample(self, step_mm: float) -> FloatArray:
        """Points along the plan about ``step_mm`` apart: an ``(n, 2)`` array (for drawing)."""
        return sample_curves(self.curves, step_mm)

    def passed(self, pose: Pose) -> bool:
        """Whether the mark is beside or behind ``pose`` along the plan's course."""
        return passed(pose, self.mark_xy, self.course)


def passed(pose: Pose, mark_xy: Vec2, heading_at_plan: float) -> bool:
    """The mark is beside or behind the robot: its along-track coordinate ≤ 0.

    The along-track coordinate is (M − P)·h with h = (cos, sin) of ``heading_at_plan`` (the
    course the bypass was planned for, not the robot's current heading, which swerves).
    "Beside" allows 1e-6 mm of rounding, so a plan's own end pose counts as passed.
    """
    hx, hy = math.cos(heading_at_plan), math.sin(heading_at_plan)
    return (mark_xy[0] - pose.x) * hx + (mark_xy[1] - pose.y) * hy <= _BESIDE_TOL_MM


def side_sign(side: Side) -> float:
    """σ of the construction: +1 for ``"left"`` (pass on the mark's left), −1 for ``"right"``."""
    if side == "left":
        return 1.0
    if side == "right":
        return -1.0
    raise PlanningError(f"side must be 'left' or 'right', got {side!r}")


def plan_bypass(
    pose: Pose,
    mark_xy: Vec2,
    *,
    mark_radius_mm: float,
    clearance_mm: float,
    side: Side,
    course: float | None = None,
    control_distance_mm: float | None = None,
    min_turn_radius_mm: float = 100.0,
) -> BypassPlan:
    """Plan the bypass of a mark as two tangent-joined quadratic Béziers (see module docstring).

    Args:
        pose: robot pose (world frame); the plan starts here, tangent to ``pose.theta``.
        mark_xy: estimated mark centre (world frame, mm).
        mark_radius_mm: physical radius of the mark; the clearance must exceed it.
        clearance_mm: D, distance kept between the robot centre and the mark centre.
        side: ``"left"`` passes on the mark's left (mark ends on the robot's right), ``"right"``
            the other way (docs/architecture.md).
        course: direction the plan ends on (rad); defaults to the robot's heading. Pass the
            original plan's course when re-planning mid-bypass.
        control_distance_mm: force a1 = a2 = this value instead of searching.
        min_turn_radius_mm: refuse plans whose tightest turn is smaller (0 disables).

    The control distances are chosen as fractions of the along-course distance L to the mark:
    every pair (a1, a2) = (f1·L, f2·L) on a grid (f1 + f2 ≤ 1, so the curves never double back)
    is checked with the exact closest-point cubic, and the one with the lowest peak curvature
    among those that keep the clearance wins; a finer grid around it follows. For a mark
    straight ahead that is a1 = a2 ≈ 0.25–0.3·L whenever that keeps the clearance (a = L/4 makes
    the along-course coordinate linear in t: each half is then a parabola); closer marks get a
    longer straight run-in beside the mark (a2 > a1). Ties go to the pair nearest (L/4, L/4).

    Raises:
        PlanningError: bad arguments (non-finite, clearance ≤ 0 or ≤ mark radius, unknown side),
            the mark behind or beside the robot, the robot already within the clearance, the
            heading more than 90° off the course, or the mark too close ahead to swerve with the
            clearance (no candidate keeps it within the turn-radius limit).
    """
    _check_inputs(pose, mark_xy, mark_radius_mm, clearance_mm, course, min_turn_radius_mm)
    sigma = side_sign(side)
    course_theta = wrap_angle(pose.theta if course is None else course)
    hc = np.array([math.cos(course_theta), math.sin(course_theta)])
    nc = np.array([-hc[1], hc[0]])
    h0 = np.array([math.cos(pose.theta), math.sin(pose.theta)])
    p0 = np.array(pose.xy)
    mark = np.array(mark_xy, float)
    rel = mark - p0
    along = float(rel @ hc)
    lateral = float(rel @ nc)
    dist_now = float(np.hypot(*rel))
    side_word = f"on its {side}"

    off_course = abs(wrap_angle(pose.theta - course_theta))
    if off_course >= 0.5 * math.pi:
        raise PlanningError(
            f"heading is {math.degrees(off_course):.0f} deg off the course: a bypass must start "
            "within 90 deg of the direction it ends on"
        )

    if along <= 0.0:
        raise PlanningError(
            f"mark is behind or beside the robot ({along:.0f} mm along the course, "
            f"{lateral:.0f} mm to the left): nothing to bypass"
        )
    if dist_now <= clearance_mm:
        raise PlanningError(
            f"robot is already within the clearance: {dist_now:.0f} mm from the mark centre, "
            f"clearance {clearance_mm:.0f} mm"
        )
    end = mark + sigma * clearance_mm * nc
    max_kappa = math.inf if min_turn_radius_mm == 0.0 else 1.0 / min_turn_radius_mm

    def evaluate(pairs: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        ctrl = _bypass_controls(p0, h0, end, hc, pairs * along)
        kappa = _peak_curvature(ctrl).reshape(-1, 2).max(axis=1)
        _, dist = _closest_batch(ctrl, mark)
        return pairs, kappa, dist.reshape(-1, 2).min(axis=1)

    if control_distance_mm is not None:
        if not (math.isfinite(control_distance_mm) and control_distance_mm > 0.0):
            raise PlanningError(
                f"control_distance_mm must be a positive number, got {control_distance_mm}"
            )
        f = control_distance_mm / along
        pairs, kappa, dist = evaluate(np.array([[f, f]]))
    else:
        g1, g2 = np.meshgrid(_COARSE_FRACTIONS, _COARSE_FRACTIONS, indexing="ij")
        coarse = np.column_stack([g1.ravel(), g2.ravel()])
        coarse = coarse[coarse.sum(axis=1) <= 1.0 + 1e-9]
        pairs, kappa, dist = evaluate(coarse)
        ok = dist >= clearance_mm * (1.0 - _CLEARANCE_RTOL)
        if np.any(ok):
            best = pairs[_pick_lowest_curvature(pairs, kappa, ok)]
            o1, o2 = np.meshgrid(_FINE_OFFSETS, _FINE_OFFSETS, indexing="ij")
            fine = best + np.column_stack([o1.ravel(), o2.ravel()])
            fine = fine[(fine.min(axis=1) >= _MIN_FRACTION) & (fine.sum(axis=1) <= 1.0 + 1e-9)]
            pairs, kappa, dist = evaluate(fine)

    ok = dist >= clearance_mm * (1.0 - _CLEARANCE_RTOL)
    if not np.any(ok) and control_distance_mm is not None:
        raise PlanningError(
            f"control_distance_mm={control_distance_mm:g} cuts inside the clearance: the plan "
            f"comes within {float(dist[0]):.0f} mm of the mark centre, clearance "
            f"{clearance_mm:.0f} mm"
        )
    if not np.any(ok):
        closest = float(dist.max())
        raise PlanningError(
            f"mark too close ahead to swerve: it is {along:.0f} mm ahead and {lateral:.0f} mm to "
            f"the left; passing {side_word} at {clearance_mm:.0f} mm clearance needs more room "
            f"(the best candidate comes within {closest:.0f} mm of the mark centre)"
        )
    idx = _pick_lowest_curvature(pairs, kappa, ok)
    if kappa[idx] > max_kappa:
        raise PlanningError(
            f"mark too close ahead to swerve: passing {side_word} at {clearance_mm:.0f} mm "
            f"clearance, {along:.0f} mm ahead, needs a turn radius of {1.0 / kappa[idx]:.0f} mm, "
            f"below min_turn_radius_mm={min_turn_radius_mm:g}"
        )
    a1, a2 = (float(v) for v in pairs[idx] * along)
    ctrl = _bypass_controls(p0, h0, end, hc, np.array([[a1, a2]]))
    curves = tuple(
        QuadraticBezier(_vec(c[0]), _vec(c[1]), _vec(c[2])) for c in ctrl
    )
    return BypassPlan(
        curves=curves,
        start_pose=pose,
        end_pose=Pose(float(end[0]), float(end[1]), course_theta),
        mark_xy=(float(mark[0]), float(mark[1])),
        clearance_mm=float(clearance_mm),
        side=side,
        control_distances_mm=(a1, a2),
    )


def _pick_lowest_curvature(pairs: FloatArray, kappa: FloatArray, ok: BoolArray) -> int:
    """Index of the feasible candidate with the lowest peak curvature.

    Ties (to rounding; e.g. every candidate of a straight path has κ = 0) go to the pair nearest
    the default (L/4, L/4), so the choice is deterministic and the parametrisation even.
    """
    k_min = float(kappa[ok].min())
    tied = ok & (kappa <= k_min * (1.0 + 1e-9) + 1e-15)
    spread = np.abs(pairs - 0.25).sum(axis=1)
    return int(np.flatnonzero(tied)[np.argmin(spread[tied])])


def _bypass_controls(
    p0: FloatArray, h0: FloatArray, end: FloatArray, hc: FloatArray, a: FloatArray
) -> FloatArray:
    """Control points of the two-quadratic bypass for each row (a1, a2) of ``a``.

    Returns ``(2n, 3, 2)``: rows 2k and 2k+1 are C1 = (P0, P0 + a1·h0, Q) and
    C2 = (Q, W − a2·hc, W) of candidate k, Q the midpoint of the inner control points.
    """
    inner1 = p0 + a[:, :1] * h0
    inner2 = end - a[:, 1:] * hc
    q = 0.5 * (inner1 + inner2)
    n = a.shape[0]
    first = np.stack([np.broadcast_to(p0, (n, 2)), inner1, q], axis=1)
    second = np.stack([q, inner2, np.broadcast_to(end, (n, 2))], axis=1)
    return np.stack([first, second], axis=1).reshape(2 * n, 3, 2)


def _peak_curvature(ctrl: FloatArray) -> FloatArray:
    """Peak |curvature| of each quadratic in ``ctrl`` ``(n, 3, 2)``, as in ``max_abs_curvature``."""
    a = ctrl[:, 1] - ctrl[:, 0]
    b = ctrl[:, 0] - 2.0 * ctrl[:, 1] + ctrl[:, 2]
    bb = np.einsum("ij,ij->i", b, b)
    with np.errstate(all="ignore"):
        t = np.where(bb > 0.0, -np.einsum("ij,ij->i", a, b) / bb, 0.0)
    t = np.clip(t, 0.0, 1.0)[:, None]
    d1 = 2.0 * (a + t * b)  # C'(t) = 2A + 2tB
    cross = np.abs(4.0 * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]))  # |C' × C''|, constant
    speed = np.hypot(d1[:, 0], d1[:, 1])
    with np.errstate(all="ignore"):
        kappa = np.where(
            speed > 0.0, cross / speed / speed / speed, np.where(cross > 0.0, np.inf, 0.0)
        )
    return np.asarray(kappa, dtype=np.float64)


def _vec(p: FloatArray) -> Vec2:
    return (float(p[0]), float(p[1]))


def _check_inputs(
    pose: Pose,
    mark_xy: Vec2,
    mark_radius_mm: float,
    clearance_mm: float,
    course: float | None,
    min_turn_radius_mm: float,
) -> None:
    numbers = {
        "pose.x": pose.x, "pose.y": pose.y, "pose.theta": pose.theta,
        "mark x": mark_xy[0], "mark y": mark_xy[1],
        "mark_radius_mm": mark_radius_mm, "clearance_mm": clearance_mm,
        "min_turn_radius_mm": min_turn_radius_mm,
    }
    if course is not None:
        numbers["course"] = course
    for name, value in numbers.items():
        if not math.isfinite(value):
            raise PlanningError(f"{name} must be a finite number, got {value}")
    if clearance_mm <= 0.0:
        raise PlanningError(f"clearance_mm must be positive, got {clearance_mm:g}")
    if mark_radius_mm < 0.0:
        raise PlanningError(f"mark_radius_mm must not be negative, got {mark_radius_mm:g}")
    if clearance_mm <= mark_radius_mm:
        raise PlanningError(
            f"clearance_mm ({clearance_mm:g}) must exceed the mark radius ({mark_radius_mm:g}): "
            "the robot centre would be inside the mark"
        )
    if min_turn_radius_mm < 0.0:
        raise PlanningError(f"min_turn_radius_mm must not be negative, got {min_turn_radius_mm:g}")
