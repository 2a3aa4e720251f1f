"""A small rig around marknav's test kit: a fake robot, fake perception and a mission."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import py_trees
import pytest
from py_trees.behaviour import Behaviour
from py_trees.common import Status

from marknav.core.clock import ManualClock
from marknav.missions.schema import Mission
from marknav.testing import FakePerception, FakeRobot, TickLog, tick_until


@dataclass
class Rig:
    robot: FakeRobot
    clock: ManualClock
    perception: FakePerception
    mission: Mission

    def tree(self, root: Behaviour, **setup: Any) -> py_trees.trees.BehaviourTree:
        tree = py_trees.trees.BehaviourTree(root)
        kwargs: dict[str, Any] = {"robot": self.robot, "clock": self.clock,
                                  "mission": self.mission, **setup}
        tree.setup(**kwargs)
        return tree

    def run(self, tree: py_trees.trees.BehaviourTree, status: Status = Status.SUCCESS, *,
            max_ticks: int = 600, dt: float = 0.05) -> TickLog:
        return tick_until(tree, status, max_ticks=max_ticks, clock=self.clock, dt=dt)

    @staticmethod
    def bb(key: str, default: Any = None) -> Any:
        bb = py_trees.blackboard.Blackboard
        return bb.get(key) if bb.exists(key) else default


@pytest.fixture
def rig(blackboard: None, fake_robot: FakeRobot, fake_perception: FakePerception,
        manual_clock: ManualClock, mission_factory: Callable[..., Mission]) -> Rig:
    return Rig(fake_robot, manual_clock, fake_perception, mission_factory())


def tick_while(rig: Rig, tree: py_trees.trees.BehaviourTree,
               until: Callable[[], bool], *, max_ticks: int = 400, dt: float = 0.05) -> int:
    """Advance the clock and tick until ``until()`` holds (checked after each tick); return the
    number of ticks. Fails the test if it never holds."""
    for i in range(max_ticks):
        rig.clock.advance(dt)
        tree.tick()
        if until():
            return i + 1
    raise AssertionError(f"condition not met in {max_ticks} ticks")
