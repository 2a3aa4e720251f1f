"""The pose history: where the robot was at a frame's capture time."""

from __future__ import annotations

import math

import pytest

from marknav.planning.kinematics import Pose
from marknav.planning.pose_history import PoseHistory, interpolate_pose


def test_interpolates_between_the_samples_around_the_time() -> None:
    h = PoseHistory()
    h.add(1.0, Pose(0.0, 0.0, 0.0), (0.0,))
    h.add(1.1, Pose(20.0, 10.0, 0.2), (2.0,))
    at = h.at(1.025)
    assert at is not None and at.clamped_s == 0.0
    assert (at.pose.x, at.pose.y, at.pose.theta) == (pytest.approx(5.0), pytest.approx(2.5),
                                                      pytest.approx(0.05))
    assert at.extra == (pytest.approx(0.5),)


def test_the_heading_turns_the_short_way_across_pi() -> None:
    p = interpolate_pose(Pose(0.0, 0.0, math.pi - 0.1), Pose(0.0, 0.0, -math.pi + 0.1), 0.5)
    assert abs(abs(p.theta) - math.pi) < 1e-9  # through π, not through 0


def test_outside_the_history_the_nearest_sample_stands_in_and_says_how_far() -> None:
    h = PoseHistory()
    assert h.at(0.0) is None
    h.add(2.0, Pose(1.0, 2.0, 0.0))
    h.add(2.05, Pose(3.0, 2.0, 0.0))
    before = h.at(1.5)
    after = h.at(2.3)
    assert before is not None and before.pose == Pose(1.0, 2.0, 0.0)
    assert before.clamped_s == pytest.approx(0.5)
    assert after is not None and after.pose == Pose(3.0, 2.0, 0.0)
    assert after.clamped_s == pytest.approx(0.25)


def test_keeps_its_span_and_a_repeated_time_replaces_the_newest() -> None:
    h = PoseHistory(span_s=0.5)
    for k in range(21):  # 0 .. 1 s every 50 ms
        h.add(0.05 * k, Pose(10.0 * k, 0.0, 0.0))
    assert len(h) <= 12  # 0.5 s at 20 Hz, plus the sample straddling the span's start
    assert h.at(0.7) is not None and h.at(0.7).clamped_s == 0.0  # type: ignore[union-attr]
    h.add(1.0, Pose(999.0, 0.0, 0.0))  # the same tick again: the newer reading wins
    assert h.at(1.0).pose.x == 999.0  # type: ignore[union-attr]
    with pytest.raises(ValueError):
        PoseHistory(span_s=0.0)
