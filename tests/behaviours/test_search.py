"""SearchWhenLost: which way it turns, success when seen, failure on timeout or a full turn."""

from __future__ import annotations

import math

import py_trees
import pytest
from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.search import SearchWhenLost
from marknav.behaviours.target import SelectTarget

TURN_WHEEL = round(math.radians(40.0) * 117.5)  # 82 mm/s at 40°/s, wheel base 235 mm


def search_tree(rig, colour="red", **kwargs):
    node = SearchWhenLost(**kwargs)
    root = py_trees.composites.Sequence("Root", memory=False, children=[
        rig.perception, SelectTarget(colour=colour, waypoint=0), node])
    return rig.tree(root), node


def last_seen_at(colour: str, x: float, y: float) -> None:
    py_trees.blackboard.Blackboard.set(keys.TARGET, keys.Target(
        waypoint=0, waypoint_id="waypoint-0-" + colour, colour=colour,
        side="left" if colour == "red" else "right", world_x=x, world_y=y))


@pytest.mark.parametrize(("colour", "wheels"), [
    ("red", (TURN_WHEEL, -TURN_WHEEL)),  # pass on its left: it lies ahead-right, turn right
    ("green", (-TURN_WHEEL, TURN_WHEEL)),  # pass on its right: ahead-left, turn left
])
def test_never_seen_turns_toward_the_pass_side(rig, colour, wheels):
    tree, node = search_tree(rig, colour)
    tree.tick()
    assert node.status == Status.RUNNING
    assert rig.robot.wheels == wheels
    way = "right" if colour == "red" else "left"
    assert node.feedback_message == f"looking for {colour} #1: turning {way}, 0°, 0.0/15 s"


def test_turns_toward_where_the_target_was_last_seen(rig):
    last_seen_at("red", -1000.0, 500.0)  # left of the robot, although red says "right"
    tree, _ = search_tree(rig)
    tree.tick()
    assert rig.robot.wheels == (-TURN_WHEEL, TURN_WHEEL)


def test_succeeds_when_the_target_comes_into_view(rig):
    rig.perception.place("red", x_mm=-2000, y_mm=200)  # 84° to the left
    last_seen_at("red", -2000.0, 200.0)
    tree, node = search_tree(rig)
    log = rig.run(tree, max_ticks=100)
    assert log.reached
    heading = rig.robot.pose().theta - math.pi / 2
    bearing = math.atan2(200.0, -2000.0) - rig.robot.pose().theta
    # it stopped as soon as the whole disc fitted in the image (28.4° half view, 2.8° disc)
    assert math.degrees(abs(bearing)) == pytest.approx(25.6, abs=2.0)
    assert math.degrees(heading) == pytest.approx(58.5, abs=2.0)
    assert node.feedback_message.startswith("found red #1 after 5")
    assert rig.robot.wheels == (0, 0)


def test_fails_after_the_timeout(rig):
    tree, node = search_tree(rig, timeout_s=2.98)
    log = rig.run(tree, Status.FAILURE, max_ticks=100)
    assert log.reached
    assert log.records[-1].t == pytest.approx(3.0)
    assert log.records[-2].status == Status.RUNNING
    assert node.feedback_message.startswith("red #1 not found in 2.98 s (turned 1")
    assert rig.robot.wheels == (0, 0)


def test_fails_after_a_full_turn(rig):
    tree, node = search_tree(rig)  # 40°/s: a full turn in 9 s, before the 15 s timeout
    log = rig.run(tree, Status.FAILURE, max_ticks=400)
    assert log.reached
    assert log.records[-1].t == pytest.approx(9.0, abs=0.06)
    assert node.feedback_message == f"red #1 not found in a full turn ({log.records[-1].t:.1f} s)"
    assert rig.robot.wheels == (0, 0)


def test_a_never_seen_mark_is_sought_toward_the_mark_passed_last():
    from marknav.behaviours import keys
    from marknav.behaviours.search import LEFT, RIGHT, search_direction
    from marknav.planning.kinematics import Pose

    green = keys.Target(waypoint=1, waypoint_id="w1", colour="green", side="right")
    here = Pose(-500.0, 1800.0, math.pi / 2)  # beside the course, after passing red on its left

    def passed(x):
        return keys.PassedWaypoint(waypoint=0, waypoint_id="w0", colour="red", side="left",
                                   t=9.0, mark_x=x, mark_y=1500.0)

    # red (passed, behind and to the right) says where the course is: turn right...
    assert search_direction(green, here, passed(-200.0)) == RIGHT
    # ...even though green, passed on its right, would otherwise be sought on the left,
    assert search_direction(green, here) == LEFT
    # and a previous mark on the left turns left.
    assert search_direction(green, here, passed(-800.0)) == LEFT


def test_a_wrong_memory_is_forgotten_after_a_full_turn(rig):
    """Issue 11: the target was a remembered mark (3.5 m away, too far for a missed frame to
    forget it) whose estimate was wrong; the real mark of that colour, 4.5 m away the other way,
    was in view during the turn but not where the memory said. After a full turn the memory
    is dropped and the search goes on for the nearest red in view."""
    rig.perception.place("red", x_mm=3200, y_mm=3200)  # 45°, 4.5 m: the real mark
    ghost = keys.KnownMark("red", -2475.0, 2475.0, t=0.0, range_mm=3000.0, seen=5)
    py_trees.blackboard.Blackboard.set(keys.KNOWN, (ghost,))
    py_trees.blackboard.Blackboard.set(keys.TARGET, keys.Target(
        waypoint=0, waypoint_id="waypoint-0-red", colour="red", side="left",
        world_x=ghost.world_x, world_y=ghost.world_y, remembered=True))
    tree, node = search_tree(rig)
    log = rig.run(tree, max_ticks=600)
    assert log.reached
    assert node.forgot_memory
    assert node.feedback_message.startswith("found red #1 after")
    target = rig.bb(keys.TARGET)
    assert not target.remembered and target.sighting is not None
    assert target.sighting.world_x == pytest.approx(3200, abs=5)
    assert all(k.world != ghost.world for k in rig.bb(keys.KNOWN, ()))
    assert log.records[-1].t > 9.0  # one full turn first


def test_a_remembered_target_without_a_mark_anywhere_still_fails(rig):
    ghost = keys.KnownMark("red", -2475.0, 2475.0, t=0.0, range_mm=3000.0, seen=5)
    py_trees.blackboard.Blackboard.set(keys.KNOWN, (ghost,))
    py_trees.blackboard.Blackboard.set(keys.TARGET, keys.Target(
        waypoint=0, waypoint_id="waypoint-0-red", colour="red", side="left",
        world_x=ghost.world_x, world_y=ghost.world_y, remembered=True))
    tree, node = search_tree(rig, timeout_s=30.0)
    log = rig.run(tree, Status.FAILURE, max_ticks=900)
    assert log.reached
    assert node.forgot_memory
    assert node.feedback_message.startswith("red #1 not found in a full turn")
    assert log.records[-1].t == pytest.approx(18.0, abs=0.2)  # two full turns


def test_a_remembered_target_found_empty_where_it_should_be_is_chosen_again_at_once(rig):
    """Random mission 271: the target was a remembered ghost (a mark seen at the wrong range,
    1.2 m instead of 2.9 m). The search turned toward it and saw nothing there, and the memory
    forgot it, but the target stayed the ghost: the real mark, remembered and then in view 2.3 m
    away, was never accepted, and after a full turn the search took an off-course mark of the
    colour that was in view at that moment. The target is chosen again as soon as its memory is
    gone: here the real mark, found within a second."""
    real = rig.perception.place("red", x_mm=1500, y_mm=1800)  # 40° right, 2.3 m
    rig.perception.place("red", x_mm=-500, y_mm=3000)  # 9° left, 3.0 m: off the course
    ghost = keys.KnownMark("red", 600.0, 1000.0, t=0.0, range_mm=1170.0, seen=6)  # 31° right
    remembered = keys.KnownMark("red", real.x_mm, real.y_mm, t=0.0, range_mm=2900.0, seen=80)
    py_trees.blackboard.Blackboard.set(keys.KNOWN, (ghost, remembered))
    node = SearchWhenLost()
    # As in the route: the waypoint's Pass selects its target once, then searches.
    tree = rig.tree(py_trees.composites.Sequence("Root", memory=False, children=[
        rig.perception, py_trees.composites.Sequence("Pass", memory=True, children=[
            SelectTarget(colour="red", waypoint=0), node])]))
    tree.tick()
    first = rig.bb(keys.TARGET)
    assert first.remembered and first.world == ghost.world  # the nearest memory, out of view
    assert rig.robot.wheels == (TURN_WHEEL, -TURN_WHEEL)  # toward it: right
    log = rig.run(tree, max_ticks=600)
    assert log.reached and not node.forgot_memory
    assert log.records[-1].t < 1.5  # not after a full turn (9 s)
    target = rig.bb(keys.TARGET)
    assert target.sighting is not None
    assert (target.sighting.world_x, target.sighting.world_y) == \
        pytest.approx((real.x_mm, real.y_mm), abs=5)
    assert all(k.world != ghost.world for k in rig.bb(keys.KNOWN, ()))


class TurnLeft(py_trees.behaviour.Behaviour):
    """Waits ``wait`` ticks, turns the robot left in place for ``ticks`` ticks, then SUCCESS."""

    def __init__(self, robot, wait: int, ticks: int) -> None:
        super().__init__("TurnLeft")
        self.robot, self.wait, self.left = robot, wait, ticks

    def update(self) -> Status:
        if self.wait > 0:
            self.wait -= 1
            return Status.RUNNING
        if self.left <= 0:
            return Status.SUCCESS
        self.left -= 1
        self.robot.drive(left=-TURN_WHEEL, right=TURN_WHEEL)
        return Status.RUNNING


def test_a_target_that_leaves_the_view_stays_the_target(rig):
    """Random mission 190, in the rig: the approach's target (0.9 m, 20° right) leaves the view
    as the robot turns left; the next red down the course (4.9 m ahead) stays in view all the
    while and does not become the target — the target is lost, so the search turns back to it,
    and finds it."""
    near = rig.perception.place("red", x_mm=308, y_mm=846)
    far = rig.perception.place("red", x_mm=0, y_mm=4900)
    node = SearchWhenLost()
    tree = rig.tree(py_trees.composites.Sequence("Root", memory=False, children=[
        rig.perception, py_trees.composites.Sequence("Pass", memory=True, children=[
            SelectTarget(colour="red", waypoint=0), TurnLeft(rig.robot, 3, 13), node])]))
    for _ in range(4):  # seen in 4 frames: remembered
        rig.clock.advance(0.05)
        tree.tick()
    assert rig.bb(keys.TARGET).world == pytest.approx((near.x_mm, near.y_mm), abs=5)
    lost = 0
    for _ in range(12):  # 0.6 s at 40°/s: the near red 44° right, out of view
        rig.clock.advance(0.05)
        tree.tick()
        target = rig.bb(keys.TARGET)
        assert target.world == pytest.approx((near.x_mm, near.y_mm), abs=5)
        marks = rig.bb(keys.MARKS)
        assert any(m.world == pytest.approx((far.x_mm, far.y_mm), abs=5) for m in marks)
        lost += not any(m.world == pytest.approx((near.x_mm, near.y_mm), abs=5) for m in marks)
    assert lost >= 8
    # Lost: the search turns right, back toward it, and finds it.
    log = rig.run(tree, max_ticks=200)
    assert log.reached and not node.forgot_memory
    assert "looking for red #1: turning right" in log.records[0].feedback
    target = rig.bb(keys.TARGET)
    assert target.sighting is not None
    assert target.sighting.world == pytest.approx((near.x_mm, near.y_mm), abs=5)
