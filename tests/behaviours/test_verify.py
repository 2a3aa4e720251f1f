"""Verify: a doubtful pass is looked back at and confirmed, refuted or left unverified; a sure
pass is done at once; the route's Passed? waits for the check."""

from __future__ import annotations

import math

import py_trees
import pytest
from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.bypass import BezierBypass
from marknav.behaviours.target import SelectTarget, WaypointPassed
from marknav.behaviours.verify import CONFIRMED, REFUTED, UNVERIFIED, VerifyPass, decide_side

NORTH = math.pi / 2
#: Where the robot believes the red mark it just passed on its left is: behind it, on its right.
BELIEVED = (300.0, -325.0)
DOUBT = "not seen since the bypass began"


def passed_red(doubt: str | None = DOUBT) -> None:
    bb = py_trees.blackboard.Blackboard
    bb.set(keys.TARGET, keys.Target(waypoint=0, waypoint_id="waypoint-0-red", colour="red",
                                    side="left", world_x=BELIEVED[0], world_y=BELIEVED[1],
                                    locked=True))
    bb.set(keys.PASSED, (keys.PassedWaypoint(0, "waypoint-0-red", "red", "left", 0.0,
                                             *BELIEVED, doubt=doubt),))


def verify_tree(rig):
    node = VerifyPass()
    passed = WaypointPassed(waypoint_id="waypoint-0-red", wait_for_check=True)
    root = py_trees.composites.Sequence("Root", memory=False, children=[rig.perception, node])
    return rig.tree(root), node, passed


def record():
    (r,) = py_trees.blackboard.Blackboard.get(keys.PASSED)
    return r


def test_the_median_offset_decides() -> None:
    assert decide_side([300.0, 280.0, -50.0], 100.0) == CONFIRMED
    assert decide_side([-300.0, -280.0, 40.0], 100.0) == REFUTED
    assert decide_side([60.0, -20.0, 30.0], 100.0) is None  # on the line driven
    assert decide_side([], 100.0) is None


def test_a_pass_without_doubt_is_done_at_once(rig):
    passed_red(doubt=None)
    tree, node, _ = verify_tree(rig)
    rig.clock.advance(0.05)
    tree.tick()
    assert node.status == Status.SUCCESS
    assert node.feedback_message == ""  # the bypass's message stands for the waypoint
    assert rig.robot.wheels == (0, 0) and record().check is None


def test_looking_back_confirms_a_pass_and_turns_back_to_the_course(rig):
    rig.perception.place("red", x_mm=BELIEVED[0], y_mm=BELIEVED[1])
    passed_red()
    tree, node, passed = verify_tree(rig)
    rig.clock.advance(0.05)
    tree.tick()
    assert node.status == Status.RUNNING
    assert rig.robot.wheels[0] > 0 > rig.robot.wheels[1]  # turning right, toward the mark
    passed.setup(robot=rig.robot, clock=rig.clock, mission=rig.mission)
    assert passed.tick_once() is None and passed.status == Status.FAILURE  # not checked yet
    log = rig.run(tree, max_ticks=400)
    assert log.reached, log
    assert record().check == CONFIRMED
    assert node.feedback_message.startswith("red #1: pass confirmed looking back (3 sightings, "
                                            "median +300 mm on its side)")
    assert math.degrees(abs(rig.robot.pose().theta - NORTH)) <= 5.0  # back on the course
    passed.tick_once()
    assert passed.status == Status.SUCCESS


def test_looking_back_refutes_a_pass_on_the_wrong_side(rig):
    # the mark is in truth across the line driven: the robot passed it on its right
    rig.perception.place("red", x_mm=-BELIEVED[0], y_mm=BELIEVED[1])
    passed_red()
    tree, node, passed = verify_tree(rig)
    log = rig.run(tree, Status.FAILURE, max_ticks=400)
    assert log.reached, log
    assert record().check == REFUTED
    assert node.feedback_message.startswith(
        "red #1 passed on its wrong side: looking back, 3 sightings put it -300 mm to its left "
        "side of the course (doubt was: not seen since the bypass began)")
    assert rig.robot.wheels == (0, 0)
    passed.setup(robot=rig.robot, clock=rig.clock, mission=rig.mission)
    passed.tick_once()
    assert passed.status == Status.FAILURE  # a refuted pass never counts


def test_nothing_seen_looking_back_leaves_the_pass_unverified(rig):
    passed_red()
    tree, node, _ = verify_tree(rig)
    log = rig.run(tree, max_ticks=400)
    assert log.reached, log
    assert record().check == UNVERIFIED
    assert node.feedback_message == f"red #1: unverified (0 sightings, median none); doubt: {DOUBT}"
    # it swept from the believed place through behind to its mirror image, then came back
    headings = [p.theta for _, p in rig.robot.trajectory]
    assert min(math.sin(h) for h in headings) == pytest.approx(-1.0, abs=0.01)  # faced south
    assert math.degrees(abs(rig.robot.pose().theta - NORTH)) <= 5.0
    assert log.records[-1].t <= rig.mission.navigation.verify_pass.timeout_s


def test_without_look_back_a_doubtful_pass_is_unverified_at_once(rig):
    rig.mission = rig.mission.model_copy(update={"navigation": rig.mission.navigation.model_copy(
        update={"verify_pass": rig.mission.navigation.verify_pass.model_copy(
            update={"look_back": False})})})
    passed_red()
    tree, node, _ = verify_tree(rig)
    rig.clock.advance(0.05)
    tree.tick()
    assert node.status == Status.SUCCESS and record().check == UNVERIFIED
    assert rig.robot.wheels == (0, 0)


def test_a_bypass_planned_on_a_misplaced_estimate_is_refuted_looking_back(rig):
    """The bypass of test_bypass_doubt: planned from an estimate 650 mm east of the real mark,
    which stays out of view during the bypass, so the pass is doubtful; looking back finds the
    real mark on the robot's left — a pass on its right, the wrong side — and the waypoint fails
    instead of being reported passed."""
    rig.perception.place("red", x_mm=-700.0, y_mm=800.0)  # the real mark
    estimate = keys.SeenMark("red", 800.0, 50.0, -50.0, 800.0, 319.5 + 590.0 * 50.0 / 800.0,
                             74.0, 640, 0.0)
    bb = py_trees.blackboard.Blackboard
    bb.set(keys.TARGET, keys.Target(waypoint=0, waypoint_id="waypoint-0-red", colour="red",
                                    side="left", sighting=estimate, world_x=-50.0,
                                    world_y=800.0))
    bb.set(keys.FRAME, keys.FrameInfo(index=1, t=0.0, width=640, height=480, marks=1))
    verify = VerifyPass()
    pass_ = py_trees.composites.Sequence("Pass", memory=True, children=[
        SelectTarget(colour="red", waypoint=0), BezierBypass(margin_mm=0.0), verify])
    root = py_trees.composites.Sequence("Root", memory=False, children=[rig.perception, pass_])
    tree = rig.tree(root)
    log = rig.run(tree, Status.FAILURE, max_ticks=600)
    assert log.reached, log
    assert record().doubt is not None and record().check == REFUTED
    assert verify.feedback_message.startswith("red #1 passed on its wrong side: looking back")
