"""The bypass plan: two tangent-joined quadratics keep the clearance (checked with the exact
closest-point cubic), start tangent to the heading, end parallel to it beside the mark on the
required side; impossible geometry raises PlanningError with the reason."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from marknav.planning import (
    BypassPlan,
    PlanningError,
    Pose,
    QuadraticBezier,
    Side,
    closest_point,
    passed,
    plan_bypass,
    to_world_frame,
    wrap_angle,
)

START = Pose(0.0, 0.0, math.pi / 2)  # the default start: origin, facing +y


def cross(a: tuple[float, float], b: tuple[float, float]) -> float:
    return a[0] * b[1] - a[1] * b[0]


def unit(v: tuple[float, float]) -> tuple[float, float]:
    n = math.hypot(*v)
    return (v[0] / n, v[1] / n)


def assert_bypass_invariants(plan: BypassPlan, pose: Pose, mark: tuple[float, float],
                             clearance: float, side: Side, course: float) -> None:
    h0 = pose.heading
    hc = (math.cos(course), math.sin(course))
    first, second = plan.curves
    # never closer than the clearance: exact (closest-point cubic) ...
    exact = min(closest_point(c, mark).distance for c in plan.curves)
    assert exact >= clearance - 1e-6
    assert plan.min_clearance_mm == pytest.approx(exact, abs=1e-9)
    # ... and an independent sampled oracle agrees (never below the exact minimum)
    pts = np.vstack([c.points(np.linspace(0, 1, 401)) for c in plan.curves])
    assert np.min(np.hypot(pts[:, 0] - mark[0], pts[:, 1] - mark[1])) >= exact - 1e-9
    # starts at the robot, tangent to its heading
    assert first.p0 == pytest.approx(pose.xy, abs=1e-9)
    d0 = unit(first.derivative(0.0))
    assert cross(h0, d0) == pytest.approx(0.0, abs=1e-9)
    assert d0[0] * h0[0] + d0[1] * h0[1] > 0
    # G1 (here C1) at the joint
    assert first.p2 == pytest.approx(second.p0, abs=1e-9)
    assert first.derivative(1.0) == pytest.approx(second.derivative(0.0), abs=1e-9)
    dj = unit(first.derivative(1.0))
    assert cross(dj, unit(second.derivative(0.0))) == pytest.approx(0.0, abs=1e-9)
    # ends parallel to the course, at exactly the clearance, on the required side
    end = second.p2
    d1 = unit(second.derivative(1.0))
    assert cross(hc, d1) == pytest.approx(0.0, abs=1e-9)
    assert d1[0] * hc[0] + d1[1] * hc[1] > 0
    assert math.dist(end, mark) == pytest.approx(clearance, abs=1e-6)
    to_mark = (mark[0] - end[0], mark[1] - end[1])
    # side "left": the robot passes on the mark's left, so the mark is on the robot's RIGHT
    expected = -clearance if side == "left" else clearance
    assert cross(hc, to_mark) == pytest.approx(expected, abs=1e-6)
    assert plan.end_pose.xy == pytest.approx(end, abs=1e-9)
    assert plan.end_pose.theta == pytest.approx(wrap_angle(course), abs=1e-12)
    # the mark is ahead at the start and beside at the end
    assert not passed(pose, mark, course)
    assert passed(plan.end_pose, mark, course)


# -- the property test -----------------------------------------------------------------------


@settings(max_examples=250, deadline=None)
@given(
    x=st.floats(-5000, 5000),
    y=st.floats(-5000, 5000),
    theta=st.floats(-math.pi, math.pi),
    along=st.floats(400, 2500),
    lateral=st.floats(-600, 600),
    clearance=st.floats(150, 500),
    side=st.sampled_from(["left", "right"]),
)
def test_bypass_keeps_clearance_for_random_marks(x: float, y: float, theta: float, along: float,
                                                 lateral: float, clearance: float,
                                                 side: Side) -> None:
    pose = Pose(x, y, theta)
    mark = to_world_frame(pose, (along, lateral))
    assume(math.hypot(along, lateral) > clearance + 1.0)  # robot not already inside the clearance
    sigma = 1.0 if side == "left" else -1.0
    # the region where a plan is guaranteed: room of about twice the clearance, plus any
    # distance the robot must cross in front of the mark
    roomy = along >= 2 * clearance + max(0.0, sigma * lateral) + 100.0
    try:
        plan = plan_bypass(pose, mark, mark_radius_mm=100.0, clearance_mm=clearance, side=side)
    except PlanningError as err:
        assert not roomy, f"no plan in the guaranteed region: {err}"
        assert "too close ahead to swerve" in str(err)
        return
    assert_bypass_invariants(plan, pose, mark, clearance, side, theta)


@settings(max_examples=60, deadline=None)
@given(
    theta=st.floats(-math.pi, math.pi),
    off=st.floats(-0.6, 0.6),
    along=st.floats(900, 2500),
    lateral=st.floats(-200, 200),
    clearance=st.floats(150, 350),
    side=st.sampled_from(["left", "right"]),
)
def test_replanning_with_a_course_keeps_the_direction(theta: float, off: float, along: float,
                                                      lateral: float, clearance: float,
                                                      side: Side) -> None:
    # mid-bypass the robot's heading is off the course; the new plan starts tangent to the
    # heading and still ends parallel to the original course.
    course = theta
    course_pose = Pose(120.0, -40.0, course)
    mark = to_world_frame(course_pose, (along, lateral))
    pose = Pose(120.0, -40.0, theta + off)
    plan = plan_bypass(pose, mark, mark_radius_mm=100.0, clearance_mm=clearance, side=side,
                       course=course)
    assert_bypass_invariants(plan, pose, mark, clearance, side, course)


# -- worked cases ----------------------------------------------------------------------------


def test_field_notes_case_keeps_exactly_the_clearance() -> None:
    # mark 1 m ahead, D = 320 mm, a = 300 mm: minimum exactly D, peak curvature 1.46 /m
    plan = plan_bypass(START, (0.0, 1000.0), mark_radius_mm=100.0, clearance_mm=320.0,
                       side="left", control_distance_mm=300.0)
    assert plan.control_distances_mm == (300.0, 300.0)
    assert plan.min_clearance_mm == pytest.approx(320.0, abs=1e-9)
    assert plan.max_curvature * 1000 == pytest.approx(1.458, abs=1e-3)
    assert plan.length_mm == pytest.approx(1070.9, abs=0.1)
    assert_bypass_invariants(plan, START, (0.0, 1000.0), 320.0, "left", math.pi / 2)


def test_single_quadratic_ending_beside_the_mark_cuts_inside() -> None:
    # Why two curves: (P0, P0 + c·h, W) for every c from 200 to 900 mm dips inside D.
    mark, d = (0.0, 1000.0), 320.0
    end = (-d, 1000.0)
    minima = [
        closest_point(QuadraticBezier((0.0, 0.0), (0.0, c), end), mark).distance
        for c in range(200, 901, 50)
    ]
    assert max(minima) < d
    assert min(minima) > 200.0
    assert (round(min(minima)), round(max(minima))) == (204, 297)


def test_side_convention_default_start() -> None:
    # facing +y, the robot's left is -x: passing on the mark's left ends at x = -D.
    left = plan_bypass(START, (0.0, 1500.0), mark_radius_mm=100.0, clearance_mm=300.0,
                       side="left")
    right = plan_bypass(START, (0.0, 1500.0), mark_radius_mm=100.0, clearance_mm=300.0,
                        side="right")
    assert left.end_pose.xy == pytest.approx((-300.0, 1500.0))
    assert right.end_pose.xy == pytest.approx((300.0, 1500.0))
    # mirror images of each other
    for a, b in zip(left.curves, right.curves, strict=True):
        for pa, pb in ((a.p0, b.p0), (a.p1, b.p1), (a.p2, b.p2)):
            assert pa == pytest.approx((-pb[0], pb[1]), abs=1e-9)


@pytest.mark.parametrize("along", [600.0, 800.0, 1000.0, 1500.0, 2500.0])
def test_control_distance_is_about_a_quarter_of_the_range(along: float) -> None:
    plan = plan_bypass(START, (0.0, along), mark_radius_mm=100.0, clearance_mm=300.0,
                       side="right")
    a1, a2 = plan.control_distances_mm
    assert a1 == pytest.approx(a2)
    assert 0.25 * along <= a1 <= 0.30 * along
    assert plan.min_clearance_mm == pytest.approx(300.0, abs=1e-6)


def test_close_mark_gets_a_longer_run_in() -> None:
    # 500 mm ahead with D = 300: the symmetric construction cannot keep D; a2 > a1 does.
    plan = plan_bypass(START, (0.0, 500.0), mark_radius_mm=100.0, clearance_mm=300.0,
                       side="left")
    a1, a2 = plan.control_distances_mm
    assert a2 > a1
    assert plan.min_clearance_mm >= 300.0 - 1e-6
    with pytest.raises(PlanningError, match="cuts inside the clearance"):
        plan_bypass(START, (0.0, 500.0), mark_radius_mm=100.0, clearance_mm=300.0,
                    side="left", control_distance_mm=0.25 * 500.0)


def test_straight_pass_when_the_mark_is_already_aside() -> None:
    # mark 300 mm to the right, pass on its left at 300 mm: drive straight on.
    plan = plan_bypass(START, (300.0, 1200.0), mark_radius_mm=100.0, clearance_mm=300.0,
                       side="left")
    assert plan.end_pose.xy == pytest.approx((0.0, 1200.0))
    assert plan.max_curvature == pytest.approx(0.0, abs=1e-12)
    assert plan.length_mm == pytest.approx(1200.0)


def test_sample_and_min_distance_helpers() -> None:
    plan = plan_bypass(START, (0.0, 1000.0), mark_radius_mm=100.0, clearance_mm=300.0,
                       side="left")
    pts = plan.sample(10.0)
    assert tuple(pts[0]) == pytest.approx(START.xy)
    assert tuple(pts[-1]) == pytest.approx(plan.end_pose.xy)
    gaps = np.hypot(*np.diff(pts, axis=0).T)
    assert gaps.max() <= 10.0 * 1.001
    assert float(np.sum(gaps)) == pytest.approx(plan.length_mm, rel=1e-4)
    assert plan.min_distance_to(plan.end_pose.xy) == pytest.approx(0.0, abs=1e-9)
    assert plan.min_distance_to((0.0, -50.0)) == pytest.approx(50.0)
    assert not plan.passed(START)
    assert plan.passed(plan.end_pose)


def test_passed_uses_the_planned_heading() -> None:
    mark = (0.0, 1000.0)
    assert not passed(Pose(0.0, 999.0, math.pi / 2), mark, math.pi / 2)
    assert passed(Pose(-300.0, 1000.0, math.pi / 2), mark, math.pi / 2)  # beside
    assert passed(Pose(-300.0, 1200.0, math.pi / 2), mark, math.pi / 2)  # behind
    # the robot's current heading does not matter, only the planned one
    assert passed(Pose(-300.0, 1000.0, 0.0), mark, math.pi / 2)
    assert not passed(Pose(-300.0, 900.0, -math.pi / 2), mark, math.pi / 2)


# -- errors ----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("mark", "kwargs", "message"),
    [
        ((0.0, -500.0), {}, "mark is behind or beside the robot"),
        ((-800.0, 0.0), {}, "mark is behind or beside the robot"),
        ((0.0, 250.0), {}, "robot is already within the clearance: 250 mm"),
        ((0.0, 400.0), {}, "mark too close ahead to swerve"),
        ((0.0, 1000.0), {"clearance_mm": 0.0}, "clearance_mm must be positive"),
        ((0.0, 1000.0), {"clearance_mm": -5.0}, "clearance_mm must be positive"),
        ((0.0, 1000.0), {"clearance_mm": 90.0}, r"must exceed the mark radius \(100\)"),
        ((0.0, 1000.0), {"side": "middle"}, "side must be 'left' or 'right'"),
        ((0.0, math.nan), {}, "mark y must be a finite number"),
        ((0.0, 1000.0), {"control_distance_mm": 100.0}, "cuts inside the clearance"),
        ((0.0, 1000.0), {"control_distance_mm": -1.0}, "control_distance_mm must be a positive"),
        ((0.0, 1000.0), {"course": 0.0}, "heading is 90 deg off the course"),
        ((0.0, 700.0), {"min_turn_radius_mm": 1000.0}, "needs a turn radius of"),
    ],
)
def test_impossible_geometry_raises(mark: tuple[float, float], kwargs: dict[str, object],
                                    message: str) -> None:
    args: dict[str, object] = {"mark_radius_mm": 100.0, "clearance_mm": 300.0, "side": "left"}
    args.update(kwargs)
    with pytest.raises(PlanningError, match=message) as info:
        plan_bypass(START, mark, **args)  # type: ignore[arg-type]
    assert isinstance(info.value, ValueError)
