"""marknav's Sequence/Selector (behaviours/composites.py) against py_trees' own.

Random trees are built three times from one seed — py_trees' composites ticked by their
generators, marknav's ticked by their generators (``tick``), marknav's ticked by ``tick_now`` —
with scripted leaves that log every initialise / update / terminate. After every tick the logs,
every node's status and current child, and (for the generator ticks) the nodes yielded must be
the same. The leaves include the three kinds ``tick_now`` treats differently: a MarknavBehaviour
(ticked by its ``tick_now``), a plain py_trees behaviour and a decorator (their generators), and
a MarknavBehaviour that overrides ``tick`` (its generator).
"""

from __future__ import annotations

import random
from collections.abc import Callable, Iterator
from typing import Any

import py_trees
import pytest
from py_trees.behaviour import Behaviour
from py_trees.common import Status

from marknav.behaviours import composites
from marknav.behaviours.base import MarknavBehaviour
from marknav.runs.runner import MissionTree

_STATUSES = (Status.SUCCESS, Status.FAILURE, Status.RUNNING)

Log = list[tuple[Any, ...]]


def _script(seed: int, index: int) -> Callable[[], Status]:
    rng = random.Random(seed * 1000 + index)
    return lambda: rng.choice(_STATUSES)


class _Leaf(MarknavBehaviour):
    def __init__(self, name: str, log: Log, script: Callable[[], Status]) -> None:
        super().__init__(name)
        self._log, self._script = log, script

    def initialise(self) -> None:
        self._log.append(("initialise", self.name))

    def update(self) -> Status:
        status = self._script()
        self._log.append(("update", self.name, status))
        return status

    def terminate(self, new_status: Status) -> None:
        self._log.append(("terminate", self.name, new_status))


class _OwnTick(_Leaf):
    """Overrides ``tick``: composites must run this generator, also from ``tick_now``."""

    def tick(self) -> Iterator[Behaviour]:
        self._log.append(("own tick", self.name))
        yield from super().tick()


class _Plain(py_trees.behaviour.Behaviour):
    """A py_trees behaviour (no tick_now): ticked through its generator."""

    def __init__(self, name: str, log: Log, script: Callable[[], Status]) -> None:
        super().__init__(name)
        self._log, self._script = log, script

    def initialise(self) -> None:
        self._log.append(("initialise", self.name))

    def update(self) -> Status:
        status = self._script()
        self._log.append(("update", self.name, status))
        return status

    def terminate(self, new_status: Status) -> None:
        self._log.append(("terminate", self.name, new_status))


def _build(seed: int, kind: str, log: Log) -> Behaviour:
    """A random tree (the same shape for every ``kind``: one RNG drives the shape)."""
    rng = random.Random(seed)
    seq, sel = ((py_trees.composites.Sequence, py_trees.composites.Selector) if kind == "py_trees"
                else (composites.Sequence, composites.Selector))
    count = [0]

    def node(depth: int) -> Behaviour:
        count[0] += 1
        i = count[0]
        roll = rng.random()
        if depth < 4 and roll < 0.45:
            cls = seq if rng.random() < 0.5 else sel
            children = [node(depth + 1) for _ in range(rng.randint(1, 4))]
            return cls(f"{cls.__name__} {i}", memory=rng.random() < 0.5, children=children)
        leaf_kind = rng.random()
        if leaf_kind < 0.6:
            return _Leaf(f"leaf {i}", log, _script(seed, i))
        if leaf_kind < 0.75:
            return _Plain(f"plain {i}", log, _script(seed, i))
        if leaf_kind < 0.9:
            return py_trees.decorators.Inverter(
                f"inverter {i}", child=_Leaf(f"inverted {i}", log, _script(seed, i)))
        return _OwnTick(f"own tick {i}", log, _script(seed, i))

    root = node(0)
    if not isinstance(root, py_trees.composites.Composite):
        root = seq("root", memory=False, children=[root])
    return root


def _state(root: Behaviour) -> list[tuple[str, Status, str | None]]:
    out = []
    for n in root.iterate():
        current = getattr(n, "current_child", None)
        out.append((n.name, n.status, current.name if current is not None else None))
    return out


@pytest.mark.parametrize("seed", range(60))
def test_random_trees_tick_as_with_py_trees_composites(blackboard: None, seed: int) -> None:
    logs: dict[str, Log] = {k: [] for k in ("py_trees", "tick", "tick_now")}
    roots = {k: _build(seed, k, logs[k]) for k in logs}
    assert [type(n).__mro__[1] if isinstance(n, composites.Sequence | composites.Selector)
            else type(n) for n in roots["tick"].iterate()] == \
        [type(n) for n in roots["py_trees"].iterate()]
    for tick in range(40):
        yielded = {k: [n.name for n in roots[k].tick()] for k in ("py_trees", "tick")}
        composites.tick_now(roots["tick_now"])
        assert yielded["tick"] == yielded["py_trees"], f"seed {seed}, tick {tick}"
        assert logs["tick"] == logs["py_trees"], f"seed {seed}, tick {tick}"
        assert logs["tick_now"] == logs["py_trees"], f"seed {seed}, tick {tick}"
        expected = _state(roots["py_trees"])
        assert _state(roots["tick"]) == expected
        assert _state(roots["tick_now"]) == expected
    assert len(logs["py_trees"]) > 40  # the trees did something


def test_stopping_a_running_tree_invalidates_it_as_py_trees_does(blackboard: None) -> None:
    for seed in range(20):
        logs: dict[str, Log] = {k: [] for k in ("py_trees", "tick_now")}
        roots = {k: _build(seed, k, logs[k]) for k in logs}
        for _ in range(5):
            for _ in roots["py_trees"].tick():
                pass
            composites.tick_now(roots["tick_now"])
        for root in roots.values():
            root.stop(Status.INVALID)
        assert logs["tick_now"] == logs["py_trees"]
        assert _state(roots["tick_now"]) == _state(roots["py_trees"])


def test_an_overridden_tick_opts_out_of_tick_now() -> None:
    assert MarknavBehaviour.TICK_NOW and _Leaf.TICK_NOW
    assert not _OwnTick.TICK_NOW

    class Sub(composites.Sequence):
        def tick(self) -> Iterator[Behaviour]:
            yield from super().tick()

    assert composites.Sequence.TICK_NOW and not Sub.TICK_NOW


def test_with_py_trees_debug_logging_its_own_code_runs(
        blackboard: None, monkeypatch: pytest.MonkeyPatch) -> None:
    messages: list[str] = []
    monkeypatch.setattr(py_trees.console, "logdebug", messages.append)
    monkeypatch.setattr(py_trees.logging, "level", py_trees.logging.Level.DEBUG)
    log: Log = []
    root = composites.Sequence("Seq", memory=False, children=[
        composites.Selector("Sel", memory=False, children=[
            _Leaf("a", log, lambda: Status.FAILURE), _Leaf("b", log, lambda: Status.SUCCESS)])])
    composites.tick_now(root)
    for _ in root.tick():
        pass
    assert sum(m.endswith("Sequence.tick()") for m in messages) == 2
    assert sum(m.endswith("Selector.tick()") for m in messages) == 2
    assert any("Selector.stop()" in m for m in messages)
    assert root.status == Status.SUCCESS


def test_mission_tree_ticks_with_or_without_a_visitor_alike(blackboard: None) -> None:
    class Names(py_trees.visitors.VisitorBase):
        def __init__(self) -> None:
            super().__init__(full=False)
            self.seen: list[str] = []

        def run(self, behaviour: Behaviour) -> None:
            self.seen.append(behaviour.name)

    logs: dict[str, Log] = {k: [] for k in ("visited", "plain")}
    trees = {k: MissionTree(_build(7, k, logs[k])) for k in logs}
    visitor = Names()
    trees["visited"].add_visitor(visitor)
    for _ in range(30):
        for tree in trees.values():
            tree.tick()
    assert logs["plain"] == logs["visited"]
    assert _state(trees["plain"].root) == _state(trees["visited"].root)
    assert visitor.seen and trees["plain"].count == trees["visited"].count == 30


def _run_route(monkeypatch: pytest.MonkeyPatch, lean: bool, ticks: int) -> tuple[Any, ...]:
    from marknav.behaviours import keys, route
    from marknav.core.clock import ManualClock
    from marknav.sim.world import generate_world
    from marknav.testing import FakePerception, FakeRobot, WorldMark, make_mission

    with monkeypatch.context() as m:
        if not lean:
            m.setattr(route, "Sequence", py_trees.composites.Sequence)
            m.setattr(route, "Selector", py_trees.composites.Selector)
        mission = make_mission(name="eight", route=["red", "green", "blue", "red"] * 2)
        world = generate_world(
            mission.route, seed=3, clearance_mm=mission.navigation.clearance_mm,
            radius_mm=mission.marks.radius_mm,
            bypass_distance_mm=mission.navigation.bypass_distance_mm,
            sides=[mission.side_of(c) for c in mission.route],
            half_fov_deg=mission.camera.hfov_deg / 2.0)
        keys.reset()
        clock = ManualClock()
        robot = FakeRobot(clock=clock, wheel_base_mm=mission.robot.wheel_base_mm)
        perception = FakePerception(world=[WorldMark(w.colour, w.x_mm, w.y_mm)
                                           for w in world.marks])
        root = route.build_route_tree(mission, perception=perception)
        tree = (MissionTree(root) if lean else py_trees.trees.BehaviourTree(root))
        tree.setup(robot=robot, clock=clock, mission=mission)
        statuses = []
        for _ in range(ticks):
            clock.advance(0.05)
            tree.tick()
            statuses.append(tuple(n.status for n in root.iterate()))
            if root.status != Status.RUNNING:
                break
        bb = py_trees.blackboard.Blackboard
        passed = bb.get(keys.PASSED) if bb.exists(keys.PASSED) else ()
        keys.reset()
        return robot.requests, statuses, passed, robot.true_pose


def test_the_route_tree_runs_as_with_py_trees_composites(
        blackboard: None, monkeypatch: pytest.MonkeyPatch) -> None:
    """An 8-waypoint route with mocked perception: marknav's composites ticked by MissionTree
    (tick_now) and py_trees' composites ticked by py_trees' BehaviourTree give the same wheel
    requests, statuses every tick, waypoints passed and final pose."""
    lean = _run_route(monkeypatch, True, 1500)
    plain = _run_route(monkeypatch, False, 1500)
    assert len(lean[2]) >= 4  # it got somewhere
    assert lean == plain
