"""Wheel-ratio calibration: sensitivities, the closed-form fit, and the filter on a drive."""

from __future__ import annotations

import math
import random

import pytest

from marknav.planning.kinematics import Pose, integrate_pose, to_robot_frame, to_world_frame
from marknav.planning.wheel_ratio import (
    WheelRatioCalibrator,
    fit_wheel_ratio,
    mark_sensitivity,
)
from marknav.robot.odometry import Odometry
from marknav.robot.packets import Model

BASE = 235.0


def _drive(true_ratio: float, steps: list[tuple[float, float]]) -> tuple[list[Pose], list[Pose]]:
    """True poses (right wheel travels ``true_ratio`` × its encoder) and odometry poses."""
    truth = [Pose(0.0, 0.0, math.pi / 2)]
    odo = Odometry(Model.CREATE2, pose=truth[0])
    seen = [odo.pose]
    for left, right in steps:
        truth.append(integrate_pose(truth[-1], left=left, right=right * true_ratio, dt=1.0,
                                    wheel_base_mm=BASE))
        seen.append(odo.advance(left_mm=left, right_mm=right))
    return truth, seen


def test_odometry_sensitivity_is_the_derivative_of_the_pose_by_the_right_scale() -> None:
    steps = [(4.0, 4.4)] * 150 + [(5.0, 3.0)] * 100
    odo = Odometry(Model.CREATE2, pose=Pose(10.0, 20.0, 0.3))
    for left, right in steps:
        odo.advance(left_mm=left, right_mm=right)
    h = 1e-5
    moved = Odometry(Model.CREATE2, pose=Pose(10.0, 20.0, 0.3))
    moved.right_scale = 1.0 + h
    for left, right in steps:
        moved.advance(left_mm=left, right_mm=right)
    numeric = ((moved.pose.x - odo.pose.x) / h, (moved.pose.y - odo.pose.y) / h,
               (moved.pose.theta - odo.pose.theta) / h)
    sens = odo.sensitivity()
    assert sens[2] == pytest.approx(numeric[2], rel=0.02)
    assert math.hypot(sens[0] - numeric[0], sens[1] - numeric[1]) < 0.03 * math.hypot(*numeric[:2])
    # a heading sensitivity of Σright / wheel base: every mm of the right wheel turns the robot
    assert sens[2] == pytest.approx(sum(r for _, r in steps) / BASE, rel=0.02)


def test_scaling_the_right_wheel_re_anchors_and_changes_later_travel_only() -> None:
    odo = Odometry(Model.CREATE2, pose=Pose(0.0, 0.0, 0.0))
    odo.advance(left_mm=100.0, right_mm=120.0)
    before = odo.pose
    odo.scale_right_wheel(0.8)
    assert odo.pose == before
    assert odo.sensitivity() == (0.0, 0.0, 0.0)
    odo.advance(left_mm=96.0, right_mm=120.0)  # the right wheel now counts 96 mm: straight
    assert odo.pose.theta == pytest.approx(before.theta)
    with pytest.raises(ValueError, match="wheel scale factor"):
        odo.scale_right_wheel(0.0)


def test_mark_sensitivity_is_the_derivative_of_the_world_estimate() -> None:
    pose, v = Pose(100.0, -50.0, 1.2), (900.0, 150.0)
    sens = (12.0, -30.0, 2.5)
    mark = to_world_frame(pose, v)
    g = mark_sensitivity((pose.x, pose.y), mark, sens)
    h = 1e-6
    shifted = Pose(pose.x + h * sens[0], pose.y + h * sens[1], pose.theta + h * sens[2])
    moved = to_world_frame(shifted, v)
    assert g == pytest.approx(((moved[0] - mark[0]) / h, (moved[1] - mark[1]) / h), rel=1e-4)


def test_fit_is_exact_on_noise_free_linear_sightings() -> None:
    truth = (500.0, 2000.0)
    eps = 0.031
    grads = [(10.0 * k, -4.0 * k * k) for k in range(8)]
    points = [(truth[0] - eps * g[0], truth[1] - eps * g[1]) for g in grads]
    fit = fit_wheel_ratio([(points, grads)])
    assert fit is not None
    assert fit.epsilon == pytest.approx(eps, rel=1e-9)
    assert fit.rms_mm == pytest.approx(0.0, abs=1e-6)
    assert fit_wheel_ratio([(points[:1], grads[:1])]) is None  # one sighting fits nothing
    assert fit_wheel_ratio([(points, [(1.0, 1.0)] * 8)]) is None  # gradients that do not vary


@pytest.mark.parametrize("true_ratio", [0.955, 1.0, 1.045])
def test_calibrator_learns_the_wheel_ratio_from_one_marks_sightings(true_ratio: float) -> None:
    """A robot weaving toward a mark 2.5 m ahead, seeing it each 50 ms with 1 % range and 1 px
    bearing noise: the filtered ratio lands within 0.5 % of the truth, and odometry driven with it
    no longer drifts away from the truth."""
    rng = random.Random(7)
    mark = (150.0, 2500.0)
    truth = Pose(0.0, 0.0, math.pi / 2)
    odo = Odometry(Model.CREATE2, pose=truth)
    cal = WheelRatioCalibrator()
    for k in range(120):  # 6 s at 20 Hz, ~3.3 mm per wheel per 15 ms stream frame
        for _ in range(3):
            bias = 0.4 * math.sin(k / 10.0)
            left, right = 3.3 - bias, 3.3 + bias
            truth = integrate_pose(truth, left=left, right=right * true_ratio, dt=1.0,
                                   wheel_base_mm=BASE)
            odo.advance(left_mm=left, right_mm=right)
        fwd, lft = to_robot_frame(truth, mark)
        rng_mm = math.hypot(fwd, lft) * (1.0 + rng.gauss(0.0, 0.01))
        bearing = math.atan2(lft, fwd) + rng.gauss(0.0, 1.0 / 590.0)
        seen = to_world_frame(odo.pose, (rng_mm * math.cos(bearing), rng_mm * math.sin(bearing)))
        if cal.samples == 0:
            odo.anchor()  # each window's sensitivities count from its start
        cal.add("red", (odo.pose.x, odo.pose.y), seen, odo.sensitivity())
        step = cal.correction()
        if step is not None:
            odo.scale_right_wheel(step.factor)
    assert odo.right_scale == pytest.approx(true_ratio, abs=0.005)
    assert cal.scale == pytest.approx(odo.right_scale)
    assert cal.rejected == 0


@pytest.mark.parametrize("wobble_mm", [0.0, 40.0])
def test_implausible_or_scattered_fits_are_dropped(wobble_mm: float) -> None:
    """Sightings that fit a 20 % wheel ratio (a misassociated or moving "mark"), or that scatter
    ±40 mm around a plausible one, end the window without touching the scale."""
    cal = WheelRatioCalibrator(min_samples=6, cluster_mm=1e4, max_range_mm=1e5)
    eps = 0.01 if wobble_mm else 0.2
    for k in range(8):
        # the pose's x moves −3000k mm per unit scale: so does the mark estimate
        x = -eps * (-3000.0 * k) + (wobble_mm if k % 2 else -wobble_mm)
        cal.add("red", (0.0, 0.0), (x, 1000.0), (-3000.0 * k, 0.0, 0.0))
    assert cal.correction() is None
    assert cal.rejected == 1
    assert cal.scale == 1.0
    assert cal.samples == 0  # a new window


def test_far_sightings_are_ignored_and_colours_are_kept_apart() -> None:
    cal = WheelRatioCalibrator(max_range_mm=3000.0)
    cal.add("red", (0.0, 0.0), (0.0, 3500.0), (0.0, 0.0, 1.0))
    assert cal.samples == 0
    cal.add("red", (0.0, 0.0), (0.0, 1000.0), (0.0, 0.0, 1.0))
    cal.add("green", (0.0, 0.0), (0.0, 1000.0), (0.0, 0.0, 1.0))
    fit = cal.fit()
    assert fit is None  # two marks with one sighting each: nothing to fit yet
    assert cal.samples == 2


def test_the_window_s_fit_is_made_again_whenever_a_sighting_changes_it() -> None:
    """The fit is kept between control cycles that add no sighting, and never outlives one:
    each answer is the closed-form fit of the window as it is."""
    rng = random.Random(4)
    cal = WheelRatioCalibrator(max_range_mm=1e9, cluster_mm=500.0)

    def fresh() -> object:
        return fit_wheel_ratio([(c.points, c.grads) for c in cal._clusters])

    def sighting() -> None:
        mark = rng.choice([(0.0, 1000.0), (2000.0, 1500.0)])
        cal.add("red", (rng.uniform(-300, 300), rng.uniform(-300, 300)),
                (mark[0] + rng.gauss(0, 20), mark[1] + rng.gauss(0, 20)),
                (rng.uniform(-500, 500), rng.uniform(-500, 500), rng.uniform(-2, 2)))

    for _ in range(6):
        sighting()
    first = cal.fit()
    assert first is not None and cal.fit() is first  # nothing added: the same fit
    sighting()
    assert cal.fit() is not first and cal.fit() == fresh()
    count = cal.samples
    cal.reset()
    assert cal.fit() is None
    for _ in range(count):  # as many sightings as before, other ones
        sighting()
    assert cal.samples == count and cal.fit() == fresh() != first
