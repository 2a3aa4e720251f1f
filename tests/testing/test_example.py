"""The example in marknav.testing's docstring (copied into the README) runs as shown."""

import inspect
import textwrap

import py_trees
from py_trees.common import Status

import marknav.testing
from marknav.behaviours.route import build_route_tree
from marknav.testing import tick_until


def test_passes_red_on_its_left(fake_robot, fake_perception, manual_clock,
                                mission_factory, blackboard):
    mission = mission_factory(route=["red"])          # red: pass on its left
    fake_perception.place("red", x_mm=100, y_mm=2000)  # 2 m ahead, a bit to the right
    tree = py_trees.trees.BehaviourTree(
        build_route_tree(mission, perception=fake_perception))
    tree.setup(robot=fake_robot, clock=manual_clock, mission=mission)

    log = tick_until(tree, Status.SUCCESS, max_ticks=400, clock=manual_clock, dt=0.05)

    assert log.reached, log                            # print(log) shows every change
    assert log.visited("Approach") and log.visited("Bypass")
    assert fake_robot.true_pose.x < 100 - 270          # left of the mark, clearance kept
    assert fake_robot.wheels == (0, 0)                 # stopped at the end


def test_docstring_example_is_this_test():
    doc = marknav.testing.__doc__
    assert doc is not None
    example = textwrap.dedent(doc.split("Example — a whole waypoint, approach and bypass, "
                                        "closed loop::")[1]).strip()
    source = inspect.getsource(test_passes_red_on_its_left).strip()
    assert source in example
