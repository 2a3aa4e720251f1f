"""Today's ground truth per waypoint (``waypoint_truth``): the window a waypoint is judged on
ends a little after the tree declared it passed, so what the robot does near that mark much
later (turning back past it for the next waypoint) does not change its verdict.

Engineer i11 is rewriting the ground truth (true-path crossings, per-waypoint physical marks);
the new truth's tests are theirs. This file pins the current rule only.
"""

from __future__ import annotations

import math

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
