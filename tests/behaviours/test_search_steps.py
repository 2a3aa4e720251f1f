"""The search's steps after a full turn: Return (back to where the target was seen, or toward
where the route predicts it) and Advance (on along the course), each found or given up with
the whole search's story, with scripted perception."""

from __future__ import annotations

import math

import py_trees
import pytest
from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.route import search_strategy
from marknav.behaviours.search_steps import predicted_mark
from marknav.behaviours.target import SelectTarget
from marknav.planning.kinematics import Pose
from marknav.testing import FakeRobot

NORTH = math.pi / 2


def strategy_tree(rig, colour="red"):
    search = search_strategy()
    root = py_trees.composites.Sequence("Root", memory=False, children=[
        rig.perception, SelectTarget(colour=colour, waypoint=0), search])
    return rig.tree(root), search


def seen_before(colour: str, x: float, y: float, range_mm: float) -> None:
    """The target, last seen (before the test's clock starts) at (x, y) from ``range_mm``."""
    sighting = keys.SeenMark(colour, range_mm, 0.0, x, y, 319.5, 590.0 * 100.0 / range_mm,
                             640, -1.0)
    py_trees.blackboard.Blackboard.set(keys.TARGET, keys.Target(
        waypoint=0, waypoint_id="waypoint-0-" + colour, colour=colour, side="left",
        sighting=sighting, world_x=x, world_y=y))


def steps(search):
    spin, back, advance = search.children
    return spin, back, advance


def test_a_mark_lost_right_behind_is_found_again_by_backing_away_from_it(rig):
    # 230 mm behind the robot: too near for its disc to fit the image from any heading (it
    # needs 247 mm), so a turn on the spot never sees it whole
    rig.perception.place("red", x_mm=0.0, y_mm=-230.0)
    seen_before("red", 0.0, -230.0, 1200.0)
    tree, search = strategy_tree(rig)
    spin, back, advance = steps(search)
    log = rig.run(tree, max_ticks=600)
    assert log.reached, log
    # (a Selector with memory resets a failed child once the next one runs: its message stays)
    assert spin.feedback_message.startswith("red #1 not found in a full turn")
    assert back.status == Status.SUCCESS and advance.status == Status.INVALID
    assert back.feedback_message.startswith("found red #1 (drive")
    # it turned to face the mark (south), then reversed away from it (north, wheels backward)
    pose = rig.robot.pose()
    assert math.degrees(abs(pose.theta + NORTH)) <= 5.0
    assert any(r.left < 0 and r.right < 0 for r in rig.robot.requests)
    assert 250.0 <= math.hypot(pose.x, pose.y + 230.0) <= 290.0


def test_a_mark_too_far_to_see_is_found_by_advancing_along_the_course(rig):
    rig.perception.min_radius_px = 30.0  # seen from 1967 mm at most
    rig.perception.place("green", x_mm=0.0, y_mm=2700.0)
    tree, search = strategy_tree(rig, "green")
    spin, back, advance = steps(search)
    log = rig.run(tree, max_ticks=800)
    assert log.reached, log
    assert spin.feedback_message.startswith("green #1 not found in a full turn")
    # never seen, nothing passed: nothing to return to
    assert back.feedback_message.endswith(
        "return: never seen, and fewer than two marks passed to predict it from")
    assert advance.status == Status.SUCCESS
    pose = rig.robot.pose()
    # north, the heading the search began with, until the mark was 1967 mm ahead
    assert pose.x == pytest.approx(0.0, abs=5.0)
    assert 2700.0 - pose.y == pytest.approx(1967.0, abs=15.0)


def test_the_route_predicts_a_mark_never_seen_and_return_drives_toward_it(rig):
    rig.perception.min_radius_px = 30.0  # seen from 1967 mm at most
    rig.robot = FakeRobot(clock=rig.clock, pose=Pose(300.0, 2700.0, NORTH))  # just past #2
    passed = (keys.PassedWaypoint(0, "w0", "blue", "left", 1.0, 0.0, 0.0),
              keys.PassedWaypoint(1, "w1", "green", "right", 2.0, 0.0, 2500.0))
    py_trees.blackboard.Blackboard.set(keys.PASSED, passed)
    assert predicted_mark(passed) == (0.0, 5000.0)  # one more step of 2.5 m
    rig.perception.place("red", x_mm=200.0, y_mm=5100.0)  # 2.4 m away: too far to see
    tree, search = strategy_tree(rig)
    spin, back, advance = steps(search)
    log = rig.run(tree, max_ticks=800)
    assert log.reached, log
    assert spin.feedback_message.startswith("red #1 not found in a full turn")
    assert back.status == Status.SUCCESS and advance.status == Status.INVALID
    pose = rig.robot.pose()
    assert math.hypot(pose.x - 200.0, pose.y - 5100.0) == pytest.approx(1967.0, abs=20.0)
    assert pose.y > 2900.0  # it drove toward the prediction


def test_the_search_gives_up_with_what_every_step_did(rig):
    seen_before("red", 0.0, 1500.0, 1500.0)  # last seen straight ahead; it is not there now
    tree, search = strategy_tree(rig)
    _, _, advance = steps(search)
    log = rig.run(tree, Status.FAILURE, max_ticks=1200)
    assert log.reached, log
    assert search.status == advance.status == Status.FAILURE
    message = advance.feedback_message
    assert message.startswith("red #1 not found; gave up after spin: not found in a full turn")
    assert "; return: not seen in a full turn after driving 0 mm; advance: not seen in a " \
           "full turn after driving 10" in message
    assert rig.robot.wheels == (0, 0)


def test_a_leg_stops_short_of_a_mark_it_knows(rig):
    # a blue mark passed before, straight ahead of the course
    py_trees.blackboard.Blackboard.set(keys.PASSED, (
        keys.PassedWaypoint(0, "w0", "blue", "left", 1.0, 0.0, 600.0),))
    tree, search = strategy_tree(rig, "green")
    _, _, advance = steps(search)
    rig.run(tree, Status.FAILURE, max_ticks=1200)
    # the robot's disc (165 mm) and the mark's (100 mm) plus 100 mm: it stops 365 mm short
    assert "stopped 36" in advance.feedback_message and "from a mark at (0, 600)" in \
        advance.feedback_message
    closest = min(math.hypot(p.x, p.y - 600.0) for _, p in rig.robot.trajectory)
    assert closest >= 355.0


def test_steps_left_out_fail_at_once(rig):
    rig.mission = rig.mission.model_copy(update={"navigation": rig.mission.navigation.model_copy(
        update={"search": rig.mission.navigation.search.model_copy(
            update={"return_distance_mm": 0.0, "advance_distance_mm": 0.0})})})
    tree, search = strategy_tree(rig)
    log = rig.run(tree, Status.FAILURE, max_ticks=400)
    assert log.records[-1].t == pytest.approx(9.0, abs=0.06)  # the spin alone, as before
    assert search.children[2].feedback_message.endswith(
        "return: left out (return_distance_mm 0); advance: left out (advance_distance_mm 0)")
