"""ApproachWhileCentring: steering sign and ratio, turn-rate cap, slowing, threshold, lost."""

from __future__ import annotations

import dataclasses
import itertools
import math

import py_trees
import pytest
from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.approach import (
    UNSETTLED_THRESHOLD_FLOOR,
    ApproachWhileCentring,
    centring_command,
    keep_clear,
    unsettled_factor,
)
from marknav.behaviours.base import MarknavBehaviour
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


# -- keeping clear of marks already passed ---------------------------------------------------


def test_keep_clear_turns_to_the_tangent_of_an_obstacle_in_the_way() -> None:
    keep = 340.0
    # 1 m ahead, 200 mm left of the straight-ahead ray: turn right to the tangent
    turned = keep_clear(0.0, [(1000.0, 200.0)], keep, reach_mm=3000.0)
    rho, bearing = math.hypot(1000.0, 200.0), math.atan2(200.0, 1000.0)
    assert turned == pytest.approx(bearing - math.asin(keep / rho))
    assert turned < 0.0
    # the new ray passes exactly at the keep-out distance
    assert abs(-1000.0 * math.sin(turned) + 200.0 * math.cos(turned)) == pytest.approx(keep)
    # the mirror case turns left
    assert keep_clear(0.0, [(1000.0, -200.0)], keep, reach_mm=3000.0) == pytest.approx(-turned)


@pytest.mark.parametrize("obstacle", [
    (-300.0, 100.0),   # behind the robot
    (1000.0, 400.0),   # the ray already keeps 400 > 340 mm
    (3500.0, 0.0),     # beyond the target
])
def test_keep_clear_leaves_a_clear_heading_alone(obstacle: tuple[float, float]) -> None:
    assert keep_clear(0.0, [obstacle], 340.0, reach_mm=3000.0) == 0.0


def test_keep_clear_from_inside_the_circle_turns_away_and_the_nearest_obstacle_wins() -> None:
    assert keep_clear(0.0, [(200.0, 50.0)], 340.0, reach_mm=3000.0) == pytest.approx(
        math.atan2(50.0, 200.0) - math.pi / 2)
    far, near = (1500.0, -100.0), (800.0, 150.0)
    assert keep_clear(0.0, [far, near], 340.0, reach_mm=3000.0) == pytest.approx(
        keep_clear(0.0, [near], 340.0, reach_mm=3000.0))


def _passed(colour: str, x: float, y: float) -> keys.PassedWaypoint:
    return keys.PassedWaypoint(waypoint=0, waypoint_id=f"{colour}-0", colour=colour,
                               side="left", t=0.0, mark_x=x, mark_y=y)


@pytest.mark.parametrize(("passed_x", "passed_y", "turns"), [
    (-100.0, 1200.0, True),    # a passed mark 100 mm left of the way ahead: skirt it
    (0.0, 3050.0, False),      # the target itself, passed before (a revisit): not an obstacle
    (-100.0, -600.0, False),   # behind
])
def test_approach_skirts_marks_already_passed(rig, passed_x, passed_y, turns):
    rig.perception.place("red", x_mm=0, y_mm=3000)  # dead ahead, 3 m
    py_trees.blackboard.Blackboard.set(keys.PASSED, (_passed("green", passed_x, passed_y),))
    tree, _ = approach_tree(rig)
    tree.tick()
    cmd = first_command(rig)
    if not turns:
        assert cmd.left == cmd.right
        return
    keep = 300.0 + 40.0  # clearance_mm + bypass_margin_mm
    rho = math.hypot(passed_x, passed_y)
    angle = math.atan2(-passed_x, passed_y) - math.asin(keep / rho)  # to the right
    assert cmd.left > cmd.right
    omega = max(-math.radians(60.0), min(math.radians(60.0), 2.0 * angle))
    assert (cmd.right - cmd.left) / 235.0 == pytest.approx(omega, abs=0.01)


def test_approach_skirts_a_remembered_mark_nearer_than_the_target(rig):
    """Long-course seed 3: heading for a far mark, the robot drove into a nearer one of another
    colour. Marks the camera has seen are obstacles too."""
    rig.perception.place("red", x_mm=0, y_mm=3000)
    blue = keys.KnownMark("blue", -100.0, 1200.0, t=0.0, range_mm=1204.0, seen=3)
    py_trees.blackboard.Blackboard.set(keys.KNOWN, (blue,))
    tree, _ = approach_tree(rig)
    tree.tick()
    cmd = first_command(rig)
    assert cmd.left > cmd.right  # turning right, around the blue mark on its left


class _Unsettled(MarknavBehaviour):
    """Stands in for perception's range learner: the frame says how uncertain the law is."""

    READS = (keys.FRAME,)
    WRITES = (keys.FRAME,)

    def __init__(self, sigma: float) -> None:
        super().__init__("Unsettled")
        self.sigma = sigma

    def update(self) -> Status:
        frame = self.read(keys.FRAME)
        if frame is not None:
            self.write(keys.FRAME, dataclasses.replace(frame, range_sigma=self.sigma))
        return Status.SUCCESS


@pytest.mark.parametrize(("sigma", "threshold"),
                         [(0.0, 800.0), (0.02, 800.0 * math.exp(-0.02)), (0.3, 600.0)])
def test_an_unsettled_range_law_holds_the_bypass_decision(rig, sigma, threshold):
    rig.perception.place("red", x_mm=0, y_mm=2500)
    node = ApproachWhileCentring()
    root = py_trees.composites.Sequence("Root", memory=False, children=[
        rig.perception, _Unsettled(sigma), SelectTarget(colour="red", waypoint=0), node])
    log = rig.run(rig.tree(root), max_ticks=300)
    assert log.reached
    y = rig.robot.true_pose.y
    assert 2500 - threshold <= y < 2500 - threshold + 0.05 * 205


def test_unsettled_factor() -> None:
    frame = keys.FrameInfo(index=0, t=0.0, width=640, height=480, marks=1)
    assert unsettled_factor(None) == unsettled_factor(frame) == 1.0
    assert unsettled_factor(dataclasses.replace(frame, range_sigma=0.1)) == pytest.approx(
        math.exp(-0.1))
    assert unsettled_factor(dataclasses.replace(frame, range_sigma=3.0)) == (
        UNSETTLED_THRESHOLD_FLOOR)
