"""Tree coverage: which nodes of a behaviour tree a test ticked, and with which outcomes.

While a :class:`TreeCoverage` is active (the ``tree_coverage`` fixture, or every test under
``pytest --marknav-coverage``), every tick of any py_trees tree is watched — through
``BehaviourTree.tick`` (a visitor sees each node the tick reaches) and ``Behaviour.tick_once``
— and each node reached is counted once per tick with the status it ended the tick with, and
the feedback message it finished with (SUCCESS or FAILURE; e.g. a search's "timed out").

A node is named by its path of names from the root of the tree it was ticked in:
``Mission/Route/Waypoint 1: red (pass on its left)/Pass/Bypass``. Queries take a path or any
``/``-separated tail of one (``"Pass/Bypass"`` matches the bypass of every waypoint):

>>> cov.ticked("Bypass"), cov.outcomes("Search"), cov.never_ticked()  # doctest: +SKIP

With no collector active the wrappers only check an empty list: ~0.1 µs a tick.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import Status

__all__ = ["NodeCoverage", "TreeCoverage"]

#: Distinct finishing messages kept per node (the rest are counted under their status only).
MAX_MESSAGES = 20

_active: list[TreeCoverage] = []
_installed = False


@dataclass
class NodeCoverage:
    """One node's ticks: how many, and with which outcomes."""

    path: str
    kind: str
    ticks: int = 0
    statuses: Counter[str] = field(default_factory=Counter)
    #: ``(status, message)`` of the node's finishing ticks (SUCCESS or FAILURE)
    finishes: Counter[tuple[str, str]] = field(default_factory=Counter)

    def merge(self, other: NodeCoverage) -> None:
        self.ticks += other.ticks
        self.statuses.update(other.statuses)
        for key, n in other.finishes.items():
            if key in self.finishes or len(self.finishes) < MAX_MESSAGES:
                self.finishes[key] += n


def _kind(node: Behaviour) -> str:
    if isinstance(node, py_trees.composites.Composite):
        return type(node).__name__
    if isinstance(node, py_trees.decorators.Decorator):
        return "decorator"
    return "leaf"


def _paths(root: Behaviour) -> list[tuple[Behaviour, str]]:
    out: list[tuple[Behaviour, str]] = []
    stack: list[tuple[Behaviour, str]] = [(root, root.name)]
    while stack:
        node, path = stack.pop()
        out.append((node, path))
        stack.extend((c, f"{path}/{c.name}") for c in reversed(node.children))
    return out


class TreeCoverage:
    """Counts, per node path, the ticks seen while it is active (:meth:`start` / :meth:`stop`,
    or ``with coverage:``)."""

    def __init__(self) -> None:
        self.nodes: dict[str, NodeCoverage] = {}
        self._paths: dict[int, tuple[Any, dict[int, str]]] = {}

    # -- collecting ----------------------------------------------------------------------------
    def start(self) -> TreeCoverage:
        _install()
        if self not in _active:
            _active.append(self)
        return self

    def stop(self) -> None:
        if self in _active:
            _active.remove(self)

    def __enter__(self) -> TreeCoverage:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _path_of(self, root: Behaviour) -> dict[int, str]:
        known = self._paths.get(id(root))
        if known is None or known[0] is not root:
            paths = _paths(root)
            for node, path in paths:
                if path not in self.nodes:
                    self.nodes[path] = NodeCoverage(path, _kind(node))
            known = (root, {id(n): p for n, p in paths})
            self._paths[id(root)] = known
        return known[1]

    def record(self, root: Behaviour, reached: Iterable[Behaviour]) -> None:
        """One tick of the tree under ``root``: the nodes it reached (each once)."""
        paths = self._path_of(root)
        for node in reached:
            path = paths.get(id(node))
            if path is None:  # a node added to the tree after its first tick
                self._paths.pop(id(root), None)
                paths = self._path_of(root)
                path = paths[id(node)]
            cov = self.nodes[path]
            status = node.status.value
            cov.ticks += 1
            cov.statuses[status] += 1
            if node.status in (Status.SUCCESS, Status.FAILURE):
                key = (status, node.feedback_message)
                if key in cov.finishes or len(cov.finishes) < MAX_MESSAGES:
                    cov.finishes[key] += 1

    def merge(self, other: TreeCoverage) -> None:
        for path, cov in other.nodes.items():
            mine = self.nodes.setdefault(path, NodeCoverage(path, cov.kind))
            mine.merge(cov)

    # -- asking --------------------------------------------------------------------------------
    def find(self, path: str) -> list[NodeCoverage]:
        """The nodes whose path is ``path`` or ends with ``/path``."""
        return [c for p, c in self.nodes.items() if p == path or p.endswith("/" + path)]

    def _one_or_more(self, path: str) -> list[NodeCoverage]:
        found = self.find(path)
        if not found:
            known = ", ".join(sorted({p.rsplit("/", 1)[-1] for p in self.nodes})) or "none"
            raise KeyError(f"no node {path!r} in the trees ticked (nodes: {known})")
        return found

    def ticked(self, path: str) -> int:
        """Ticks the node (all nodes matching ``path``) got."""
        return sum(c.ticks for c in self._one_or_more(path))

    def outcomes(self, path: str) -> set[str]:
        """The statuses the node ended its ticks with (``RUNNING``, ``SUCCESS``, ``FAILURE``)."""
        return {s for c in self._one_or_more(path) for s, n in c.statuses.items() if n}

    def messages(self, path: str, status: str | None = None) -> set[str]:
        """The feedback messages the node finished with (of ``status`` only, if given)."""
        return {m for c in self._one_or_more(path) for (s, m) in c.finishes
                if status is None or s == status}

    def never_ticked(self) -> list[str]:
        """Paths of the nodes of the trees ticked that no tick reached."""
        return [p for p, c in self.nodes.items() if c.ticks == 0]

    def as_dict(self) -> dict[str, dict[str, Any]]:
        """Plain data: per path, ``ticks``, ``statuses`` and ``finishes`` (``"STATUS: msg"``)."""
        return {p: {"kind": c.kind, "ticks": c.ticks, "statuses": dict(c.statuses),
                    "finishes": {f"{s}: {m}": n for (s, m), n in c.finishes.items()}}
                for p, c in self.nodes.items()}

    def report(self, *, top: str | None = None) -> list[str]:
        """A table, one line per node, indented by depth: ticks, running / success / failure
        counts, and what never happened. ``top``: only paths under it."""
        lines = [f"{'node':60s} {'ticks':>7s} {'run':>6s} {'ok':>6s} {'fail':>6s}"]
        groups: dict[str, list[NodeCoverage]] = {}  # by root, in the order first ticked
        for path, c in self.nodes.items():
            if top is None or path.startswith(top):
                groups.setdefault(path.split("/", 1)[0], []).append(c)
        for c in (c for group in groups.values() for c in group):
            path = c.path
            depth = path.count("/")
            name = "  " * depth + path.rsplit("/", 1)[-1]
            st = c.statuses
            note = "  never ticked" if c.ticks == 0 else ""
            lines.append(f"{name[:60]:60s} {c.ticks:7d} {st['RUNNING']:6d} {st['SUCCESS']:6d} "
                         f"{st['FAILURE']:6d}{note}")
        return lines


def _commit(root: Behaviour, reached: dict[int, Behaviour]) -> None:
    for cov in list(_active):
        cov.record(root, reached.values())


class _Visitor(py_trees.visitors.VisitorBase):
    """Sees each node one tick of a BehaviourTree reaches."""

    def __init__(self) -> None:
        super().__init__(full=False)
        self.reached: dict[int, Behaviour] = {}

    def run(self, behaviour: Behaviour) -> None:
        self.reached[id(behaviour)] = behaviour


def _install() -> None:
    """Wrap ``BehaviourTree.tick`` and ``Behaviour.tick_once`` (once per process)."""
    global _installed
    if _installed:
        return
    _installed = True
    tree_tick: Callable[..., None] = py_trees.trees.BehaviourTree.tick
    tick_once: Callable[..., None] = py_trees.behaviour.Behaviour.tick_once

    def tick(self: py_trees.trees.BehaviourTree, *args: Any, **kwargs: Any) -> None:
        if not _active:
            tree_tick(self, *args, **kwargs)
            return
        visitor = _Visitor()
        self.visitors.append(visitor)
        try:
            tree_tick(self, *args, **kwargs)
        finally:
            self.visitors.remove(visitor)
            _commit(self.root, visitor.reached)

    def once(self: Behaviour) -> None:
        if not _active:
            tick_once(self)
            return
        reached: dict[int, Behaviour] = {}
        for node in self.tick():
            reached[id(node)] = node
        _commit(self, reached)

    setattr(py_trees.trees.BehaviourTree, "tick", tick)  # noqa: B010
    setattr(py_trees.behaviour.Behaviour, "tick_once", once)  # noqa: B010
