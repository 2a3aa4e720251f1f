"""The real perception pipeline in the loop: simulator camera → detector → estimate → tree."""

from __future__ import annotations

import math

import py_trees
from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.route import build_route_tree
from marknav.sim.builtin_camera import SimCamera
from marknav.sim.world import MarkSpec, World
from marknav.testing import tick_until


def test_passes_a_rendered_mark_with_the_real_detector(blackboard, fake_robot, manual_clock,
                                                       mission_factory):
    mission = mission_factory(route=["green"])  # pass on its right
    world = World(marks=(MarkSpec(colour="green", x_mm=-150.0, y_mm=1500.0),))
    camera = SimCamera(world, mission.palette(), pose_fn=lambda: fake_robot.true_pose,
                       clock=manual_clock)
    tree = py_trees.trees.BehaviourTree(build_route_tree(mission))
    tree.setup(robot=fake_robot, clock=manual_clock, mission=mission, camera=camera)
    log = tick_until(tree, Status.SUCCESS, max_ticks=300, clock=manual_clock)
    assert log.reached, log
    first = keys.snapshot()[keys.PLANS][0].plan.mark_xy
    assert math.dist(first, (-150.0, 1500.0)) < 30.0  # estimated from pixels at 0.8 m
    clearance = min(math.hypot(p.x + 150.0, p.y - 1500.0) for _, p in fake_robot.trajectory)
    assert clearance >= 270.0
    assert fake_robot.true_pose.x > -150.0  # on the mark's right (clearance checked above)
