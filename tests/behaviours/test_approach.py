"""ApproachWhileCentring: steering sign and ratio, turn-rate cap, slowing, threshold, lost."""

from __future__ import annotations

import itertools
import math

import py_trees
import pytest
from py_trees.common import Status

from marknav.behaviours.approach import ApproachWhileCentring, centring_command
from marknav.behaviours.target import SelectTarget


def approach_tree(rig, **kwargs):
    node = ApproachWhileCentring(**kwargs)
    root = py_trees.composites.Sequence("Root", memory=False, children=[
        rig.perception, SelectTarget(colour="red", waypoint=0), node])
    return rig.tree(root), node


def first_command(rig):
    moving = [c for c in rig.robot.commands if (c.left, c.right) != (0, 0)]
    return moving[0]


@pytest.mark.parametrize("x_mm", [300.0, -300.0, 0.0])
def test_steers_toward_the_mark_with_the_expected_wheel_speeds(rig, x_mm):
    rig.perception.place("red", x_mm=x_mm, y_mm=2000)  # robot at the origin facing +y
    tree, node = approach_tree(rig)
    tree.tick()
    assert node.status == Status.RUNNING
    cmd = first_command(rig)
    angle = math.atan2(-x_mm, 2000.0)  # pixel error -> angle off-centre (left positive)
    v = 250.0 * math.cos(angle)
    omega = 2.0 * angle
    assert (cmd.left, cmd.right) == (round(v - omega * 117.5), round(v + omega * 117.5))
    if x_mm > 0:
        assert cmd.left > cmd.right  # mark to the right: turn right
        assert node.feedback_message == "red #1: 2.00 m ahead, 9° right, 247 mm/s"
    elif x_mm < 0:
        assert cmd.right > cmd.left
    else:
        assert cmd.left == cmd.right == 250


def test_turn_rate_is_capped(rig):
    rig.perception.place("red", x_mm=-800, y_mm=2000)  # 22° left
    tree, _ = approach_tree(rig, steer_gain=10.0, max_turn_rate_deg_s=30.0)
    tree.tick()
    cmd = first_command(rig)
    assert (cmd.right - cmd.left) / 235.0 == pytest.approx(math.radians(30.0), abs=0.01)


def test_centring_command_scales_both_wheels_together():
    cmd = centring_command(angle_rad=0.3, forward_mm=3000, speed_mm_s=300,
                           bypass_distance_mm=800, steer_gain=2.0, max_turn_rate=2.0,
                           slow_band_mm=500, min_speed_fraction=0.8, wheel_base_mm=235,
                           max_wheel_mm_s=300)
    raw_left = 300 * math.cos(0.3) - 0.6 * 117.5
    raw_right = 300 * math.cos(0.3) + 0.6 * 117.5
    assert cmd.right == pytest.approx(300.0)
    assert cmd.left / cmd.right == pytest.approx(raw_left / raw_right)


def test_slows_near_the_threshold_and_succeeds_there(rig):
    rig.perception.place("red", x_mm=0, y_mm=2500)
    tree, node = approach_tree(rig)
    log = rig.run(tree, max_ticks=200)
    assert log.reached
    forward = [c.left for c in rig.robot.commands if c.left > 0]
    assert forward[0] == 250  # cruising
    assert 195 <= forward[-1] <= 205  # 0.8 × 250 at the threshold
    assert all(a >= b for a, b in itertools.pairwise(forward))  # never speeds up
    y = rig.robot.true_pose.y
    assert 2500 - 800 <= y < 2500 - 800 + 0.05 * 205  # the first tick within 800 mm
    assert node.feedback_message == (f"red #1 at {(2500 - y) / 1000:.2f} m: "
                                     "bypass threshold reached")
    assert rig.robot.wheels == (0, 0)  # nobody took over: stopped


def test_fails_when_the_target_is_lost_and_stops(rig):
    mark = rig.perception.place("red", x_mm=100, y_mm=3000)
    tree, node = approach_tree(rig)
    log = rig.run(tree, Status.RUNNING, max_ticks=1)
    for _ in range(4):
        rig.clock.advance(0.05)
        tree.tick()
    rig.perception.world.remove(mark)  # last seen at t = 0.2
    log = rig.run(tree, Status.FAILURE, max_ticks=40)
    assert log.reached
    assert log.records[-1].t == pytest.approx(0.2 + 0.55)  # first tick unseen > 0.5 s
    assert node.feedback_message == "lost red #1: unseen for 0.55 s"
    # it kept driving toward the dead-reckoned mark meanwhile, then stopped
    moving_after = [c for c in rig.robot.commands if c.t > 0.2 and c.left > 0]
    assert len(moving_after) >= 9
    assert rig.robot.wheels == (0, 0)


@pytest.mark.parametrize(("colour", "sign"), [("red", 1.0), ("green", -1.0)])
def test_side_aim_heads_for_the_pass_point(rig, mission_factory, colour, sign):
    # red is passed on its left (aim left of it), green on its right (aim right of it).
    rig.mission = mission_factory(navigation={"approach_aim": "side"})
    rig.perception.place(colour, x_mm=0, y_mm=2000)  # dead ahead
    node = ApproachWhileCentring()
    root = py_trees.composites.Sequence("Root", memory=False, children=[
        rig.perception, SelectTarget(colour=colour, waypoint=0), node])
    tree = rig.tree(root)
    tree.tick()
    cmd = first_command(rig)
    angle = sign * math.atan2(300.0, 2000.0)  # clearance beside the mark, on its pass side
    v = 250.0 * math.cos(angle)
    assert (cmd.left, cmd.right) == (round(v - 2.0 * angle * 117.5),
                                     round(v + 2.0 * angle * 117.5))
