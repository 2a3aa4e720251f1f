"""Target selection and association: nearest mark, locked by world position, passed excluded."""

from __future__ import annotations

import math
from dataclasses import replace

import py_trees
import pytest
from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.target import (
    SelectTarget,
    TargetLocked,
    TargetSeen,
    WaypointPassed,
    associate,
    nearest_of_colour,
    remember,
    remembered_target,
)
from marknav.planning.kinematics import Pose
from marknav.testing import RobotMark


def seen(colour: str, x: float, y: float, t: float = 0.0) -> keys.SeenMark:
    """A 100 mm mark seen from the origin facing +y (forward = y, left = -x) by a camera of
    f = 590 px (its image radius f·R/d)."""
    return keys.SeenMark(colour=colour, forward_mm=y, left_mm=-x, world_x=x, world_y=y,
                         x_px=0.0, radius_px=590.0 * 100.0 / max(y, 100.0), image_width=640,
                         t=t)


def target(**kw) -> keys.Target:
    base = {"waypoint": 0, "waypoint_id": "waypoint-0-red", "colour": "red", "side": "left"}
    return keys.Target(**{**base, **kw})


def test_unlocked_target_is_the_nearest_mark_of_its_colour():
    marks = [seen("red", 0, 2000), seen("green", 0, 900), seen("red", 300, 1200)]
    assert associate(marks, target()) == marks[2]
    assert associate([marks[1]], target()) is None


def test_locked_target_follows_its_world_position_not_the_nearest():
    far, near = seen("red", 0, 2000), seen("red", 300, 1200)
    locked = target(locked=True, world_x=40.0, world_y=1900.0)
    assert associate([far, near], locked) == far
    # beyond the gate (max(250, 20 % of range)), nothing is associated
    assert associate([near], locked) is None


def test_passed_marks_are_never_selected_again():
    old, new = seen("red", -200, 400), seen("red", 250, 2500)
    passed = [keys.PassedWaypoint(waypoint=0, waypoint_id="w0", colour="red", side="left",
                                  t=1.0, mark_x=-180.0, mark_y=420.0)]
    assert nearest_of_colour([old, new], "red") == old
    assert nearest_of_colour([old, new], "red", passed) == new
    # a passed mark of another colour at the same place does not exclude it
    green_passed = [keys.PassedWaypoint(0, "w0", "green", "right", 1.0, -200.0, 400.0)]
    assert nearest_of_colour([old, new], "red", green_passed) == old


def test_select_target_then_seen_until_lost(rig):
    # red ahead for 3 ticks, then out of view
    rig.perception.script = [[RobotMark("red", 1500.0, 100.0)]] * 3
    select = SelectTarget(colour="red", waypoint=0)
    seen_node = TargetSeen()
    root = py_trees.composites.Sequence("Root", memory=False,
                                        children=[rig.perception, select, seen_node])
    tree = rig.tree(root)
    statuses = []
    for _ in range(9):
        tree.tick()
        statuses.append(tree.root.status)
        rig.clock.advance(0.1)
    # seen at t = 0, 0.1, 0.2; still "seen" up to 0.5 s later; lost at t = 0.8
    assert statuses == [Status.SUCCESS] * 8 + [Status.FAILURE]
    assert seen_node.feedback_message == "red #1 unseen for 0.60 s"
    t = rig.bb(keys.TARGET)
    assert (t.colour, t.side, t.waypoint, t.locked) == ("red", "left", 0, False)
    assert t.sighting.t == pytest.approx(0.2)
    assert t.world == (pytest.approx(-100.0), pytest.approx(1500.0))  # origin, facing +y
    assert select.feedback_message == "red #1, pass on its left: not in view"


def test_select_target_keeps_a_locked_target_of_its_waypoint(rig):
    rig.perception.script = [[RobotMark("red", 600.0, 0.0), RobotMark("red", 2000.0, 500.0)]]
    py_trees.blackboard.Blackboard.set(keys.TARGET, target(
        locked=True, world_x=-500.0, world_y=2000.0))
    select = SelectTarget(colour="red", waypoint=0)
    locked = TargetLocked(waypoint_id="waypoint-0-red")
    root = py_trees.composites.Sequence("Root", memory=False,
                                        children=[rig.perception, select, locked])
    tree = rig.tree(root)
    tree.tick()
    assert tree.root.status == Status.SUCCESS
    t = rig.bb(keys.TARGET)
    assert t.locked
    # Perception associated the far mark (by position), not the nearer one straight ahead
    assert t.sighting.forward_mm == 2000.0
    assert select.feedback_message == "red #1 (locked, bypass under way)"


def test_waypoint_passed_reads_route_progress(rig):
    node = WaypointPassed(waypoint_id="waypoint-1-green")
    tree = rig.tree(node)
    tree.tick()
    assert node.status == Status.FAILURE
    py_trees.blackboard.Blackboard.set(keys.PASSED, (keys.PassedWaypoint(
        1, "waypoint-1-green", "green", "right", 12.5, 0.0, 3000.0),))
    tree.tick()
    assert node.status == Status.SUCCESS
    assert node.feedback_message == "passed on its right at t=12.5 s"


def test_revisit_marks_excludes_only_the_mark_passed_last(mission_factory):
    from marknav.behaviours import keys
    from marknav.behaviours.target import excluded_passes

    def passed(i, colour):
        return keys.PassedWaypoint(waypoint=i, waypoint_id=f"w{i}", colour=colour, side="left",
                                   t=float(i), mark_x=0.0, mark_y=1000.0 * i)

    history = (passed(0, "red"), passed(1, "green"))
    assert excluded_passes(history, mission_factory()) == history
    figure_eight = mission_factory(navigation={"revisit_marks": True})
    assert excluded_passes(history, figure_eight) == history[1:]
    assert excluded_passes((), figure_eight) == ()
    assert excluded_passes(history, None) == history


# -- the mark memory -------------------------------------------------------------------------


def test_remember_updates_within_the_gate_adds_new_marks_and_ignores_far_ones():
    known = remember((), [seen("red", 0, 1500, t=0.0), seen("green", 500, 3000, t=0.0),
                          seen("blue", 0, 4500, t=0.0)])  # blue: beyond 4 m, too coarse
    assert [(k.colour, k.world) for k in known] == [("red", (0, 1500)), ("green", (500, 3000))]
    known = remember(known, [seen("red", 80, 1450, t=0.5), seen("red", -900, 1500, t=0.5)])
    assert [(k.colour, k.world, k.t, k.seen) for k in known] == [
        ("red", (80, 1450), 0.5, 2),     # the same red (80 mm off, gate 300 mm): updated
        ("green", (500, 3000), 0.0, 1),
        ("red", (-900, 1500), 0.5, 1)]   # another red


def test_a_remembered_mark_in_view_that_is_not_seen_is_forgotten():
    """A green mark read as blue for a few frames must not become a remembered "blue" where no
    blue stands (the robot would search for it in vain): a mark seen in three frames that
    should be in view but is not seen for three frames is forgotten."""
    origin = Pose(0.0, 0.0, math.pi / 2)  # facing +y, as seen() assumes
    known = remember((), [seen("blue", 100, 2000)] * 3)
    assert known[0].seen == 3
    half_fov = math.radians(28.5)
    for expected_missed in (1, 2):
        known = remember(known, [seen("green", -250, 2000)], pose=origin, half_fov_rad=half_fov)
        assert [(k.colour, k.missed) for k in known if k.colour == "blue"] == [
            ("blue", expected_missed)]
    known = remember(known, [], pose=origin, half_fov_rad=half_fov)
    assert [k.colour for k in known] == ["green"]
    # out of view (behind the robot): nothing to say about it
    behind = Pose(0.0, 3000.0, math.pi / 2)
    kept = remember(remember((), [seen("red", 0, 1500)]), [], pose=behind, half_fov_rad=half_fov)
    assert kept[0].missed == 0


def test_a_mark_seen_in_many_frames_outlasts_as_many_misses():
    """A mark confirmed in 12 frames, then unseen in view (turned edge-on as the robot closes
    in beside it): kept through 11 misses, forgotten at the 12th."""
    origin = Pose(0.0, 0.0, math.pi / 2)
    half_fov = math.radians(28.5)
    known = remember((), [seen("red", 100, 2000)])
    for _ in range(11):
        known = remember(known, [seen("red", 100, 2000)])
    assert known[0].seen == 12
    for expected_missed in range(1, 12):
        known = remember(known, [], pose=origin, half_fov_rad=half_fov)
        assert [(k.colour, k.missed) for k in known] == [("red", expected_missed)]
    assert remember(known, [], pose=origin, half_fov_rad=half_fov) == ()


def test_remembered_target_is_the_nearest_unpassed_mark_out_of_view():
    known = remember((), [seen("green", 900, 1800), seen("green", 300, 900)])
    known = remember(remember(known, [seen("green", 900, 1800), seen("green", 300, 900)]),
                     [seen("green", 900, 1800), seen("green", 300, 900)])
    assert [k.seen for k in known] == [3, 3]
    assert remembered_target(remember((), [seen("green", 900, 1800)]), "green", (), (0.0, 0.0),
                             []) is None  # seen once: perhaps a false detection
    passed = (keys.PassedWaypoint(waypoint=0, waypoint_id="w0", colour="green", side="right",
                                  t=0.0, mark_x=300.0, mark_y=900.0),)  # the nearer one
    in_view = [seen("green", 0, 9000)]
    got = remembered_target(known, "green", passed, (0.0, 0.0), in_view)
    assert got is not None and got.world == (900, 1800)
    # in view now: the sighting speaks for it
    assert remembered_target(known, "green", passed, (0.0, 0.0), [seen("green", 950, 1800)]) \
        is None
    assert remembered_target(known, "green", (), (0.0, 0.0), in_view) == known[1]  # nearest
    assert remembered_target(known, "red", (), (0.0, 0.0), in_view) is None


def test_a_remembered_nearer_mark_beats_a_farther_one_in_view(rig):
    """Long-course seed 3: a bypass left the robot facing away from the next green; a green far
    down the course was in view. The target is the remembered one, followed by position."""
    py_trees.blackboard.Blackboard.set(keys.KNOWN, remember((), [seen("green", 1500, 1500)] * 3))
    rig.perception.script = [[RobotMark("green", 8000.0, 300.0)]]  # far, straight ahead
    select = SelectTarget(colour="green", waypoint=1)
    root = py_trees.composites.Sequence("Root", memory=False,
                                        children=[rig.perception, select])
    tree = rig.tree(root)
    tree.tick()
    t = rig.bb(keys.TARGET)
    assert t.remembered and t.sighting is None and t.world == (1500, 1500)
    assert select.feedback_message == ("green #2, pass on its right: out of view, "
                                       "remembered from t=0.0 s")
    # Perception does not swap it for the far green: association is by position
    assert associate([seen("green", -300, 8000)], t) is None
    assert associate([seen("green", 1450, 1520)], t) is not None


def test_a_mark_in_view_as_near_as_the_remembered_one_wins(rig):
    py_trees.blackboard.Blackboard.set(keys.KNOWN, remember((), [seen("green", 1500, 1500)] * 3))
    rig.perception.script = [[RobotMark("green", 2000.0, 300.0)]]  # 2.02 m vs 2.12 m
    root = py_trees.composites.Sequence("Root", memory=False, children=[
        rig.perception, SelectTarget(colour="green", waypoint=1)])
    rig.tree(root).tick()
    t = rig.bb(keys.TARGET)
    assert not t.remembered and t.sighting is not None and t.sighting.forward_mm == 2000.0


def test_a_remembered_target_is_recognised_within_a_wider_gate():
    """A mark remembered from 3 m may be 470 mm off its true place; seen again from 1.9 m (gate
    407 mm) it must still be recognised, or the search turns in vain."""
    t = target(colour="yellow", remembered=True, world_x=0.0, world_y=2370.0)
    near = seen("yellow", 0, 1900)
    assert associate([near], replace(t, remembered=False)) is not None  # unlocked: nearest
    assert associate([near], t) is near                                # 470 mm ≤ 2.5 × 407 mm
    assert associate([near], replace(t, locked=True, remembered=False)) is None  # locked: strict


def test_a_remembered_target_is_taken_only_once_turned_toward_it():
    """Issue 11's zigzag: purple #4 remembered 2.1 m ahead-right, its estimate off; turning
    toward it the search first saw purple #5 (the next mark, within the wide gate) and took it.
    Now nothing is taken until the remembered position is near the heading; then the sighting
    nearest to the remembered position wins."""
    t = target(colour="purple", remembered=True, world_x=1500.0, world_y=1500.0)
    nxt = seen("purple", 900, 2400)    # 1082 mm from the memory: within 2.5 gates (1616 mm)
    real = seen("purple", 1800, 1250)  # 391 mm from it
    facing_next = Pose(0.0, 0.0, math.atan2(2400, 900))
    facing_memory = Pose(0.0, 0.0, math.radians(45.0 + 5.0))
    assert associate([nxt], t) is nxt                       # without the pose: the gate alone
    assert associate([nxt], t, pose=facing_next) is None    # memory 23° off the heading
    assert associate([nxt, real], t, pose=facing_memory) is real
    assert associate([nxt], t, pose=facing_memory) is nxt   # alone, within the gate: taken
    # A locked target is not affected (followed by position, strict gate).
    locked = replace(t, locked=True, remembered=False, world_x=900.0, world_y=2400.0)
    assert associate([nxt], locked, pose=facing_next) is nxt


def test_an_unlocked_target_out_of_view_is_not_swapped_for_a_farther_mark_of_its_colour():
    """Random mission 190: the approach's target, 0.9 m away and 33° right, left the view; the
    nearest red in view was the next one down the course, 4.9 m ahead, and the approach took
    it, passing the near one on the wrong side. The memory holds the near one out of view: no
    sighting of the target this frame (the search turns back toward it)."""
    near = seen("red", 500, 750)
    known = remember((), [near, near, near])
    chasing = target(sighting=near, world_x=near.world_x, world_y=near.world_y)
    farther = seen("red", 0, 4900)
    here = Pose(0.0, 0.0, math.pi / 2)
    assert associate([farther], chasing, (), here, known) is None
    # without the memory, or without the pose, the nearest of the colour in view, as before
    assert associate([farther], chasing) == farther
    assert associate([farther], chasing, (), None, known) == farther
    # the target's own mark in view again: it
    assert associate([farther, near], chasing, (), here, known) == near
    # a mark in view not clearly nearer than the remembered one (by 500 mm) is taken ...
    close = seen("red", -300, 1100)
    assert associate([close], chasing, (), here, known) == close
    # ... and so is one in view when the memory holds a mark of the colour elsewhere, not the
    # target's own
    elsewhere = remember((), [seen("red", -900, 300)] * 3)
    assert associate([farther], chasing, (), here, elsewhere) == farther
    # a mark passed already is no memory to keep
    passed = [keys.PassedWaypoint(0, "w0", "red", "left", 1.0, near.world_x, near.world_y)]
    assert associate([farther], chasing, passed, here, known) == farther
