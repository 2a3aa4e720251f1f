"""Wiggle, tested with marknav's kit: the fixtures come from marknav's pytest plugin."""

from __future__ import annotations

import py_trees
from marknav_wiggle import Wiggle, WiggleParams
from py_trees.common import Status

from marknav.testing import tick_until


def test_swings_left_right_left_then_stops(fake_robot, manual_clock, mission_factory,
                                            blackboard):
    mission = mission_factory(robot={"wheel_base_mm": 240})
    tree = py_trees.trees.BehaviourTree(
        Wiggle(params=WiggleParams(swings=3, turn_deg_s=60, swing_s=0.5)))
    tree.setup(robot=fake_robot, clock=manual_clock, mission=mission)

    log = tick_until(tree, Status.SUCCESS, max_ticks=100, clock=manual_clock, dt=0.05)

    assert log.reached, log
    assert 1.5 <= manual_clock.now() <= 1.55  # 3 swings of 0.5 s
    drives = [r for r in fake_robot.requests if r.kind == "drive"]
    signs = []
    for r in drives:
        assert abs(r.left + r.right) < 1e-9  # on the spot
        assert abs(abs(r.right) - 125.66) < 0.01  # 60 °/s × 240 mm / 2
        sign = 1 if r.right > 0 else -1
        if not signs or signs[-1] != sign:
            signs.append(sign)
    assert signs == [1, -1, 1]  # left, right, left
    assert fake_robot.wheels == (0, 0)  # stopped when done
