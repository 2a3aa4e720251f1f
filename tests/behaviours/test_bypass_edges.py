"""BezierBypass at its edges: settings and their errors, the start without a target or an
estimate, resuming beside the mark, the clearance fallbacks, and which sightings re-plan.

Written against the mutants mutmut left alive in behaviours/bypass.py (docs/mutation.md).
"""

from __future__ import annotations

import math
import re

import py_trees
import pytest
from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.base import SetupError
from marknav.behaviours.bypass import BezierBypass, behind_of, lateral_of
from marknav.behaviours.target import SelectTarget
from marknav.planning.kinematics import Pose, to_robot_frame
from marknav.testing import FakeRobot

BB = py_trees.blackboard.Blackboard


def red_target(**kw: object) -> keys.Target:
    base: dict[str, object] = {"waypoint": 0, "waypoint_id": "waypoint-0-red", "colour": "red",
                               "side": "left"}
    return keys.Target(**{**base, **kw})  # type: ignore[arg-type]


def alone(rig, **kwargs):
    """The bypass alone (no perception): the target comes from the blackboard."""
    kwargs.setdefault("margin_mm", 0.0)
    node = BezierBypass(**kwargs)
    return rig.tree(node), node


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"exit_mm": -1.0}, "exit_mm must be >= 0, got -1.0"),
    ({"exit_mm": math.inf}, "exit_mm must be >= 0, got inf"),
    ({"replan_ratio": 0.0}, "replan_ratio must be in (0, 1], got 0.0"),
    ({"replan_ratio": 1.5}, "replan_ratio must be in (0, 1], got 1.5"),
    ({"replan_min_shift_mm": -5.0}, "replan_min_shift_mm must be >= 0, got -5.0"),
    ({"replan_min_shift_mm": math.nan}, "replan_min_shift_mm must be >= 0, got nan"),
    ({"clearance_mm": 0.0}, "clearance_mm must be a positive number, got 0.0"),
    ({"speed_mm_s": -1.0}, "speed_mm_s must be a positive number, got -1.0"),
    ({"lookahead_mm": math.nan}, "lookahead_mm must be a positive number, got nan"),
])
def test_bad_settings_are_named(kwargs, message):
    with pytest.raises(ValueError) as exc:
        BezierBypass(**kwargs)
    assert str(exc.value) == message


def test_limits_of_the_settings_are_accepted():
    node = BezierBypass(exit_mm=0.0, replan_ratio=1.0, replan_min_shift_mm=0.0)
    assert (node.replan_ratio, node.replan_min_shift_mm) == (1.0, 0.0)


def test_settings_come_from_the_constructor_else_the_mission(rig):
    _, node = alone(rig, clearance_mm=350.0, speed_mm_s=120.0, lookahead_mm=90.0, exit_mm=40.0,
                    margin_mm=15.0)
    assert node.settings == {"clearance_mm": 350.0, "margin_mm": 15.0, "speed_mm_s": 120.0,
                             "lookahead_mm": 90.0, "mark_radius_mm": 100.0, "exit_mm": 40.0,
                             "wheel_base_mm": 235.0, "max_wheel_mm_s": 300.0}
    _, node = alone(rig, margin_mm=None)
    nav = rig.mission.navigation
    assert node.settings == {
        "clearance_mm": nav.clearance_mm, "margin_mm": nav.bypass_margin_mm,
        "speed_mm_s": 0.8 * nav.approach_speed_mm_s, "lookahead_mm": nav.lookahead_mm,
        "mark_radius_mm": 100.0, "exit_mm": 165.0 + 100.0 + 60.0, "wheel_base_mm": 235.0,
        "max_wheel_mm_s": rig.mission.robot.max_speed_mm_s}


def test_without_a_mission_setup_names_the_missing_setting(manual_clock, fake_robot, blackboard):
    node = BezierBypass(clearance_mm=300.0)
    with pytest.raises(SetupError, match=r"^BezierBypass 'Bypass': no bypass speed: "):
        py_trees.trees.BehaviourTree(node).setup(robot=fake_robot, clock=manual_clock)
    with pytest.raises(SetupError, match=r"^BezierBypass 'Bypass': not set up"):
        BezierBypass().initialise()


def test_no_target_and_no_estimate_fail_with_the_reason(rig):
    tree, node = alone(rig)
    tree.tick()
    assert (node.status, node.feedback_message) == (Status.FAILURE, "no target selected")
    BB.set(keys.TARGET, red_target())  # selected, never seen: no world estimate
    tree.tick()
    assert (node.status, node.feedback_message) == (Status.FAILURE,
                                                   "no position estimate of red #1")
    assert rig.bb(keys.PLANS, ()) == () and rig.robot.wheels == (0, 0)


def test_resumed_beside_the_mark_it_counts_as_passed_once(rig):
    # e.g. after a bump recovery: the mark 320 mm to the robot's right, 20 mm behind
    BB.set(keys.TARGET, red_target(world_x=320.0, world_y=-20.0, locked=True))
    BB.set(keys.PASSED, (keys.PassedWaypoint(0, "waypoint-0-red", "red", "left", 1.0, 320.0,
                                             -20.0),))
    tree, node = alone(rig)
    tree.tick()
    assert node.status == Status.SUCCESS
    assert len(rig.bb(keys.PASSED)) == 1  # not recorded twice
    assert node.feedback_message == "passed red #1 on its left (320 mm beside it)"


def test_beside_but_ahead_or_on_the_wrong_side_it_cannot_be_passed_yet(rig):
    BB.set(keys.TARGET, red_target(world_x=320.0, world_y=40.0))  # 40 mm ahead on the right
    tree, node = alone(rig)
    tree.tick()
    assert node.status == Status.FAILURE
    assert node.feedback_message.startswith("cannot bypass red #1: ")
    BB.set(keys.TARGET, red_target(world_x=-320.0, world_y=-20.0))  # behind, on the left
    tree, node = alone(rig)
    tree.tick()
    assert node.status == Status.FAILURE


@pytest.mark.parametrize(("ahead", "planned"), [(480.0, 340.0), (390.0, 300.0)])
def test_a_plan_that_does_not_fit_falls_back_to_a_narrower_clearance(rig, ahead, planned):
    # 2 bump recoveries widen the plan to 300 + 40 + 2 × 60 = 460 mm; a mark this near leaves
    # no room for that: clearance + margin (340 mm) where it fits, else the bare 300 mm
    BB.set(keys.RECOVERY, keys.Recovery(count=2))
    BB.set(keys.TARGET, red_target(world_x=60.0, world_y=ahead))
    tree, node = alone(rig, margin_mm=None)
    tree.tick()
    assert node.status == Status.RUNNING
    (record,) = rig.bb(keys.PLANS)
    assert record.plan.min_clearance_mm == pytest.approx(planned, abs=1e-6)
    assert node.planned_clearance_mm() == pytest.approx(460.0)


def sighting_of(rig, x: float, y: float) -> keys.SeenMark:
    """A sighting now of a mark at world (x, y), from the robot's odometry pose."""
    forward, left = to_robot_frame(rig.robot.pose(), (x, y))
    return keys.SeenMark(colour="red", forward_mm=forward, left_mm=left, world_x=x, world_y=y,
                         x_px=320.0, radius_px=30.0, image_width=640, t=rig.clock.now())


def test_which_sightings_re_plan(rig):
    mark = (50.0, 1000.0)
    first = sighting_of(rig, *mark)
    BB.set(keys.TARGET, red_target(world_x=mark[0], world_y=mark[1], sighting=first))
    tree, node = alone(rig, replan_min_shift_mm=20.0)
    tree.tick()
    assert [p.reason for p in rig.bb(keys.PLANS)] == ["initial"]

    def see(x: float, y: float, *, waypoint_id: str = "waypoint-0-red") -> None:
        rig.clock.advance(0.05)
        seen = sighting_of(rig, x, y)
        BB.set(keys.TARGET, red_target(waypoint_id=waypoint_id, world_x=x, world_y=y,
                                       sighting=seen, locked=True))
        tree.tick()

    def drive_until_range_below(limit: float) -> None:
        for _ in range(200):
            p = rig.robot.pose()
            if math.hypot(mark[0] - p.x, mark[1] - p.y) < limit:
                return
            rig.clock.advance(0.05)
            tree.tick()
        raise AssertionError("never got near enough")

    # another waypoint's target: ignored
    drive_until_range_below(850.0)
    see(mark[0] + 100.0, mark[1], waypoint_id="waypoint-1-red")
    assert node.replans == 0
    BB.set(keys.TARGET, red_target(world_x=mark[0], world_y=mark[1], sighting=first,
                                   locked=True))
    # nearer than 90 % of the planning range but moved by only 15 mm: confirms the plan
    see(mark[0] + 15.0, mark[1])
    assert node.replans == 0
    # not nearer than 90 % of that confirmed range: ignored, however far it moved
    see(mark[0] + 100.0, mark[1])
    assert node.replans == 0
    # nearer still and moved by 60 mm: re-planned, the same course kept
    drive_until_range_below(0.9 * 820.0)
    see(mark[0] + 60.0, mark[1])
    assert node.replans == 1
    plans = rig.bb(keys.PLANS)
    assert [p.reason for p in plans] == ["initial", "re-plan"]
    assert plans[1].plan.course == plans[0].plan.course
    assert plans[1].plan.mark_xy == (mark[0] + 60.0, mark[1])
    assert node.feedback_message.endswith(" m to go, re-planned 1×")
    # the same sighting again (not newer): nothing happens
    tree.tick()
    assert node.replans == 1


def test_lateral_of_is_the_offset_to_the_left():
    north = Pose(0.0, 0.0, math.pi / 2)
    assert lateral_of(north, (-100.0, 500.0), north.theta) == pytest.approx(100.0)
    assert lateral_of(north, (100.0, 500.0), north.theta) == pytest.approx(-100.0)


@pytest.mark.parametrize("course", [0.0, 0.5, 2.2, -2.6])
def test_behind_and_lateral_are_the_robot_frame_on_any_course(course):
    pose = Pose(120.0, -80.0, course)
    for mark in [(500.0, 300.0), (-250.0, 40.0), (120.0, 900.0), (-700.0, -600.0)]:
        forward, left = to_robot_frame(pose, mark)
        assert behind_of(pose, mark, course) == pytest.approx(-forward, abs=1e-9)
        assert lateral_of(pose, mark, course) == pytest.approx(left, abs=1e-9)


@pytest.mark.parametrize(("colour", "sign"), [("red", -1.0), ("green", 1.0)])
def test_a_bypass_on_a_slanted_course_passes_on_the_required_side(rig, colour, sign):
    # the robot starts facing 35° (not along an axis), the mark 900 mm straight ahead
    heading = math.radians(35.0)
    rig.robot = FakeRobot(clock=rig.clock, pose=Pose(200.0, -100.0, heading))
    mark = (200.0 + 900.0 * math.cos(heading), -100.0 + 900.0 * math.sin(heading))
    rig.perception.place(colour, x_mm=mark[0], y_mm=mark[1])
    node = BezierBypass(margin_mm=0.0)
    root = py_trees.composites.Sequence("Root", memory=False, children=[
        rig.perception, py_trees.composites.Sequence("Pass", memory=True, children=[
            SelectTarget(colour=colour, waypoint=0), node])])
    tree = rig.tree(root)
    tree.tick()
    assert re.fullmatch(rf"passing {colour} #1 on its (left|right): \d\.\d\d m to go",
                        node.feedback_message), node.feedback_message
    to_go = float(node.feedback_message.split(": ")[1].split(" m")[0])
    log = rig.run(tree, max_ticks=300)
    assert log.reached
    (plan,) = rig.bb(keys.PLANS)
    assert plan.plan.course == pytest.approx(heading, abs=0.05)
    assert 1.0 < to_go < 2.0  # the curve plus the run-out, ~1.4 m
    end = rig.robot.pose()
    # beside the mark at the clearance on the required side (the mark to the robot's right
    # when passing on its left), and past it by the run-out, along the slanted course
    assert lateral_of(end, mark, plan.plan.course) == pytest.approx(sign * 300.0, abs=15.0)
    assert behind_of(end, mark, plan.plan.course) == pytest.approx(165.0 + 100.0 + 60.0,
                                                                  abs=15.0)
    (passed,) = rig.bb(keys.PASSED)
    assert (passed.colour, passed.mark_x, passed.mark_y) == (
        colour, pytest.approx(mark[0]), pytest.approx(mark[1]))


# -- setup without a mission: which setting is missing, by name -----------------------------------

_SETUP_HINT = ": pass it to the constructor or set the tree up with tree.setup(mission=...)"


@pytest.mark.parametrize(("kwargs", "missing"), [
    ({}, "clearance_mm"),
    ({"clearance_mm": 300.0}, "bypass speed"),
    ({"clearance_mm": 300.0, "speed_mm_s": 150.0}, "lookahead_mm"),
    # every constructor setting given: the mark radius has no constructor override
    ({"clearance_mm": 300.0, "speed_mm_s": 150.0, "lookahead_mm": 100.0, "exit_mm": 50.0,
      "margin_mm": 0.0}, "marks.radius_mm"),
])
def test_setup_without_a_mission_names_the_first_missing_setting(
        manual_clock, fake_robot, blackboard, kwargs, missing):
    node = BezierBypass(**kwargs)
    with pytest.raises(SetupError) as exc:
        py_trees.trees.BehaviourTree(node).setup(robot=fake_robot, clock=manual_clock)
    assert type(exc.value) is SetupError
    assert str(exc.value) == f"BezierBypass 'Bypass': no {missing}{_SETUP_HINT}"
    assert node.settings == {}


# -- what a plan record says ----------------------------------------------------------------------


def test_a_plan_record_names_the_waypoint_colour_and_side(rig):
    BB.set(keys.TARGET, keys.Target(waypoint=2, waypoint_id="waypoint-2-green", colour="green",
                                    side="right", world_x=0.0, world_y=900.0))
    rig.clock.advance(1.25)
    tree, _ = alone(rig)
    tree.tick()
    (record,) = rig.bb(keys.PLANS)
    assert (record.waypoint, record.colour, record.side, record.t, record.reason) == (
        2, "green", "right", 1.25, "initial")


# -- the planning range from a start off the origin ----------------------------------------------


def test_the_planning_range_is_measured_from_where_the_robot_is(rig):
    # the robot at (1500, 2000) with the mark 1 m ahead: a sighting from 950 mm (95 % of the
    # planning range) confirms nothing and re-plans nothing; from under 900 mm it re-plans
    start = Pose(1500.0, 2000.0, math.pi / 2)
    rig.robot = FakeRobot(clock=rig.clock, pose=start)
    mark = (1550.0, 2998.75)  # 1000 mm from the start
    BB.set(keys.TARGET, red_target(world_x=mark[0], world_y=mark[1],
                                   sighting=sighting_of(rig, *mark)))
    tree, node = alone(rig, replan_min_shift_mm=20.0)
    tree.tick()

    def drive_until_range_below(limit: float) -> None:
        for _ in range(200):
            p = rig.robot.pose()
            if math.hypot(mark[0] - p.x, mark[1] - p.y) < limit:
                return
            rig.clock.advance(0.05)
            tree.tick()
        raise AssertionError("never got near enough")

    def see(x: float, y: float) -> None:
        rig.clock.advance(0.05)
        BB.set(keys.TARGET, red_target(world_x=x, world_y=y, sighting=sighting_of(rig, x, y),
                                       locked=True))
        tree.tick()

    drive_until_range_below(955.0)
    see(mark[0] + 60.0, mark[1])
    assert node.replans == 0 and node.status == Status.RUNNING
    drive_until_range_below(880.0)
    see(mark[0] + 60.0, mark[1])
    assert node.replans == 1


# -- the end of the bypass -----------------------------------------------------------------------


def test_without_a_run_out_the_bypass_ends_just_short_of_the_marks_line(rig):
    # exit_mm = 0: the path ends beside the mark, and the bypass ends when the tracker reaches
    # that end (within its goal tolerance) with the mark on the required side — the robot's
    # centre still short of the mark's line: "beside or behind" is not required strictly here
    rig.perception.place("red", x_mm=0.0, y_mm=900.0)
    node = BezierBypass(margin_mm=0.0, exit_mm=0.0)
    root = py_trees.composites.Sequence("Root", memory=False, children=[
        rig.perception, py_trees.composites.Sequence("Pass", memory=True, children=[
            SelectTarget(colour="red", waypoint=0), node])])
    tree = rig.tree(root)
    log = rig.run(tree, max_ticks=300)
    assert log.reached and node.status == Status.SUCCESS
    (plan,) = rig.bb(keys.PLANS)
    end = rig.robot.pose()
    assert -200.0 < behind_of(end, (0.0, 900.0), plan.plan.course) < 0.0
    assert lateral_of(end, (0.0, 900.0), plan.plan.course) < -250.0


@pytest.mark.parametrize(("along", "status"), [(-20.0, Status.SUCCESS), (40.0, Status.FAILURE)])
def test_resumed_beside_the_mark_on_a_slanted_course_off_the_origin(rig, along, status):
    # as test_resumed_beside_the_mark_it_counts_as_passed_once, the robot at (200, -100) facing
    # 35°: the mark 320 mm to its right and 20 mm behind is passed; 40 mm ahead it is not yet
    heading = math.radians(35.0)
    here = Pose(200.0, -100.0, heading)
    rig.robot = FakeRobot(clock=rig.clock, pose=here)
    c, s = math.cos(heading), math.sin(heading)
    mark = (here.x + along * c + 320.0 * s, here.y + along * s - 320.0 * c)
    BB.set(keys.TARGET, red_target(world_x=mark[0], world_y=mark[1], locked=True))
    tree, node = alone(rig)
    tree.tick()
    assert node.status == status, node.feedback_message
    if status == Status.SUCCESS:
        assert node.feedback_message == "passed red #1 on its left (320 mm beside it)"
    else:
        assert node.feedback_message.startswith("cannot bypass red #1: ")


def test_the_distance_to_go_shrinks_to_nothing(rig):
    rig.perception.place("red", x_mm=0.0, y_mm=900.0)
    node = BezierBypass(margin_mm=0.0)
    root = py_trees.composites.Sequence("Root", memory=False, children=[
        rig.perception, py_trees.composites.Sequence("Pass", memory=True, children=[
            SelectTarget(colour="red", waypoint=0), node])])
    tree = rig.tree(root)
    figures = []
    for _ in range(300):
        rig.clock.advance(0.05)
        tree.tick()
        if node.status != Status.RUNNING:
            break
        figures.append(float(node.feedback_message.split(": ")[1].split(" m")[0]))
    assert node.status == Status.SUCCESS
    assert figures == sorted(figures, reverse=True) and figures[0] > 1.0
    assert figures[-1] <= 0.1
