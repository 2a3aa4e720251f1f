"""The association gate's floor: near the mark, where the gate's 20 % of the range is small,
sightings that scatter by up to 250 mm still belong to the locked target (and to a passed mark).

Monocular estimates near a mark scatter by more than 20 % of the range (a partly occluded disc, a
mark at the image edge, a wrongly placed odometry pose): without the floor the locked target is
lost exactly when the bypass needs it, and a passed mark seen again from close by is taken for a
new one.
"""

from __future__ import annotations

import py_trees
import pytest
from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.target import (
    SelectTarget,
    TargetSeen,
    associate,
    gate_mm,
    nearest_of_colour,
)
from marknav.testing import RobotMark


def seen(colour: str, x: float, y: float, t: float = 0.0,
         radius_px: float = 10.0) -> keys.SeenMark:
    """A mark seen from the origin facing +y (forward = y, left = -x)."""
    return keys.SeenMark(colour=colour, forward_mm=y, left_mm=-x, world_x=x, world_y=y,
                         x_px=0.0, radius_px=radius_px, image_width=640, t=t)


def locked(x: float, y: float) -> keys.Target:
    return keys.Target(waypoint=0, waypoint_id="waypoint-0-red", colour="red", side="left",
                       locked=True, world_x=x, world_y=y)


def test_the_gate_is_250_mm_near_and_a_fifth_of_the_range_far():
    assert [gate_mm(r) for r in (0.0, 600.0, 1250.0, 2000.0, 5000.0)] == [
        250.0, 250.0, 250.0, 400.0, 1000.0]


def locked_tree(rig, sightings):
    """Perception (scripted) → SelectTarget (keeps the locked target) → Seen?."""
    rig.perception.script = sightings
    seen_node = TargetSeen()
    root = py_trees.composites.Sequence("Root", memory=False, children=[
        rig.perception, SelectTarget(colour="red", waypoint=0), seen_node])
    return rig.tree(root), seen_node


def test_a_locked_target_keeps_its_close_sightings_within_the_floor(rig):
    # Locked at (-100, 600); the next frame puts it 180 mm east, 600 mm ahead (gate: 20 % of
    # 627 mm is 125 mm, the floor makes it 250 mm): the same mark.
    py_trees.blackboard.Blackboard.set(keys.TARGET, locked(-100.0, 600.0))
    tree, seen_node = locked_tree(rig, [[RobotMark("red", 600.0, -80.0)]])
    tree.tick()
    assert tree.root.status == Status.SUCCESS
    assert seen_node.feedback_message == "red #1 seen 0.00 s ago"
    t = rig.bb(keys.TARGET)
    assert t.locked and t.world == (pytest.approx(80.0), pytest.approx(600.0))
    assert t.sighting is not None and t.sighting.forward_mm == 600.0


def test_a_close_sighting_beyond_the_floor_is_another_mark(rig):
    # 300 mm off at the same range: not the locked target, which stays where it was, unseen.
    py_trees.blackboard.Blackboard.set(keys.TARGET, locked(-100.0, 600.0))
    tree, seen_node = locked_tree(rig, [[RobotMark("red", 600.0, -200.0)]])
    tree.tick()
    assert tree.root.status == Status.FAILURE
    assert seen_node.feedback_message == "red #1 not seen yet"
    t = rig.bb(keys.TARGET)
    assert t.world == (-100.0, 600.0) and t.sighting is None


def test_far_away_the_gate_is_the_laws_error_and_the_radius_error():
    # A 100 mm mark 2 m away is 29.5 px across its radius (f = 590 px): gate (0.2 + 0.5 / 29.5)
    # of the range, 444 mm at (430, 2000) and 445 mm at (460, 2000).
    target = locked(0.0, 2000.0)
    assert associate([seen("red", 430.0, 2000.0, radius_px=29.5)], target) is not None
    assert associate([seen("red", 460.0, 2000.0, radius_px=29.5)], target) is None
    # A smaller image radius (a smaller mark, a shorter lens) reads the range less precisely:
    # the same offset is within its gate.
    assert associate([seen("red", 460.0, 2000.0, radius_px=12.0)], target) is not None


def test_a_passed_mark_seen_again_from_close_by_stays_passed():
    passed = [keys.PassedWaypoint(waypoint=0, waypoint_id="waypoint-0-red", colour="red",
                                  side="left", t=3.0, mark_x=0.0, mark_y=500.0)]
    again = seen("red", 200.0, 500.0)  # 200 mm off its recorded place, 539 mm away
    other = seen("red", 0.0, 1800.0)
    assert nearest_of_colour([again, other], "red", passed) == other
