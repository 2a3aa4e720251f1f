"""tick_until: statuses tick by tick, active path, clock stepping, early stop."""

import py_trees
import pytest
from py_trees.common import Status

from marknav.testing import ManualClock, active_path, tick_until


def _tree(ticks: int, then: Status) -> py_trees.trees.BehaviourTree:
    counter = py_trees.behaviours.TickCounter(name="Count", duration=ticks,
                                              completion_status=then)
    root = py_trees.composites.Sequence("Root", memory=True, children=[
        py_trees.behaviours.Success(name="First"), counter])
    return py_trees.trees.BehaviourTree(root)


def test_records_each_tick_until_the_status():
    clock = ManualClock(10.0)
    log = tick_until(_tree(3, Status.SUCCESS), Status.SUCCESS, max_ticks=10, clock=clock,
                     dt=0.1)
    assert log.reached
    assert log.statuses == [Status.RUNNING] * 3 + [Status.SUCCESS]
    assert [r.t for r in log] == pytest.approx([10.0, 10.1, 10.2, 10.3])
    assert log.active[:3] == ["Root/Count"] * 3
    assert log.active[3] == "Root"
    assert log.first("Count").index == 0
    assert clock.now() == pytest.approx(10.3)  # no advance after the last tick
    assert "reached after 4 ticks" in str(log)


def test_stops_on_another_terminal_status_and_on_max_ticks():
    log = tick_until(_tree(2, Status.FAILURE), Status.SUCCESS, max_ticks=10)
    assert not log.reached
    assert log.final == Status.FAILURE
    assert log.ticks == 3
    log = tick_until(_tree(50, Status.SUCCESS), Status.SUCCESS, max_ticks=5)
    assert (log.reached, log.ticks, log.final) == (False, 5, Status.RUNNING)
    with pytest.raises(ValueError):
        tick_until(_tree(1, Status.SUCCESS), max_ticks=0)


def test_accepts_a_bare_behaviour_and_follows_decorators():
    inner = py_trees.behaviours.Running(name="Spin")
    root = py_trees.decorators.Inverter(name="Not", child=inner)
    log = tick_until(root, Status.SUCCESS, max_ticks=2)
    assert log.active == ["Not/Spin", "Not/Spin"]
    assert active_path(root) == "Not/Spin"
