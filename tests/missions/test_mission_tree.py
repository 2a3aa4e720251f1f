"""MissionTree: py_trees' BehaviourTree without the post-tick walk nobody asked for."""

from __future__ import annotations

import py_trees
from py_trees.common import Status

from marknav.runs.runner import MissionTree


class Counting(py_trees.visitors.VisitorBase):
    def __init__(self, *, full: bool) -> None:
        super().__init__(full=full)
        self.seen: list[str] = []

    def run(self, behaviour: py_trees.behaviour.Behaviour) -> None:
        self.seen.append(behaviour.name)


def make_root() -> py_trees.behaviour.Behaviour:
    return py_trees.composites.Sequence("root", memory=True, children=[
        py_trees.behaviours.Success("a"),
        py_trees.behaviours.Running("b"),
        py_trees.behaviours.Success("c"),
    ])


def test_same_statuses_and_visits_as_py_trees() -> None:
    ours, theirs = MissionTree(make_root()), py_trees.trees.BehaviourTree(make_root())
    visitors = []
    for tree in (ours, theirs):
        partial, full = Counting(full=False), Counting(full=True)
        tree.add_visitor(partial)
        tree.add_visitor(full)
        visitors.append((partial, full))
        handled: list[int] = []
        tree.add_post_tick_handler(lambda t, handled=handled: handled.append(t.count))
        for _ in range(3):
            tree.tick()
        assert handled == [0, 1, 2]
        assert tree.root.status == Status.RUNNING
        assert [c.status for c in tree.root.children] == [
            Status.SUCCESS, Status.RUNNING, Status.INVALID]
    (p1, f1), (p2, f2) = visitors
    assert p1.seen == p2.seen  # nodes ticked
    assert f1.seen == f2.seen  # every node, each tick (full visitors still get the walk)


def test_no_walk_without_full_visitors(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    tree = MissionTree(make_root())
    walks: list[int] = []
    original = tree.root.iterate

    def counting_iterate(*args, **kwargs):  # type: ignore[no-untyped-def]
        walks.append(1)
        return original(*args, **kwargs)

    monkeypatch.setattr(tree.root, "iterate", counting_iterate)
    tree.tick()
    assert walks == []
    assert tree.count == 1
