"""SearchWhenLost at its edges: found the very tick it starts, the timeout to the tick, the mark
exactly ahead, the mark passed last among several, explicit settings and setup errors.

Written against the mutants mutmut left alive in behaviours/search.py (docs/mutation.md).
"""

from __future__ import annotations

import math

import py_trees
import pytest
from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.base import SetupError
from marknav.behaviours.search import LEFT, RIGHT, SearchWhenLost, search_direction
from marknav.planning.kinematics import Pose

EAST = Pose(0.0, 0.0, 0.0)  # facing +x: a point (d, 0) is exactly ahead, left == 0.0 exactly


def target(side: str = "left", world: tuple[float, float] | None = None,
           sighting_t: float | None = None) -> keys.Target:
    sighting = None
    if sighting_t is not None:
        assert world is not None
        sighting = keys.SeenMark(colour="red", forward_mm=world[1], left_mm=-world[0],
                                 world_x=world[0], world_y=world[1], x_px=320.0,
                                 radius_px=20.0, image_width=640, t=sighting_t)
    return keys.Target(waypoint=0, waypoint_id="waypoint-0-red", colour="red",
                       side=side,  # type: ignore[arg-type]
                       world_x=None if world is None else world[0],
                       world_y=None if world is None else world[1], sighting=sighting)


def passed(i: int, x: float, y: float) -> keys.PassedWaypoint:
    return keys.PassedWaypoint(waypoint=i, waypoint_id=f"waypoint-{i}-blue", colour="blue",
                               side="left", t=float(i), mark_x=x, mark_y=y)


@pytest.mark.parametrize(("side", "expected"), [("left", RIGHT), ("right", LEFT)])
def test_a_point_exactly_ahead_says_nothing_and_the_pass_side_decides(side, expected):
    assert search_direction(target(side, (1000.0, 0.0)), EAST) == expected
    # and a previous mark exactly ahead says nothing either
    assert search_direction(target(side), EAST, passed(0, 500.0, 0.0)) == expected


@pytest.mark.parametrize("side", ["left", "right"])
def test_half_a_millimetre_off_ahead_is_enough_to_choose(side):
    assert search_direction(target(side, (1000.0, 0.5)), EAST) == LEFT
    assert search_direction(target(side, (1000.0, -0.5)), EAST) == RIGHT


def test_the_search_turns_toward_the_mark_passed_last_not_an_earlier_one(rig):
    # never seen; three marks passed: the last on the robot's left, the others on its right
    py_trees.blackboard.Blackboard.set(keys.PASSED, (
        passed(0, 800.0, 300.0), passed(1, 600.0, 900.0), passed(2, -700.0, 1200.0)))
    py_trees.blackboard.Blackboard.set(keys.TARGET, target("left"))  # the side says "right"
    node = SearchWhenLost()
    tree = rig.tree(node)
    tree.tick()
    assert node.status == Status.RUNNING and node.direction == LEFT
    left, right = rig.robot.wheels
    assert left < 0 < right


def test_explicit_turn_speed_and_timeout_win_over_the_mission(rig):
    py_trees.blackboard.Blackboard.set(keys.TARGET, target("left"))
    node = SearchWhenLost(turn_speed_deg_s=20.0, timeout_s=4.0)
    tree = rig.tree(node)
    tree.tick()
    wheel = round(math.radians(20.0) * 117.5)  # 41 mm/s, wheel base 235 mm; mission: 40°/s
    assert rig.robot.wheels == (wheel, -wheel)
    assert node.feedback_message == "looking for red #1: turning right, 0°, 0.0/4 s"


def test_found_on_the_tick_the_search_starts(rig):
    rig.clock.set(7.0)
    py_trees.blackboard.Blackboard.set(keys.TARGET, target("left", (0.0, 1500.0),
                                                          sighting_t=7.0))
    node = SearchWhenLost()
    tree = rig.tree(node)
    tree.tick()
    assert node.status == Status.SUCCESS
    assert node.feedback_message == "found red #1 after 0° (0.0 s)"


def test_the_timeout_counts_from_the_start_and_ends_on_its_tick(rig):
    rig.clock.set(10.0)
    py_trees.blackboard.Blackboard.set(keys.TARGET, target("left"))
    node = SearchWhenLost(turn_speed_deg_s=30.0, timeout_s=2.0)
    tree = rig.tree(node)
    statuses = []
    for k in range(21):  # every 0.1 s; the last tick at exactly 12.0 s
        rig.clock.set(10.0 + k * 0.1)
        tree.tick()
        statuses.append(node.status)
    assert rig.clock.now() - 10.0 == 2.0
    assert statuses == [Status.RUNNING] * 20 + [Status.FAILURE]
    message = node.feedback_message
    assert message.startswith("red #1 not found in 2 s (turned ")
    assert 50 <= int(message.split("turned ")[1].rstrip("°)")) <= 60  # 30°/s for 2 s


def test_no_target_fails_with_the_reason(rig):
    node = SearchWhenLost()
    tree = rig.tree(node)
    tree.tick()
    assert node.status == Status.FAILURE
    assert node.feedback_message == "no target selected"
    assert rig.robot.wheels == (0, 0)


def test_bad_settings_are_named():
    with pytest.raises(ValueError, match=r"^turn_speed_deg_s must be a positive number"):
        SearchWhenLost(turn_speed_deg_s=0.0)
    with pytest.raises(ValueError, match=r"^timeout_s must be a positive number"):
        SearchWhenLost(timeout_s=-1.0)


def test_without_a_mission_setup_names_the_missing_setting(manual_clock, fake_robot, blackboard):
    def setup(node):
        py_trees.trees.BehaviourTree(node).setup(robot=fake_robot, clock=manual_clock)

    with pytest.raises(SetupError, match=r"^SearchWhenLost 'Search': no search turn speed: "):
        setup(SearchWhenLost())
    with pytest.raises(SetupError, match=r"^SearchWhenLost 'Search': no search timeout: "):
        setup(SearchWhenLost(turn_speed_deg_s=30.0))
    with pytest.raises(SetupError, match=r"^SearchWhenLost 'Search': no robot\.wheel_base_mm: "):
        setup(SearchWhenLost(turn_speed_deg_s=30.0, timeout_s=5.0))


def test_ticked_without_setup_is_a_setup_error(blackboard):
    node = SearchWhenLost(turn_speed_deg_s=30.0, timeout_s=5.0)  # no wheel base without setup
    with pytest.raises(SetupError, match=r"not set up \(tree\.setup\(mission=\.\.\.\)\)"):
        node.update()
