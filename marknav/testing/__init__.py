"""Fakes and pytest fixtures for testing behaviours with mocked perception and a fake robot.

Installing marknav registers a pytest plugin (entry point ``pytest11``) with these fixtures:

- ``manual_clock`` — a :class:`~marknav.core.clock.ManualClock` at t = 0;
- ``fake_robot`` — a :class:`FakeRobot` on that clock, connected, at the origin facing +y;
- ``fake_perception`` — a :class:`FakePerception` (named ``Perception``) with no marks yet;
- ``blackboard`` — clears py_trees' process-global blackboard before and after the test;
- ``mission_factory`` — :func:`make_mission`: a minimal valid mission, with overrides;
- ``tree_coverage`` — a :class:`TreeCoverage` of the test's ticks: which nodes ticked, with
  which outcomes (``pytest --marknav-coverage``: the whole session's, summed up at the end).

:func:`tick_until` ticks a tree (advancing the clock) until a status, recording every tick.

Example — a whole waypoint, approach and bypass, closed loop::

    import py_trees
    from py_trees.common import Status

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
"""

from marknav.core.clock import ManualClock
from marknav.testing.coverage import NodeCoverage, TreeCoverage
from marknav.testing.missions import BASE_MISSION, make_mission
from marknav.testing.perception import FakePerception, RobotMark, WorldMark, pinhole_pixels
from marknav.testing.robot import DriveRequest, FakeRobot, WheelCommand
from marknav.testing.ticking import TickLog, TickRecord, active_path, tick_until

__all__ = [
    "BASE_MISSION",
    "DriveRequest",
    "FakePerception",
    "FakeRobot",
    "ManualClock",
    "NodeCoverage",
    "RobotMark",
    "TickLog",
    "TickRecord",
    "TreeCoverage",
    "WheelCommand",
    "WorldMark",
    "active_path",
    "make_mission",
    "pinhole_pixels",
    "tick_until",
]
