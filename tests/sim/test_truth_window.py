"""Today's ground truth per waypoint (``waypoint_truth``): the window a waypoint is judged on
ends a little after the tree declared it passed, so what the robot does near that mark much
later (turning back past it for the next waypoint) does not change its verdict.

Engineer i11 is rewriting the ground truth (true-path crossings, per-waypoint physical marks);
the new truth's tests are theirs. This file pins the current rule only.
"""

from __future__ import annotations

import math

import pytest

from marknav.planning.kinematics import Pose
from marknav.sim.environment import GroundTruth, waypoint_truth
from marknav.sim.world import MarkSpec, World

RED = (0.0, 1000.0)


def drive(truth: GroundTruth, t0: float, t1: float, start: tuple[float, float],
          end: tuple[float, float], heading: float) -> None:
    """Straight from ``start`` to ``end`` between ``t0`` and ``t1``, a pose every 0.1 s."""
    n = round((t1 - t0) / 0.1)
    for k in range(n + 1):
        u = k / n
        truth.record(t0 + 0.1 * k, Pose(start[0] + u * (end[0] - start[0]),
                                        start[1] + u * (end[1] - start[1]), heading))


def there_and_back() -> GroundTruth:
    """North along x = −300 past the red mark (on its left, 300 mm off) until t = 8 s, then back
    south along x = +100: 100 mm from the mark at t ≈ 14 s."""
    truth = GroundTruth()
    drive(truth, 0.0, 8.0, (-300.0, 0.0), (-300.0, 1600.0), math.pi / 2)
    drive(truth, 8.1, 10.0, (-300.0, 1600.0), (100.0, 1600.0), 0.0)
    drive(truth, 10.1, 18.0, (100.0, 1600.0), (100.0, 0.0), -math.pi / 2)
    return truth


def test_the_window_ends_three_seconds_after_the_declared_pass() -> None:
    world = World(marks=(MarkSpec(colour="red", x_mm=RED[0], y_mm=RED[1]),))
    truth = there_and_back()
    # declared passed at t = 6 s (y = 1200): judged on t ≤ 9 s, before the return leg
    ((side, clearance, index),) = waypoint_truth(truth, world, ["red"], [6.0])
    assert (side, index) == ("left", 0)
    assert clearance == 300.0
    # declared at t = 15 s instead, the return leg is inside the window: 100 mm
    ((side, clearance, _),) = waypoint_truth(truth, world, ["red"], [15.0])
    assert side == "left" and clearance == 100.0


def test_a_waypoint_never_declared_passed_has_no_side() -> None:
    world = World(marks=(MarkSpec(colour="red", x_mm=RED[0], y_mm=RED[1]),))
    ((side, clearance, index),) = waypoint_truth(there_and_back(), world, ["red"], [None])
    assert (side, index) == (None, 0)
    assert clearance == 100.0  # the whole run


def test_trajectory_windows_are_inclusive_at_both_ends() -> None:
    truth = GroundTruth()
    for k in range(6):
        truth.record(float(k), Pose(10.0 * k, 0.0, 0.5 * k))
    assert truth.theta == [0.0, 0.5, 1.0, 1.5, 2.0, 2.5]
    assert truth.trajectory(1.0, 3.0)[:, 0].tolist() == [10.0, 20.0, 30.0]
    assert truth.trajectory(2.0)[:, 0].tolist() == [20.0, 30.0, 40.0, 50.0]
    assert truth.trajectory(None, 2.0)[:, 0].tolist() == [0.0, 10.0, 20.0]
    assert truth.trajectory(2.5, 2.6).shape == (0, 2)
    assert GroundTruth().trajectory().shape == (0, 2)


def north(truth: GroundTruth, x: float, t0: float, t1: float, y0: float, speed: float) -> None:
    n = round((t1 - t0) / 0.1)
    for k in range(n + 1):
        truth.record(t0 + 0.1 * k, Pose(x, y0 + speed * 0.1 * k, math.pi / 2))


def two_reds() -> tuple[World, GroundTruth]:
    """Two red marks on one line north and a green near the start; the robot drives north at
    x = −300.04 mm (0.1 m/s): 300.04 mm from the reds, 299.96 mm from the green."""
    world = World(marks=(MarkSpec(colour="red", x_mm=0.0, y_mm=1000.0),
                         MarkSpec(colour="red", x_mm=0.0, y_mm=3000.0),
                         MarkSpec(colour="green", x_mm=-600.0, y_mm=200.0)))
    truth = GroundTruth()
    north(truth, -300.04, 0.0, 40.0, 0.0, 100.0)
    return world, truth


def test_each_waypoint_is_the_mark_of_its_colour_nearest_when_declared() -> None:
    world, truth = two_reds()
    # declared at 31 s (y = 3100): the second red, judged from the start (no earlier pass)
    assert waypoint_truth(truth, world, ["red"], [31.0]) == [("left", 300.0, 1)]
    # declared after the end of the record: the robot's last position decides (y = 4000)
    assert waypoint_truth(truth, world, ["red"], [99.0])[0][2] == 1


def test_a_waypoint_never_declared_is_the_next_unused_mark_of_its_colour() -> None:
    world, truth = two_reds()
    # first red declared at 11 s (mark 0); the second red never: mark 1, not mark 0 again
    (first, second) = waypoint_truth(truth, world, ["red", "red"], [11.0, None])
    assert first == ("left", 300.0, 0)
    assert second[0] is None and second[2] == 1


def test_a_waypoint_is_judged_from_the_previous_declared_pass_on() -> None:
    world, truth = two_reds()
    # green stands 300 mm west of the path near its start: after red, declared at 11 s, it is
    # judged from t = 11 s on (y ≥ 1100 mm), far from it
    (_, green) = waypoint_truth(truth, world, ["red", "green"], [11.0, 12.0])
    assert green[2] == 2 and green[1] is not None and green[1] > 900.0
    # the same green as the first waypoint: measured from the start, 300 mm
    ((_, clearance, _),) = waypoint_truth(truth, world, ["green"], [5.0])
    assert clearance == 300.0  # 299.96 mm, to one decimal


def test_a_colour_the_world_lacks_or_an_empty_record_gives_nothing() -> None:
    world, truth = two_reds()
    assert waypoint_truth(truth, world, ["blue", "red"], [3.0, 11.0]) == [
        (None, None, None), ("left", 300.0, 0)]
    assert waypoint_truth(GroundTruth(), world, ["red"], [1.0]) == [(None, None, None)]


def test_route_and_pass_times_must_match() -> None:
    world, truth = two_reds()
    with pytest.raises(ValueError):
        waypoint_truth(truth, world, ["red", "red"], [11.0])
