"""Path tracking: pure pursuit from odometry against the paper's open-loop stepping, with a
3 % slow right wheel, simulated at 20 Hz with quantised wheel encoders."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pytest

from marknav.planning import (
    ArcStep,
    BypassPlan,
    PathLike,
    Pose,
    PurePursuit,
    QuadraticBezier,
    Side,
    WheelSpeeds,
    arc_curvature,
    integrate_pose,
    open_loop_command,
    open_loop_wheel_steps,
    plan_bypass,
    to_robot_frame,
)

WB = 235.0
DT = 0.05  # 20 Hz
MAX_WHEEL = 500.0
MM_PER_COUNT = math.pi * 72.0 / 508.8  # Create encoder resolution
START = Pose(0.0, 0.0, math.pi / 2)


@dataclass
class Run:
    true_pose: Pose
    odometry: Pose
    ticks: int
    min_mark_distance: float
    max_wheel: float


def drive_closed_loop(tracker: PurePursuit, start: Pose, mark: tuple[float, float], *,
                      right_gain: float, max_ticks: int = 600) -> Run:
    """The robot really turns its right wheel ``right_gain`` times the command; the encoders
    count the real wheel motion (quantised), and the tracker only sees that odometry."""
    true_pose = odometry = start
    travelled = [0.0, 0.0]
    counts = [0, 0]
    ticks, min_dist, max_wheel = 0, math.inf, 0.0
    while not tracker.finished(odometry) and ticks < max_ticks:
        cmd = tracker.command(odometry)
        max_wheel = max(max_wheel, cmd.max_abs)
        left, right = cmd.left, cmd.right * right_gain
        true_pose = integrate_pose(true_pose, left=left, right=right, dt=DT, wheel_base_mm=WB)
        travelled[0] += left * DT
        travelled[1] += right * DT
        new = [math.floor(d / MM_PER_COUNT) for d in travelled]
        d_left, d_right = ((n - c) * MM_PER_COUNT for n, c in zip(new, counts, strict=True))
        counts = new
        odometry = integrate_pose(odometry, left=d_left / DT, right=d_right / DT, dt=DT,
                                  wheel_base_mm=WB)
        ticks += 1
        min_dist = min(min_dist, math.dist(true_pose.xy, mark))
    return Run(true_pose, odometry, ticks, min_dist, max_wheel)


def play_open_loop(steps: list[ArcStep], start: Pose, *, right_gain: float) -> Pose:
    pose = start
    for step in steps:
        pose = integrate_pose(pose, left=step.speeds.left, right=step.speeds.right * right_gain,
                              dt=step.duration_s, wheel_base_mm=WB)
    return pose


def field_notes_plan() -> BypassPlan:
    return plan_bypass(START, (0.0, 1000.0), mark_radius_mm=100.0, clearance_mm=320.0,
                       side="left", control_distance_mm=300.0)


def make_tracker(path: PathLike) -> PurePursuit:
    return PurePursuit(path, lookahead_mm=150.0, speed_mm_s=250.0, wheel_base_mm=WB,
                       max_wheel_mm_s=MAX_WHEEL)


# -- the comparison the evaluation relies on -------------------------------------------------


def test_pure_pursuit_reaches_the_end_despite_a_slow_right_wheel() -> None:
    plan = field_notes_plan()
    run = drive_closed_loop(make_tracker(plan), START, plan.mark_xy, right_gain=0.97)
    assert run.ticks < 600
    error = math.dist(run.true_pose.xy, plan.end_pose.xy)
    assert error < 10.0
    # encoders see the real wheel motion: odometry stays with the true pose (no slip)
    assert math.dist(run.odometry.xy, run.true_pose.xy) < 2.0
    # it ended parallel to the course, and never got much inside the planned clearance
    assert abs(run.true_pose.theta - plan.course) < math.radians(5)
    assert run.min_mark_distance > 320.0 - 5.0
    assert run.max_wheel <= MAX_WHEEL


def test_open_loop_stepping_drifts_with_the_same_wheel() -> None:
    plan = field_notes_plan()
    steps = open_loop_wheel_steps(plan, START, speed_mm_s=250.0, wheel_base_mm=WB,
                                  max_wheel_mm_s=MAX_WHEEL)
    assert len(steps) == 40
    # with perfect wheels the exact arcs land on the end ...
    perfect = play_open_loop(steps, START, right_gain=1.0)
    assert math.dist(perfect.xy, plan.end_pose.xy) < 1e-6
    # ... with the right wheel 3 % slow and nothing fed back, far off
    drifted = play_open_loop(steps, START, right_gain=0.97)
    assert math.dist(drifted.xy, plan.end_pose.xy) > 50.0
    closed = drive_closed_loop(make_tracker(plan), START, plan.mark_xy, right_gain=0.97)
    assert math.dist(closed.true_pose.xy, plan.end_pose.xy) < math.dist(
        drifted.xy, plan.end_pose.xy) / 5


@pytest.mark.parametrize(("along", "clearance", "side"), [
    (800.0, 300.0, "right"), (1500.0, 300.0, "left"), (2500.0, 450.0, "right"),
])
def test_pure_pursuit_on_other_plans(along: float, clearance: float, side: Side) -> None:
    plan = plan_bypass(START, (0.0, along), mark_radius_mm=100.0, clearance_mm=clearance,
                       side=side)
    run = drive_closed_loop(make_tracker(plan), START, plan.mark_xy, right_gain=0.97)
    assert math.dist(run.true_pose.xy, plan.end_pose.xy) < 10.0
    assert run.min_mark_distance > clearance - 5.0


# -- pure pursuit behaviour ------------------------------------------------------------------


def straight_path(length: float = 1000.0) -> npt.NDArray[np.float64]:
    return np.array([[0.0, 0.0], [0.0, length]])


def test_on_a_straight_path_both_wheels_cruise() -> None:
    tracker = make_tracker(straight_path())
    cmd = tracker.command(START)
    assert (cmd.left, cmd.right) == pytest.approx((250.0, 250.0), abs=1e-9)


def test_steers_back_towards_the_path() -> None:
    # 50 mm to the left of a path heading +y: turn right (left wheel faster)
    cmd = make_tracker(straight_path()).command(Pose(-50.0, 0.0, math.pi / 2))
    assert cmd.left > cmd.right > 0
    cmd = make_tracker(straight_path()).command(Pose(50.0, 0.0, math.pi / 2))
    assert cmd.right > cmd.left > 0


def test_slows_down_near_the_end_and_stops_there() -> None:
    tracker = make_tracker(straight_path(1000.0))
    assert tracker.command(Pose(0.0, 500.0, math.pi / 2)).linear == pytest.approx(250.0)
    assert tracker.command(Pose(0.0, 850.0, math.pi / 2)).linear == pytest.approx(125.0)
    assert tracker.command(Pose(0.0, 990.0, math.pi / 2)).linear == pytest.approx(50.0)
    assert tracker.finished(Pose(0.0, 996.0, math.pi / 2))  # within the 5 mm tolerance
    assert tracker.command(Pose(0.0, 996.0, math.pi / 2)) == WheelSpeeds(left=0.0, right=0.0)


def test_finished_past_the_end_line_but_not_at_the_start_of_a_u_turn() -> None:
    tracker = make_tracker(straight_path(1000.0))
    assert tracker.finished(Pose(40.0, 1003.0, math.pi / 2))  # past the normal line, off-path
    assert not tracker.finished(Pose(40.0, 990.0, math.pi / 2))
    # a U-turn: the start is already "past" the end's normal line, but far from the end
    u_turn = [QuadraticBezier((0.0, 0.0), (0.0, 500.0), (250.0, 500.0)),
              QuadraticBezier((250.0, 500.0), (500.0, 500.0), (500.0, 0.0))]
    tracker = make_tracker(u_turn)
    assert not tracker.finished(START)
    assert tracker.finished(Pose(500.0, -1.0, -math.pi / 2))


def test_wheel_limit_scales_both_wheels() -> None:
    # a tight left turn at high speed: the outer wheel would exceed the limit
    tight = [QuadraticBezier((0.0, 0.0), (0.0, 100.0), (-100.0, 100.0))]
    tracker = PurePursuit(tight, lookahead_mm=60.0, speed_mm_s=450.0, wheel_base_mm=WB,
                          max_wheel_mm_s=MAX_WHEEL, slowdown_mm=0.0)
    cmd = tracker.command(START)
    assert cmd.right == pytest.approx(MAX_WHEEL)
    target = tracker.lookahead_point(START)
    kappa = arc_curvature(to_robot_frame(START, target))
    assert (cmd.right - cmd.left) / (WB / 2 * (cmd.right + cmd.left)) == pytest.approx(kappa)


def test_progress_never_goes_back() -> None:
    tracker = make_tracker(straight_path())
    tracker.command(Pose(0.0, 600.0, math.pi / 2))
    before = tracker.progress_mm
    tracker.command(Pose(0.0, 300.0, math.pi / 2))
    assert tracker.progress_mm == before == pytest.approx(600.0)


def test_constructor_checks() -> None:
    with pytest.raises(ValueError, match="lookahead_mm"):
        PurePursuit(straight_path(), lookahead_mm=0.0, speed_mm_s=200.0, wheel_base_mm=WB,
                    max_wheel_mm_s=MAX_WHEEL)
    with pytest.raises(ValueError, match="two distinct points"):
        make_tracker(np.array([[1.0, 1.0], [1.0, 1.0]]))
    with pytest.raises(ValueError, match=r"\(n, 2\)"):
        make_tracker(np.zeros((3, 3)))
    with pytest.raises(TypeError):
        PurePursuit(straight_path(), 150.0, 200.0, WB, MAX_WHEEL)  # type: ignore[call-arg]


# -- open-loop playback ----------------------------------------------------------------------


def test_open_loop_command_schedule() -> None:
    a = ArcStep(WheelSpeeds(left=100.0, right=120.0), 0.5)
    b = ArcStep(WheelSpeeds(left=130.0, right=90.0), 0.25)
    assert open_loop_command([a, b], 0.0) == a.speeds
    assert open_loop_command([a, b], 0.49) == a.speeds
    assert open_loop_command([a, b], 0.5) == b.speeds
    assert open_loop_command([a, b], 0.75) is None


def test_open_loop_steps_follow_the_curve_points() -> None:
    plan = field_notes_plan()
    steps = open_loop_wheel_steps(plan, START, speed_mm_s=250.0, wheel_base_mm=WB,
                                  max_wheel_mm_s=MAX_WHEEL, steps_per_curve=10)
    pose = START
    for k, step in enumerate(steps):
        pose = integrate_pose(pose, left=step.speeds.left, right=step.speeds.right,
                              dt=step.duration_s, wheel_base_mm=WB)
        curve = plan.curves[k // 10]
        assert pose.xy == pytest.approx(curve.point((k % 10 + 1) / 10), abs=1e-6)
        assert step.speeds.max_abs <= MAX_WHEEL + 1e-9
    with pytest.raises(ValueError, match="steps_per_curve"):
        open_loop_wheel_steps(plan, START, speed_mm_s=250.0, wheel_base_mm=WB,
                              max_wheel_mm_s=MAX_WHEEL, steps_per_curve=0)


def _point_at_reference(pp: PurePursuit, s_mm: float) -> tuple[float, float]:
    """PurePursuit.point_at in NumPy, as it was before it used Python floats."""
    if s_mm >= pp.length_mm:
        extra = s_mm - pp.length_mm
        return (pp.end[0] + extra * pp.end_direction[0], pp.end[1] + extra * pp.end_direction[1])
    s = max(0.0, s_mm)
    cum = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(pp.points, axis=0).T))))
    i = min(int(np.searchsorted(cum, s, side="right")) - 1, len(pp.points) - 2)
    seg = np.diff(pp.points, axis=0)
    u = (s - cum[i]) / np.hypot(seg[i, 0], seg[i, 1])
    p = pp.points[i] + u * seg[i]
    return (float(p[0]), float(p[1]))


def _closest_reference(pp: PurePursuit, xy: tuple[float, float], lo: float, hi: float) -> float:
    """PurePursuit._closest with np.clip, as it was."""
    import bisect

    cum = pp._cum_list
    first = max(0, bisect.bisect_right(cum, lo) - 1)
    last = max(min(len(pp._seg), bisect.bisect_right(cum, hi)), first + 1)
    starts, seg = pp.points[first:last], pp._seg[first:last]
    p = np.array(xy, dtype=float)
    u = np.einsum("ij,ij->i", p - starts, seg)
    u /= pp._seg_len2[first:last]
    np.clip(u, 0.0, 1.0, out=u)
    d = u[:, None] * seg
    d += starts
    d -= p
    k = int(np.einsum("ij,ij->i", d, d).argmin())
    return float(cum[first + k] + u[k] * pp._seg_len[first + k])


def test_point_at_and_closest_are_bitwise_the_numpy_arithmetic() -> None:
    rng = np.random.default_rng(16)
    checked = 0
    for along, clearance, side in [(1500.0, 300.0, "left"), (900.0, 450.0, "right"),
                                   (2500.0, 250.0, "left")]:
        plan = plan_bypass(START, (0.0, along), mark_radius_mm=100.0, clearance_mm=clearance,
                           side=side)  # type: ignore[arg-type]
        polyline = np.cumsum(rng.normal(0.0, 40.0, size=(60, 2)), axis=0)
        for path in (plan, polyline):
            pp = PurePursuit(path, lookahead_mm=150.0, speed_mm_s=250.0, wheel_base_mm=WB,
                             max_wheel_mm_s=MAX_WHEEL)
            for s in rng.uniform(-50.0, pp.length_mm + 200.0, size=400):
                assert pp.point_at(float(s)) == _point_at_reference(pp, float(s))
                checked += 1
            for x, y in rng.uniform(-600.0, max(along, 600.0), size=(300, 2)):
                lo = float(rng.uniform(0.0, pp.length_mm))
                hi = lo + float(rng.uniform(0.0, 600.0))
                assert pp._closest((x, y), lo, hi) == _closest_reference(pp, (x, y), lo, hi)
    assert checked == 2400
