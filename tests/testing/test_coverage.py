"""Tree coverage: which nodes a test ticked and with which outcomes, as data (the
``tree_coverage`` fixture) and as the session summary of ``pytest --marknav-coverage``."""

from __future__ import annotations

import py_trees
import pytest
from py_trees.common import Status

from marknav.behaviours.route import build_route_tree
from marknav.testing import TreeCoverage, tick_until

pytest_plugins = ["pytester"]


def _selector() -> py_trees.behaviour.Behaviour:
    return py_trees.composites.Selector("Either", memory=False, children=[
        py_trees.behaviours.Failure("No"),
        py_trees.composites.Sequence("Both", memory=True, children=[
            py_trees.behaviours.Success("Yes"), py_trees.behaviours.Running("Wait")]),
        py_trees.behaviours.Success("Never"),
    ])


def test_counts_each_node_once_a_tick_with_the_status_it_ended_with() -> None:
    root = _selector()
    with TreeCoverage() as cov:
        for _ in range(3):
            root.tick_once()
    assert cov.ticked("Either") == 3
    assert cov.outcomes("No") == {"FAILURE"}
    assert cov.outcomes("Both") == {"RUNNING"}
    # memory: Yes ran in the first tick only, then the sequence resumed at Wait
    assert cov.ticked("Both/Yes") == 1 and cov.ticked("Wait") == 3
    assert cov.never_ticked() == ["Either/Never"]
    assert cov.as_dict()["Either/No"]["finishes"] == {"FAILURE: failure": 3}
    root.tick_once()  # after the collector stopped: not counted
    assert cov.ticked("Either") == 3


def test_behaviour_trees_are_watched_too_and_unknown_nodes_are_named() -> None:
    tree = py_trees.trees.BehaviourTree(_selector())
    visitors = list(tree.visitors)
    cov = TreeCoverage().start()
    try:
        tree.tick()
        tree.tick()
    finally:
        cov.stop()
    assert cov.ticked("Wait") == 2
    assert tree.visitors == visitors  # its own visitors as they were
    with pytest.raises(KeyError, match=r"no node 'Bypass'.*Wait"):
        cov.ticked("Bypass")


def test_a_waypoint_closed_loop_approach_and_bypass_ran_recovery_did_not(
        fake_robot, fake_perception, manual_clock, mission_factory, blackboard,
        tree_coverage) -> None:
    mission = mission_factory(route=["red"])
    fake_perception.place("red", x_mm=100, y_mm=2000)
    tree = py_trees.trees.BehaviourTree(build_route_tree(mission, perception=fake_perception))
    tree.setup(robot=fake_robot, clock=manual_clock, mission=mission)
    log = tick_until(tree, Status.SUCCESS, max_ticks=400, clock=manual_clock, dt=0.05)
    assert log.reached, log
    assert tree_coverage.outcomes("Pass/Bypass") == {"RUNNING", "SUCCESS"}
    assert "RUNNING" in tree_coverage.outcomes("Approach")
    assert tree_coverage.outcomes("Passed?") == {"FAILURE"}  # the tree ends as Pass succeeds
    assert tree_coverage.ticked("Mission") == log.ticks
    never = tree_coverage.never_ticked()
    assert any(p.endswith("/BackOff") for p in never)  # no bump: no recovery
    assert not any(p.endswith("/Bypass") for p in never)


def test_a_search_that_times_out_is_seen_with_its_message(
        fake_robot, fake_perception, manual_clock, mission_factory, blackboard,
        tree_coverage) -> None:
    mission = mission_factory(route=["red"])  # and no red mark anywhere
    tree = py_trees.trees.BehaviourTree(build_route_tree(mission, perception=fake_perception))
    tree.setup(robot=fake_robot, clock=manual_clock, mission=mission)
    log = tick_until(tree, Status.SUCCESS, max_ticks=2000, clock=manual_clock, dt=0.05)
    assert not log.reached
    assert "FAILURE" in tree_coverage.outcomes("Search")
    assert any("not found" in m for m in tree_coverage.messages("Search", "FAILURE"))
    assert tree_coverage.ticked("Bypass") == 0


def test_the_session_summary_lists_nodes_outcomes_and_what_never_ran(pytester) -> None:
    pytester.makepyfile(
        """
        import py_trees

        def test_one(tree_coverage):
            root = py_trees.composites.Selector("Root", memory=False, children=[
                py_trees.behaviours.Failure("Left"), py_trees.behaviours.Success("Right"),
                py_trees.behaviours.Success("Spare")])
            root.tick_once()
            root.tick_once()
            assert tree_coverage.outcomes("Right") == {"SUCCESS"}
        """
    )
    result = pytester.runpytest("-p", "no:cacheprovider", "--marknav-coverage")
    result.assert_outcomes(passed=1)
    result.stdout.re_match_lines([
        r".*marknav tree coverage.*",
        r"Root\s+2\s+0\s+2\s+0$",
        r"  Left\s+2\s+0\s+0\s+2$",
        r"  Right\s+2\s+0\s+2\s+0$",
        r"  Spare\s+0\s+0\s+0\s+0\s+never ticked$",
        r"4 nodes, 1 never ticked; 1 of 2 ticked leaves never failed",
    ])
    plain = pytester.runpytest("-p", "no:cacheprovider")
    assert "marknav tree coverage" not in plain.stdout.str()
