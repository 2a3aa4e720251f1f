"""Odometry from encoder counts (Create 2) and distance/angle (Create 1)."""

from __future__ import annotations

import math

import pytest

from marknav.planning.kinematics import Pose
from marknav.robot.odometry import MM_PER_COUNT, Odometry, counts_delta, counts_to_mm
from marknav.robot.packets import Model, SensorState


def test_counts_delta_wraps_the_short_way() -> None:
    assert counts_delta(5, 3) == 2
    assert counts_delta(-32768, 32767) == 1
    assert counts_delta(32767, -32768) == -1
    assert counts_delta(-32000, 32000) == 1536


def test_mm_per_count_is_the_spec_formula() -> None:
    assert counts_to_mm(508.8) == pytest.approx(math.pi * 72.0)
    assert pytest.approx(0.44456, abs=1e-5) == MM_PER_COUNT


def test_create2_first_counts_are_the_reference_then_straight_line() -> None:
    odo = Odometry(Model.CREATE2)
    start = odo.pose
    odo.update(SensorState(encoder_left=30000, encoder_right=30000))
    assert odo.pose == start
    odo.update(SensorState(encoder_left=-30000, encoder_right=-30000))  # +5536 counts, wrapped
    assert odo.pose.y == pytest.approx(5536 * MM_PER_COUNT)
    assert odo.pose.x == pytest.approx(0.0, abs=1e-9)
    assert odo.distance_mm == pytest.approx(5536 * MM_PER_COUNT)


def test_create2_spin_in_place_turns_by_arc_over_wheel_base() -> None:
    odo = Odometry(Model.CREATE2, pose=Pose(0.0, 0.0, 0.0))
    odo.update(SensorState(encoder_left=0, encoder_right=0))
    counts = round(0.5 * math.pi * 235.0 / 2 / MM_PER_COUNT)  # quarter turn: each wheel πb/4
    odo.update(SensorState(encoder_left=-counts, encoder_right=counts))
    assert odo.pose.theta == pytest.approx(math.pi / 2, abs=0.005)
    assert math.hypot(odo.pose.x, odo.pose.y) < 1e-6


def test_create1_uses_distance_and_angle() -> None:
    odo = Odometry(Model.CREATE1, pose=Pose(0.0, 0.0, 0.0))
    odo.update(SensorState(model=Model.CREATE1, distance_mm=100, angle_deg=0))
    assert (odo.pose.x, odo.pose.y) == pytest.approx((100.0, 0.0))
    odo.update(SensorState(model=Model.CREATE1, distance_mm=0, angle_deg=90))
    assert odo.pose.theta == pytest.approx(math.pi / 2)
    odo.update(SensorState(model=Model.CREATE1, distance_mm=50, angle_deg=0))
    assert (odo.pose.x, odo.pose.y) == pytest.approx((100.0, 50.0))


def test_reset_keeps_the_encoder_reference() -> None:
    odo = Odometry(Model.CREATE2)
    odo.update(SensorState(encoder_left=100, encoder_right=100))
    odo.update(SensorState(encoder_left=200, encoder_right=200))
    odo.reset(Pose(1.0, 2.0, 0.0))
    assert odo.pose == Pose(1.0, 2.0, 0.0) and odo.distance_mm == 0.0
    odo.update(SensorState(encoder_left=300, encoder_right=300))
    assert odo.pose.x == pytest.approx(1.0 + 100 * MM_PER_COUNT)
