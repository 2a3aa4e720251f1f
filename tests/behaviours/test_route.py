"""The default route tree: structure, three marks in order, progress across interruptions."""

from __future__ import annotations

import math

import py_trees
import pytest
from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.bypass import BezierBypass
from marknav.behaviours.route import build_route_tree, failure_reason
from marknav.behaviours.target import TargetLocked
from marknav.testing import active_path

from .conftest import tick_while

SLALOM = (("red", 150.0, 1500.0), ("green", -150.0, 3200.0), ("red", 200.0, 4800.0))


def route_tree(rig, route, marks):
    for colour, x, y in marks:
        rig.perception.place(colour, x_mm=x, y_mm=y)
    rig.mission = rig.mission.model_copy(update={"route": list(route)})
    return rig.tree(build_route_tree(rig.mission, perception=rig.perception))


def side_at(rig, mark):
    """The robot's x where it crossed the mark's y, minus the mark's x (true trajectory)."""
    _, pose = min(rig.robot.trajectory, key=lambda tp: abs(tp[1].y - mark[1]))
    return pose.x - mark[0]


def test_tree_shape_and_memory(mission_factory, blackboard):
    root = build_route_tree(mission_factory(route=["red", "green"]))
    text = py_trees.display.ascii_tree(root)
    assert text.splitlines()[:6] == [
        "[-] Mission", "    --> Perception", "    --> SafetyGuard", "    [o] BumpRecovery",
        "        --> NotBumped?", "        --> BackOff"]
    assert "    {-} Route" in text
    assert "        [o] Waypoint 1: red (pass on its left)" in text
    assert "        [o] Waypoint 2: green (pass on its right)" in text
    memory = {n.name: n.memory for n in root.iterate()
              if isinstance(n, py_trees.composites.Sequence | py_trees.composites.Selector)}
    assert memory["Mission"] is False and memory["BumpRecovery"] is False
    assert memory["Route"] is True and memory["Pass"] is True
    assert memory["Reach"] is False and memory["CloseIn"] is False
    assert memory["Seen?|Search"] is False


def test_passes_three_marks_in_order_on_their_sides(rig):
    tree = route_tree(rig, ["red", "green", "red"], SLALOM)
    log = rig.run(tree, max_ticks=800)
    assert log.reached, log
    passed = rig.bb(keys.PASSED)
    assert [(p.waypoint, p.colour, p.side) for p in passed] == [
        (0, "red", "left"), (1, "green", "right"), (2, "red", "left")]
    assert passed[0].t < passed[1].t < passed[2].t
    for (colour, x, y), p in zip(SLALOM, passed, strict=True):
        offset = side_at(rig, (x, y))
        assert (offset < 0) if p.side == "left" else (offset > 0), colour  # robot's side
        clearance = min(math.hypot(q.x - x, q.y - y) for _, q in rig.robot.trajectory)
        assert clearance >= 300.0 - 30.0, colour
    order = [log.first(f"Waypoint {i}:").index for i in (1, 2, 3)]
    assert order == sorted(order)
    assert len(rig.bb(keys.PLANS)) == 3
    assert rig.robot.wheels == (0, 0)


def test_route_progress_survives_a_recovery(rig):
    tree = route_tree(rig, ["red", "green"], SLALOM[:2])
    tick_while(rig, tree, lambda: "Waypoint 2" in active_path(tree.root)
               and "Approach" in active_path(tree.root), max_ticks=600)
    rig.robot.bump()
    tree.tick()
    assert active_path(tree.root) == "Mission/BumpRecovery/BackOff"
    rig.robot.release_bump()
    log = rig.run(tree, max_ticks=600)
    assert log.reached
    # waypoint 1 was not done again: the Route restarted, Passed? skipped it
    assert not any("Waypoint 1" in a for a in log.active)
    assert [p.colour for p in rig.bb(keys.PASSED)] == ["red", "green"]


def test_a_bump_mid_bypass_resumes_the_bypass_of_the_same_mark(rig):
    tree = route_tree(rig, ["red"], SLALOM[:1])
    bypass = next(n for n in tree.root.iterate() if isinstance(n, BezierBypass))
    locked = next(n for n in tree.root.iterate() if isinstance(n, TargetLocked))
    tick_while(rig, tree, lambda: bypass.status == Status.RUNNING)
    for _ in range(6):
        rig.clock.advance(0.05)
        tree.tick()
    rig.robot.bump()
    tree.tick()
    rig.robot.release_bump()
    tick_while(rig, tree, lambda: bypass.status == Status.RUNNING)
    assert locked.status == Status.SUCCESS  # "Bypassing?": no new approach, no search
    log = rig.run(tree, max_ticks=400)
    assert log.reached
    assert not log.visited("Approach") and not log.visited("Search")
    plans = rig.bb(keys.PLANS)
    assert [p.reason for p in plans] == ["initial", "resumed"]  # planned from the new pose
    assert plans[1].plan.mark_xy == pytest.approx(plans[0].plan.mark_xy)
    assert side_at(rig, (150.0, 1500.0)) < 0  # still passed on its left
    clearance = min(math.hypot(q.x - 150.0, q.y - 1500.0) for _, q in rig.robot.trajectory)
    assert clearance >= 270.0


def test_a_mark_that_cannot_be_found_fails_the_mission_with_the_reason(rig):
    tree = route_tree(rig, ["green"], ())  # nothing in the world
    log = rig.run(tree, Status.FAILURE, max_ticks=800)
    assert log.reached
    # a full turn at 40°/s (9 s), nothing to return to, 1 m on at 150 mm/s (6.7 s), a full turn
    assert log.records[-1].t == pytest.approx(9.0 + 1000.0 / 150.0 + 9.0, abs=0.3)
    why = failure_reason(tree.root)
    assert why is not None and not why.aborted
    assert why.path == ("Mission/Route/Waypoint 1: green (pass on its right)/Pass/Reach/"
                        "CloseIn/Seen?|Search/Search/Advance")
    head, driven = why.reason.rsplit(" ", 2)[0], why.reason.rsplit(" ", 2)[1]
    assert head == (
        "Advance: green #1 not found; gave up after spin: not found in a full turn (9.0 s); "
        "return: never seen, and fewer than two marks passed to predict it from; "
        "advance: not seen in a full turn after driving")
    assert float(driven) == pytest.approx(1000.0, abs=10.0)  # one tick at 150 mm/s: 7.5 mm
    assert failure_reason(tree.root.children[0]) is None  # Perception did not fail
