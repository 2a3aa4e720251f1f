"""Association, the passed-mark exclusion and the mark memory at their edges: both coordinates
count, boundaries are inclusive, other colours never interfere, and the memory's "should have
seen it" test uses the robot's real position and field of view.

Written against the mutants mutmut left alive in behaviours/target.py (docs/mutation.md).
"""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from marknav.behaviours import keys
from marknav.behaviours.target import (
    MEMORY_MIN_SEEN,
    associate,
    excluded_passes,
    nearest_of_colour,
    remember,
    remembered_target,
)
from marknav.planning.kinematics import Pose


def seen(colour: str, x: float, y: float, t: float = 0.0) -> keys.SeenMark:
    """A 100 mm mark seen from the origin facing +y (forward = y, left = -x) by a camera of
    f = 590 px (its image radius f·R/d)."""
    return keys.SeenMark(colour=colour, forward_mm=y, left_mm=-x, world_x=x, world_y=y,
                         x_px=0.0, radius_px=radius_at(y), image_width=640, t=t)


def radius_at(forward_mm: float) -> float:
    """The image radius (px) of a 100 mm mark ``forward_mm`` ahead, f = 590 px."""
    return 590.0 * 100.0 / max(forward_mm, 100.0)


def target(**kw: object) -> keys.Target:
    base: dict[str, object] = {"waypoint": 0, "waypoint_id": "waypoint-0-red", "colour": "red",
                               "side": "left"}
    return keys.Target(**{**base, **kw})  # type: ignore[arg-type]


def passed_at(x: float, y: float, colour: str = "red", i: int = 0) -> keys.PassedWaypoint:
    return keys.PassedWaypoint(waypoint=i, waypoint_id=f"w{i}", colour=colour, side="left",
                               t=float(i), mark_x=x, mark_y=y)


# -- association ---------------------------------------------------------------------------------


def test_an_unlocked_target_skips_passed_marks():
    old, new = seen("red", 0, 600), seen("red", 100, 2500)
    assert associate([old, new], target(), [passed_at(20.0, 620.0)]) == new


def test_a_locked_target_ignores_other_colours_wherever_they_are():
    locked = target(locked=True, world_x=0.0, world_y=1000.0)
    green_on_it, red = seen("green", 0, 1000), seen("red", 60, 1050)
    assert associate([green_on_it, red], locked) == red
    assert associate([green_on_it], locked) is None


def test_the_gate_is_inclusive():
    locked = target(locked=True, world_x=0.0, world_y=500.0)
    assert associate([seen("red", 250.0, 500.0)], locked) is not None  # exactly 250 mm off


def test_locked_wins_over_remembered_a_locked_target_keeps_the_strict_gate():
    t = target(locked=True, remembered=True, world_x=0.0, world_y=2370.0)
    assert associate([seen("red", 0, 1900)], t) is None  # 470 mm > the gate of 407 mm


def test_a_locked_target_may_be_near_a_passed_mark_of_its_colour():
    # a figure-eight passes a mark twice: the bypass under way keeps its sighting
    locked = target(locked=True, world_x=0.0, world_y=1000.0)
    assert associate([seen("red", 30, 1000)], locked, [passed_at(0.0, 1000.0)]) is not None


def test_passed_exclusion_needs_both_coordinates_near():
    passed = [passed_at(0.0, 1000.0)]
    east, north = seen("red", 600.0, 1000.0), seen("red", 0.0, 1600.0)
    assert nearest_of_colour([east], "red", passed) == east  # same y, 600 mm east: another
    assert nearest_of_colour([north], "red", passed) == north  # same x, 600 mm on
    at_gate = seen("red", 250.0, 1000.0)  # 1031 mm away: gate 250 mm, exactly on it
    assert nearest_of_colour([at_gate], "red", passed) is None


def test_revisiting_excludes_the_last_pass_of_three(mission_factory):
    figure_eight = mission_factory(navigation={"revisit_marks": True})
    history = (passed_at(0, 0, i=0), passed_at(0, 1000, i=1), passed_at(0, 2000, i=2))
    assert excluded_passes(history, figure_eight) == history[2:]


# -- the mark memory -----------------------------------------------------------------------------


def test_remember_skips_far_marks_but_not_the_near_ones_after_them():
    known = remember((), [seen("red", 0, 4500), seen("red", 0, 1500)])
    assert [(k.world, k.range_mm) for k in known] == [((0, 1500), 1500.0)]


def test_remember_matches_in_both_coordinates():
    known = remember((), [seen("red", 0, 1500)])
    # gate at 2 m: (0.2 + 0.5 px / 29.5 px) × 2000 mm = 434 mm
    moved_on = remember(known, [seen("red", 0, 2000)])  # 500 mm further on
    assert [k.world for k in moved_on] == [(0, 1500), (0, 2000)]
    aside = remember(known, [seen("red", 500, 2000)])  # 500 mm aside of that
    assert [k.world for k in remember(moved_on, [seen("red", 500, 2000)])] == [
        (0, 1500), (0, 2000), (500, 2000)]
    assert [k.world for k in aside] == [(0, 1500), (500, 2000)]
    again = remember((replace(known[0], missed=2),), [seen("red", 50, 1520)])
    assert [(k.seen, k.missed) for k in again] == [(2, 0)]  # seen again: misses forgotten


HALF_FOV = math.radians(28.5)


def misses(mark_xy: tuple[float, float], pose: Pose, *, frames: int = 1) -> int:
    """How many misses a remembered red at ``mark_xy`` counts when ``frames`` frames from
    ``pose`` see only an unrelated blue; -1 once forgotten."""
    known = remember((), [seen("red", *mark_xy)] * MEMORY_MIN_SEEN)
    for _ in range(frames):
        known = remember(known, [seen("blue", -3000, 100)], pose=pose, half_fov_rad=HALF_FOV)
    reds = [k for k in known if k.colour == "red"]
    return reds[0].missed if reds else -1


def test_a_mark_well_inside_the_view_that_is_not_seen_counts_a_miss():
    here = Pose(1000.0, -500.0, math.pi / 2)  # not at the origin: positions are relative
    assert misses((1000.0, 1500.0), here) == 1   # 2 m straight ahead
    assert misses((1000.0, 1500.0), here, frames=3) == -1  # forgotten after three
    # just inside 0.75 × the half view (21.4°) at 2 m ahead: 780 mm aside; outside it: no miss
    assert misses((1000.0 + 760.0, 1500.0), here) == 1
    assert misses((1000.0 - 760.0, 1500.0), here) == 1
    assert misses((1000.0 + 800.0, 1500.0), here) == 0
    # nearer than 300 mm (the camera cannot see it whole) or beyond 3 m: nothing to say
    assert misses((1000.0, -250.0), here) == 0
    assert misses((1000.0, 2600.0), here) == 0  # 3.1 m ahead
    assert misses((1000.0, 2400.0), here) == 1  # 2.9 m ahead


def test_a_mark_seen_in_this_frame_counts_no_miss():
    origin = Pose(0.0, 0.0, math.pi / 2)
    known = remember((), [seen("red", 0, 2000)] * 3)
    known = remember(known, [seen("red", 20, 2010), seen("green", 900, 2500)], pose=origin,
                     half_fov_rad=HALF_FOV)
    assert [(k.colour, k.seen, k.missed) for k in known] == [("red", 4, 0), ("green", 1, 0)]


def test_without_a_field_of_view_nothing_is_missed():
    known = remember((), [seen("red", 0, 2000)] * 3)
    assert remember(known, [], pose=Pose(0.0, 0.0, math.pi / 2), half_fov_rad=None) == known
    assert remember(known, [], pose=None, half_fov_rad=HALF_FOV) == known


def test_the_remembered_target_is_the_nearest_in_both_coordinates():
    known = remember((), [seen("green", 1200, 1000), seen("green", -300, 1500),
                          seen("blue", 0, 500)] * 3)
    here = (-200.0, 1400.0)
    assert remembered_target(known, "green", (), here, []).world == (-300, 1500)
    assert remembered_target(known, "green", (), (1100.0, 900.0), []).world == (1200, 1000)
    # one in view (seen now within its gate) is left out, the other still found
    in_view = [seen("green", -310, 1520)]
    assert remembered_target(known, "green", (), here, in_view).world == (1200, 1000)
    # a passed one is left out: the next is found (other colours first in memory do not stop it)
    assert remembered_target(known, "green", [passed_at(-300, 1500, "green")], here,
                             []).world == (1200, 1000)
    off_in_x = [seen("green", -300 + 600, 1500)]  # same y, 600 mm off: not the one in view
    assert remembered_target(known, "green", (), here, off_in_x).world == (-300, 1500)


# -- the condition nodes' names, messages and settings -------------------------------------------


def test_describe_says_how_far_and_which_way():
    from marknav.behaviours.target import describe

    assert describe(None) == "not in view"
    assert describe(seen("red", -300, 1500)) == "1.53 m, 11° left"
    assert describe(seen("red", 300, 1500)) == "1.53 m, 11° right"
    assert describe(seen("red", 0, 2000)) == "2.00 m, 0° right"  # dead ahead counts as right


def test_condition_nodes_names_and_messages(rig):
    import py_trees
    from py_trees.common import Status

    from marknav.behaviours.base import SetupError
    from marknav.behaviours.target import SelectTarget, TargetLocked, TargetSeen, WaypointPassed

    assert [n.name for n in (SelectTarget(colour="red"), TargetSeen(), TargetLocked(),
                             WaypointPassed(waypoint_id="w"))] == [
        "SelectTarget", "Seen?", "Bypassing?", "Passed?"]
    with pytest.raises(ValueError, match=r"^side must be 'left' or 'right', got 'up'$"):
        SelectTarget(colour="red", side="up")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"^lost_after_s must be a positive number"):
        TargetSeen(lost_after_s=0.0)
    seen_node = TargetSeen(lost_after_s=0.2)  # wins over the mission's 0.5 s
    locked = TargetLocked(waypoint_id="waypoint-0-red")
    passed = WaypointPassed(waypoint_id="waypoint-0-red")
    for node in (seen_node, locked, passed):
        rig.tree(node)
    assert seen_node.lost_after_s == 0.2
    for node in (seen_node, locked, passed):
        node.tick_once()
    assert [(n.status, n.feedback_message) for n in (seen_node, locked, passed)] == [
        (Status.FAILURE, "no target selected"), (Status.FAILURE, "no bypass under way"),
        (Status.FAILURE, "not yet")]
    py_trees.blackboard.Blackboard.set(keys.TARGET, target(locked=True, world_x=0.0,
                                                           world_y=900.0))
    locked.tick_once()
    assert (locked.status, locked.feedback_message) == (Status.SUCCESS,
                                                        "red #1: bypass under way")
    other = TargetLocked(waypoint_id="waypoint-1-red")  # another waypoint's lock is not ours
    rig.tree(other)
    other.tick_once()
    assert other.status == Status.FAILURE
    with pytest.raises(SetupError, match=r"not set up \(no lost_after_s\)"):
        TargetSeen().update()
    with pytest.raises(SetupError, match=r"^SelectTarget 'SelectTarget': colour 'purple' is "
                                         r"not in the mission's marks\.colours$"):
        rig.tree(SelectTarget(colour="purple"))


# -- the memory's edges: the order of the memory, exact gates, off the origin --------------------


def known(x: float, y: float, colour: str = "red", range_mm: float = 1000.0) -> keys.KnownMark:
    """A mark remembered often enough to be a target."""
    return keys.KnownMark(colour, x, y, 0.0, range_mm, seen=MEMORY_MIN_SEEN)


def seen_from(pose: Pose, colour: str, x: float, y: float, t: float = 0.0) -> keys.SeenMark:
    """A mark at world (x, y) seen from ``pose``."""
    from marknav.planning.kinematics import to_robot_frame

    fwd, left = to_robot_frame(pose, (x, y))
    return keys.SeenMark(colour=colour, forward_mm=fwd, left_mm=left, world_x=x, world_y=y,
                         x_px=0.0, radius_px=radius_at(fwd), image_width=640, t=t)


@pytest.mark.parametrize(("offset", "near"), [
    ((2000.0, 0.0), False), ((0.0, 2000.0), False),   # far in one coordinate only: not passed
    ((250.0, 0.0), True), ((0.0, -250.0), True),      # exactly the gate (250 mm at 1 m): passed
    ((251.0, 0.0), False)])
def test_a_remembered_mark_is_left_out_only_when_near_a_passed_one_in_both_coordinates(
        offset, near):
    memory = (known(500.0, 1500.0),)
    passed = [passed_at(500.0 + offset[0], 1500.0 + offset[1])]
    found = remembered_target(memory, "red", passed, (0.0, 0.0), [])
    assert (found is None) == near


def test_marks_the_memory_skips_do_not_hide_the_ones_after_them():
    here = (0.0, 0.0)
    # another colour, one seen too rarely, one near a passed mark, one in view now: each comes
    # before the answer in the memory and is passed over, not the end of the search
    answer = known(-400.0, 2500.0)
    rare = keys.KnownMark("red", 300.0, 900.0, 0.0, 1000.0, seen=MEMORY_MIN_SEEN - 1)
    assert remembered_target((known(0.0, 800.0, "green"), answer), "red", (), here, []) == answer
    assert remembered_target((rare, answer), "red", (), here, []) == answer
    assert remembered_target((known(0.0, 700.0), answer), "red", [passed_at(0.0, 700.0)], here,
                             []) == answer
    in_view = [seen("red", 20.0, 1010.0)]
    assert remembered_target((known(0.0, 1000.0), answer), "red", (), here, in_view) == answer


def test_a_sighting_exactly_one_gate_from_a_remembered_mark_is_that_mark_in_view():
    sighting = seen("red", 0.0, 1000.0)        # 1 m away: gate 250 mm
    memory = (known(250.0, 1000.0, range_mm=1500.0),)
    assert remembered_target(memory, "red", (), (0.0, 0.0), [sighting]) is None
    beyond = (known(250.5, 1000.0, range_mm=1500.0),)
    assert remembered_target(beyond, "red", (), (0.0, 0.0), [sighting]) == beyond[0]


@pytest.mark.parametrize(("a", "b"), [
    ((0.0, 1000.0), (1500.0, 200.0)),   # nearer by y alone the other one would win
    ((1000.0, 0.0), (200.0, 1500.0))])  # nearer by x alone the other one would win
def test_the_nearest_remembered_mark_is_nearest_by_straight_line(a, b):
    memory = (known(*b), known(*a))
    assert remembered_target(memory, "red", (), (0.0, 0.0), []).world == a


def test_a_turned_robot_misses_a_mark_straight_ahead_not_one_to_the_side():
    # facing 45°: a mark 1 m straight ahead has dx = dy; the lateral offset is c·dy − s·dx = 0
    here = Pose(200.0, -100.0, math.pi / 4)
    ahead = (200.0 + 1000.0 * math.cos(math.pi / 4), -100.0 + 1000.0 * math.sin(math.pi / 4))
    assert misses(ahead, here) == 1
    # 1 m along the heading and 600 mm to its left: outside 0.75 × the half view (21.4°)
    aside = (ahead[0] - 600.0 * math.sin(math.pi / 4), ahead[1] + 600.0 * math.cos(math.pi / 4))
    assert misses(aside, here) == 0


# -- SelectTarget between the memory, the sighting and the passed marks --------------------------


def select(rig, *, robot=None, marks=(), passed=(), memory=(), mission=None):
    """One tick of SelectTarget for red (waypoint 2) on a blackboard holding only these."""
    import py_trees

    from marknav.behaviours.target import SelectTarget

    py_trees.blackboard.Blackboard.clear()
    node = SelectTarget(colour="red", waypoint=2)
    tree = py_trees.trees.BehaviourTree(node)
    tree.setup(robot=robot or rig.robot, clock=rig.clock, mission=mission or rig.mission)
    bb = py_trees.blackboard.Blackboard
    bb.set(keys.MARKS, tuple(marks))
    bb.set(keys.PASSED, tuple(passed))
    bb.set(keys.KNOWN, tuple(memory))
    tree.tick()
    return bb.get(keys.TARGET)


def test_select_skips_a_passed_mark_in_view_for_the_next_one(rig):
    near, far = seen("red", 0.0, 600.0), seen("red", 300.0, 2000.0)
    chosen = select(rig, marks=[near, far], passed=[passed_at(10.0, 610.0)])
    assert chosen.sighting == far and not chosen.remembered


def test_select_on_a_figure_eight_may_target_a_mark_passed_before_the_last(rig,
                                                                           mission_factory):
    figure_eight = mission_factory(navigation={"revisit_marks": True})
    first_red, green = passed_at(0.0, 1500.0, i=0), passed_at(0.0, 3000.0, "green", i=1)
    again = seen("red", 0.0, 1500.0)
    chosen = select(rig, marks=[again], passed=[first_red, green], mission=figure_eight)
    assert chosen.sighting == again
    # without revisiting, the same mark stays passed: nothing to target in view
    assert select(rig, marks=[again], passed=[first_red, green]).sighting is None


def test_select_takes_a_remembered_mark_when_none_is_in_view_and_no_target_was_kept(rig):
    memory = known(-300.0, 2500.0)
    chosen = select(rig, memory=[memory])
    assert chosen.remembered and chosen.world == memory.world and chosen.sighting is None


def test_select_prefers_a_remembered_mark_much_nearer_than_the_one_in_view_off_the_origin(
        rig, manual_clock):
    from marknav.testing import FakeRobot

    here = Pose(1000.0, 1000.0, math.pi / 2)
    robot = FakeRobot(clock=manual_clock, pose=here)
    far = seen_from(here, "red", 1000.0, 3000.0)            # 2 m ahead
    memory = known(1000.0, 2000.0, range_mm=900.0)
    chosen = select(rig, robot=robot, marks=[far], memory=[memory])
    # 1000 mm from the robot, 1500 mm short of the sighting's 2000 − 500: the memory wins
    assert chosen.remembered and chosen.world == (1000.0, 2000.0)
    # exactly at the preference boundary (memory 1500 mm away, sighting 2000 mm): still memory;
    # beyond it, the mark in view
    edge = known(1000.0, 2500.0, range_mm=900.0)
    assert select(rig, robot=robot, marks=[far], memory=[edge]).remembered
    past = known(1000.0 + 1501.0 * math.cos(0.3), 1000.0 + 1501.0 * math.sin(0.3))
    chosen = select(rig, robot=robot, marks=[far], memory=[past])
    assert not chosen.remembered and chosen.sighting == far


def test_a_remembered_target_is_recognised_once_centred_from_anywhere():
    # the robot at (1000, 500) facing 45°, the remembered mark 1 m straight ahead: recognised;
    # turned 30° away from it: not yet
    here = Pose(1000.0, 500.0, math.pi / 4)
    ahead = (1000.0 + 1000.0 * math.cos(math.pi / 4), 500.0 + 1000.0 * math.sin(math.pi / 4))
    memory = target(remembered=True, world_x=ahead[0], world_y=ahead[1])
    sighting = seen_from(here, "red", ahead[0] + 30.0, ahead[1])
    assert associate([sighting], memory, (), here) == sighting
    turned = Pose(here.x, here.y, here.theta + math.radians(30.0))
    assert associate([seen_from(turned, "red", *ahead)], memory, (), turned) is None
