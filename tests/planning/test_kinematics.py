"""Differential-drive kinematics: eqs. 25–30 integrated exactly, frames, the well-posed wheel
speeds and the paper's ill-posed eqs. 35–36."""

from __future__ import annotations

import dataclasses
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from marknav.planning.kinematics import (
    Pose,
    WheelSpeeds,
    arc_curvature,
    arc_step,
    body_velocity,
    integrate_pose,
    paper_wheel_speeds,
    scale_to_limit,
    to_robot_frame,
    to_world_frame,
    wheel_speeds_for_curvature,
    wheel_speeds_to_point,
    wrap_angle,
)

WB = 235.0
coord = st.floats(-5000, 5000)
angle = st.floats(-10.0, 10.0)
speed = st.floats(-500, 500)


def pose_close(a: Pose, b: Pose, tol: float = 1e-9) -> bool:
    return (
        math.isclose(a.x, b.x, abs_tol=tol)
        and math.isclose(a.y, b.y, abs_tol=tol)
        and abs(wrap_angle(a.theta - b.theta)) <= tol
    )


# -- wrap_angle ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("angle_in", "expected"),
    [
        (0.0, 0.0),
        (math.pi, math.pi),
        (-math.pi, math.pi),
        (3 * math.pi, math.pi),
        (-1.5 * math.pi, 0.5 * math.pi),
        (2 * math.pi + 0.25, 0.25),
        (-0.25, -0.25),
    ],
)
def test_wrap_angle_values(angle_in: float, expected: float) -> None:
    assert wrap_angle(angle_in) == pytest.approx(expected, abs=1e-12)


@given(st.floats(-1e4, 1e4))
def test_wrap_angle_range_and_equivalence(a: float) -> None:
    w = wrap_angle(a)
    assert -math.pi < w <= math.pi
    assert math.cos(w) == pytest.approx(math.cos(a), abs=1e-9)
    assert math.sin(w) == pytest.approx(math.sin(a), abs=1e-9)


# -- value types -----------------------------------------------------------------------------


def test_wheel_speeds_are_keyword_only_and_frozen() -> None:
    with pytest.raises(TypeError):
        WheelSpeeds(100.0, 200.0)  # type: ignore[call-arg]
    w = WheelSpeeds(left=100.0, right=200.0)
    assert (w.left, w.right, w.linear, w.max_abs) == (100.0, 200.0, 150.0, 200.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        w.left = 0.0  # type: ignore[misc]
    assert w.scaled(0.5) == WheelSpeeds(left=50.0, right=100.0)


def test_pose_vectors() -> None:
    p = Pose(1.0, 2.0, math.pi / 2)
    assert p.xy == (1.0, 2.0)
    assert p.heading == pytest.approx((0.0, 1.0), abs=1e-15)
    assert p.left_normal == pytest.approx((-1.0, 0.0), abs=1e-15)  # facing north, left is west
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.x = 0.0  # type: ignore[misc]


def test_body_velocity_eqs_25_to_27() -> None:
    v, omega = body_velocity(left=100.0, right=300.0, wheel_base_mm=200.0)
    assert v == 200.0
    assert omega == 1.0  # (300 - 100) / (2 * 100)
    with pytest.raises(ValueError, match="wheel_base_mm"):
        body_velocity(left=1.0, right=1.0, wheel_base_mm=0.0)


# -- integrate_pose --------------------------------------------------------------------------


def test_straight_line() -> None:
    end = integrate_pose(Pose(10.0, 20.0, math.pi / 2), left=200.0, right=200.0, dt=2.0,
                         wheel_base_mm=WB)
    assert pose_close(end, Pose(10.0, 420.0, math.pi / 2))


def test_spin_in_place() -> None:
    start = Pose(-30.0, 45.0, 0.3)
    end = integrate_pose(start, left=-100.0, right=100.0, dt=1.5, wheel_base_mm=WB)
    assert end.xy == pytest.approx(start.xy, abs=1e-12)
    assert end.theta == pytest.approx(wrap_angle(0.3 + 200.0 * 1.5 / WB), abs=1e-12)


def test_full_circle_returns_home() -> None:
    start = Pose(100.0, -50.0, 1.0)
    _, omega = body_velocity(left=100.0, right=200.0, wheel_base_mm=WB)
    period = 2 * math.pi / omega
    one_go = integrate_pose(start, left=100.0, right=200.0, dt=period, wheel_base_mm=WB)
    assert pose_close(one_go, start, 1e-9)
    pose = start
    for _ in range(37):  # and in many small steps
        pose = integrate_pose(pose, left=100.0, right=200.0, dt=period / 37, wheel_base_mm=WB)
    assert pose_close(pose, start, 1e-9)


def test_quarter_circle_lands_on_the_arc() -> None:
    # radius 500 mm to the left: centre at (0, 500) for a robot at the origin facing +x.
    r, v = 500.0, 200.0
    left, right = v * (1 - WB / 2 / r), v * (1 + WB / 2 / r)
    t = (math.pi / 2) * r / v
    end = integrate_pose(Pose(0.0, 0.0, 0.0), left=left, right=right, dt=t, wheel_base_mm=WB)
    assert pose_close(end, Pose(500.0, 500.0, math.pi / 2), 1e-9)


@settings(max_examples=60)
@given(coord, coord, angle, speed, speed, st.floats(0.0, 3.0), st.floats(0.0, 3.0))
def test_integration_composes(x: float, y: float, th: float, vl: float, vr: float,
                              t1: float, t2: float) -> None:
    start = Pose(x, y, th)
    once = integrate_pose(start, left=vl, right=vr, dt=t1 + t2, wheel_base_mm=WB)
    mid = integrate_pose(start, left=vl, right=vr, dt=t1, wheel_base_mm=WB)
    twice = integrate_pose(mid, left=vl, right=vr, dt=t2, wheel_base_mm=WB)
    assert pose_close(once, twice, 1e-6)
    assert -math.pi < once.theta <= math.pi


def test_integrate_pose_rejects_negative_dt() -> None:
    with pytest.raises(ValueError, match="dt"):
        integrate_pose(Pose(0, 0, 0), left=1.0, right=1.0, dt=-0.1, wheel_base_mm=WB)


# -- frames ----------------------------------------------------------------------------------


def test_robot_frame_convention() -> None:
    start = Pose(0.0, 0.0, math.pi / 2)  # default start, facing +y
    assert to_robot_frame(start, (0.0, 1500.0)) == pytest.approx((1500.0, 0.0), abs=1e-9)
    assert to_robot_frame(start, (-100.0, 0.0)) == pytest.approx((0.0, 100.0), abs=1e-9)  # left
    assert to_robot_frame(start, (100.0, 0.0)) == pytest.approx((0.0, -100.0), abs=1e-9)


@given(coord, coord, angle, coord, coord)
def test_frames_round_trip(x: float, y: float, th: float, px: float, py: float) -> None:
    pose = Pose(x, y, th)
    back = to_world_frame(pose, to_robot_frame(pose, (px, py)))
    assert back == pytest.approx((px, py), abs=1e-6)


# -- well-posed wheel speeds -----------------------------------------------------------------


def test_arc_curvature_values() -> None:
    assert arc_curvature((1000.0, 0.0)) == 0.0
    assert arc_curvature((0.0, 200.0)) == pytest.approx(1 / 100)  # straight left: r = 100
    assert arc_curvature((0.0, -200.0)) == pytest.approx(-1 / 100)
    with pytest.raises(ValueError, match="own position"):
        arc_curvature((0.0, 0.0))


@given(st.floats(-3000, 3000), st.floats(-3000, 3000))
def test_arc_passes_through_the_point(xr: float, yr: float) -> None:
    if math.hypot(xr, yr) < 1.0 or abs(yr) < 1e-6:
        return
    k = arc_curvature((xr, yr))
    radius = 1.0 / k  # circle centre (0, radius) in the robot frame, through the robot
    assert math.hypot(xr, yr - radius) == pytest.approx(abs(radius), rel=1e-9)


def test_wheel_speeds_for_curvature_formula() -> None:
    w = wheel_speeds_for_curvature(200.0, 1 / 500, wheel_base_mm=WB, max_wheel_mm_s=500.0)
    assert w.left == pytest.approx(200.0 * (1 - 117.5 / 500))
    assert w.right == pytest.approx(200.0 * (1 + 117.5 / 500))


@given(st.floats(1.0, 500.0), st.floats(-0.05, 0.05), st.floats(50.0, 500.0))
def test_scaling_keeps_curvature(v: float, kappa: float, limit: float) -> None:
    w = wheel_speeds_for_curvature(v, kappa, wheel_base_mm=WB, max_wheel_mm_s=limit)
    assert w.max_abs <= limit * (1 + 1e-12)
    raw = WheelSpeeds(left=v * (1 - kappa * WB / 2), right=v * (1 + kappa * WB / 2))
    # same direction in (left, right) space: the driven curvature is unchanged
    assert w.left * raw.right - w.right * raw.left == pytest.approx(0.0, abs=1e-6 * v * v)
    assert w.left * raw.left + w.right * raw.right > 0
    if raw.max_abs <= limit:
        assert w == raw


def test_scale_to_limit_never_clamps_one_wheel() -> None:
    w = scale_to_limit(WheelSpeeds(left=250.0, right=1000.0), 500.0)
    assert w == WheelSpeeds(left=125.0, right=500.0)
    w = scale_to_limit(WheelSpeeds(left=-800.0, right=400.0), 500.0)
    assert w == WheelSpeeds(left=-500.0, right=250.0)
    assert scale_to_limit(WheelSpeeds(left=10.0, right=20.0), 500.0) == WheelSpeeds(
        left=10.0, right=20.0
    )
    with pytest.raises(ValueError, match="max_wheel_mm_s"):
        scale_to_limit(WheelSpeeds(left=1.0, right=1.0), 0.0)


@settings(max_examples=60)
@given(coord, coord, angle, st.floats(20.0, 600.0), st.floats(-1.2, 1.2))
def test_arc_step_lands_on_target(x: float, y: float, th: float, dist: float,
                                  bearing: float) -> None:
    pose = Pose(x, y, th)
    target = to_world_frame(pose, (dist * math.cos(bearing), dist * math.sin(bearing)))
    step = arc_step(pose, target, speed_mm_s=250.0, wheel_base_mm=WB, max_wheel_mm_s=500.0)
    assert step.speeds.max_abs <= 500.0 + 1e-9
    end = integrate_pose(pose, left=step.speeds.left, right=step.speeds.right,
                         dt=step.duration_s, wheel_base_mm=WB)
    assert end.xy == pytest.approx(target, abs=1e-6)
    # the arc tangent to the heading turns it by twice the bearing (not once, as eq. 31 says)
    assert wrap_angle(end.theta - th) == pytest.approx(2 * bearing, abs=1e-9)


def test_arc_step_refuses_target_behind() -> None:
    with pytest.raises(ValueError, match="not ahead"):
        arc_step(Pose(0, 0, 0), (-10.0, 5.0), speed_mm_s=100.0, wheel_base_mm=WB,
                 max_wheel_mm_s=500.0)


# -- the paper's eqs. 35-36 against the well-posed form --------------------------------------


def test_paper_formula_blows_up_at_its_own_start_heading() -> None:
    start = Pose(0.0, 0.0, math.pi / 2)  # the paper's [0, 0], phi0 = pi/2
    target = (4.0, 60.0)  # the next point of a curve that swerves right
    paper = paper_wheel_speeds(start, target, v_max_mm_s=250.0, wheel_base_mm=WB)
    assert (not math.isfinite(paper.left)) or abs(paper.left) > 1e15
    ours = wheel_speeds_to_point(start, target, speed_mm_s=250.0, wheel_base_mm=WB,
                                 max_wheel_mm_s=500.0)
    assert math.isfinite(ours.left) and math.isfinite(ours.right)
    assert ours.max_abs <= 500.0
    assert ours.left > ours.right > 0  # a gentle right turn, both wheels forward
    step = arc_step(start, target, speed_mm_s=250.0, wheel_base_mm=WB, max_wheel_mm_s=500.0)
    assert step.speeds == ours
    end = integrate_pose(start, left=ours.left, right=ours.right, dt=step.duration_s,
                         wheel_base_mm=WB)
    assert end.xy == pytest.approx(target, abs=1e-9)


def test_paper_formula_is_implemented_as_printed() -> None:
    # phi0 = 0, step to (100, 10), v_max = 250 mm/s, d = 117.5 mm:
    # eq. 24: dt_r = sqrt(100^2 + 10^2) / 250; eq. 31: phi_T = atan2(10, 100)
    # eq. 35: v_L = (100 / cos 0 - d * phi_T) / dt_r; eq. 36: v_R = 2 d phi_T / dt_r + v_L
    dt_r = math.sqrt(100.0**2 + 10.0**2) / 250.0
    phi_t = math.atan2(10.0, 100.0)
    v_l = (100.0 - 117.5 * phi_t) / dt_r
    v_r = 2 * 117.5 * phi_t / dt_r + v_l
    paper = paper_wheel_speeds(Pose(0.0, 0.0, 0.0), (100.0, 10.0), v_max_mm_s=250.0,
                               wheel_base_mm=WB)
    assert paper.left == pytest.approx(v_l, rel=1e-12)
    assert paper.right == pytest.approx(v_r, rel=1e-12)
    assert (round(paper.left, 2), round(paper.right, 2)) == (219.63, 277.89)
