"""py_trees' Sequence and Selector without the per-tick costs nobody asked for.

py_trees 2.6's composites build a debug string on every tick and every stop
(``f"{self.__class__.__name__}.tick()"``, ``f"...stop()[{self.status}->{new_status}]"``: two
enum formats each) and hand it to a logger that drops it unless ``py_trees.logging.level`` is
DEBUG; and a tick is a chain of generators, every node ticked handed up through each of its
ancestors' generators for the visitors — also when there are none. :class:`Sequence` and
:class:`Selector` here are the py_trees classes (``isinstance`` checks, displays and visitors see
no difference):

- ``tick`` is py_trees 2.6's, statement for statement, without building those strings (with
  ``py_trees.logging.level`` at DEBUG, py_trees' own code runs, messages included);
- ``tick_now`` does the same without yielding anything: children that can (these composites,
  :class:`~marknav.behaviours.base.MarknavBehaviour` leaves that keep its ``tick``) are ticked
  by their ``tick_now``, any other child by its own generator, acted on when it yields itself
  exactly as ``tick`` does. :class:`marknav.runs.runner.MissionTree` ticks this way when no
  visitor watches the nodes ticked (benchmarks, evaluations, ``--tree none``).

``tests/behaviours/test_composites.py`` ticks random trees of py_trees' classes, of these with
``tick`` and of these with ``tick_now`` side by side and compares every node's status, current
child and the order of every ``initialise``/``update``/``terminate`` call.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from typing import Any, ClassVar

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import Status

__all__ = ["Selector", "Sequence", "tick_now"]

_INFO = py_trees.logging.Level.INFO


def _debugging() -> bool:
    """Whether py_trees would print its debug messages (its Logger.debug's test): then its
    own code runs."""
    return py_trees.logging.level < _INFO


def tick_now(node: Behaviour) -> None:
    """Tick ``node`` once as ``for _ in node.tick(): pass`` would, without the generators when
    it (a :class:`Sequence`, a :class:`Selector`, a
    :class:`~marknav.behaviours.base.MarknavBehaviour` that keeps its ``tick``) can."""
    if getattr(node, "TICK_NOW", False):
        node.tick_now()  # type: ignore[attr-defined]
    else:
        for _ in node.tick():
            pass


def _composite_stop(node: py_trees.composites.Composite, new_status: Status) -> None:
    """``py_trees.composites.Composite.stop`` (its body; it logs nothing itself)."""
    if new_status == Status.INVALID:
        node.current_child = None
        for child in node.children:
            if child.status != Status.INVALID:
                child.stop(new_status)
    node.terminate(new_status)
    node.status = new_status
    node.iterator = node.tick()


class Sequence(py_trees.composites.Sequence):
    """:class:`py_trees.composites.Sequence` without its debug strings (see the module)."""

    #: ``False`` for a subclass that overrides ``tick`` (see :func:`tick_now`).
    TICK_NOW: ClassVar[bool] = True

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "tick" in cls.__dict__:
            cls.TICK_NOW = False

    def tick(self) -> Iterator[Behaviour]:
        if _debugging():
            return super().tick()
        return self._tick()

    def _tick(self) -> Iterator[Behaviour]:
        # py_trees 2.6 Sequence.tick, less the logger calls.
        index = 0
        children = self.children
        if self.status != Status.RUNNING:
            self.current_child = children[0] if children else None
            for child in children:
                if child.status != Status.INVALID:
                    child.stop(Status.INVALID)
            self.initialise()
        elif self.memory and self.current_child is not None:
            index = children.index(self.current_child)
        else:
            self.current_child = children[0] if children else None

        if not children:
            self.current_child = None
            self.stop(Status.SUCCESS)
            yield self
            return

        for child in itertools.islice(children, index, None):
            for node in child.tick():
                yield node
                if node is child and node.status != Status.SUCCESS:
                    if not self.memory:
                        for later in itertools.islice(children, index + 1, None):
                            if later.status != Status.INVALID:
                                later.stop(Status.INVALID)
                    if node.status != Status.RUNNING:
                        self.stop(node.status)
                    else:
                        self.status = node.status
                    yield self
                    return
            try:
                self.current_child = children[index + 1]
                index += 1
            except IndexError:
                pass

        self.stop(Status.SUCCESS)
        yield self

    def tick_now(self) -> None:
        """:meth:`tick` without yielding the nodes ticked (see :func:`tick_now`)."""
        if _debugging():
            for _ in self.tick():
                pass
            return
        index = 0
        children = self.children
        if self.status != Status.RUNNING:
            self.current_child = children[0] if children else None
            for child in children:
                if child.status != Status.INVALID:
                    child.stop(Status.INVALID)
            self.initialise()
        elif self.memory and self.current_child is not None:
            index = children.index(self.current_child)
        else:
            self.current_child = children[0] if children else None

        if not children:
            self.current_child = None
            self.stop(Status.SUCCESS)
            return

        for child in itertools.islice(children, index, None):
            if getattr(child, "TICK_NOW", False):
                child.tick_now()  # type: ignore[attr-defined]
                halted = child.status != Status.SUCCESS
            else:
                halted = False
                for node in child.tick():
                    if node is child and node.status != Status.SUCCESS:
                        halted = True
                        break
            if halted:
                if not self.memory:
                    for later in itertools.islice(children, index + 1, None):
                        if later.status != Status.INVALID:
                            later.stop(Status.INVALID)
                if child.status != Status.RUNNING:
                    self.stop(child.status)
                else:
                    self.status = child.status
                return
            try:
                self.current_child = children[index + 1]
                index += 1
            except IndexError:
                pass

        self.stop(Status.SUCCESS)

    def stop(self, new_status: Status = Status.INVALID) -> None:
        if _debugging():
            super().stop(new_status)
        else:
            _composite_stop(self, new_status)


class Selector(py_trees.composites.Selector):
    """:class:`py_trees.composites.Selector` without its debug strings (see the module)."""

    #: ``False`` for a subclass that overrides ``tick`` (see :func:`tick_now`).
    TICK_NOW: ClassVar[bool] = True

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "tick" in cls.__dict__:
            cls.TICK_NOW = False

    def tick(self) -> Iterator[Behaviour]:
        if _debugging():
            return super().tick()
        return self._tick()

    def _tick(self) -> Iterator[Behaviour]:
        # py_trees 2.6 Selector.tick, less the logger calls.
        children = self.children
        if self.status != Status.RUNNING:
            self.current_child = children[0] if children else None
            self.initialise()

        if not children:
            self.current_child = None
            self.stop(Status.FAILURE)
            yield self
            return

        if self.memory:
            assert self.current_child is not None
            index = children.index(self.current_child)
            for child in itertools.islice(children, None, index):
                if child.status != Status.INVALID:
                    child.stop(Status.INVALID)
        else:
            index = 0

        previous = self.current_child
        for child in itertools.islice(children, index, None):
            for node in child.tick():
                yield node
                if node is child and (node.status == Status.RUNNING
                                      or node.status == Status.SUCCESS):
                    self.current_child = child
                    if previous is None or previous != self.current_child:
                        # a new choice: invalidate everything at a lower priority
                        passed = False
                        for other in children:
                            if passed and other.status != Status.INVALID:
                                other.stop(Status.INVALID)
                            passed = True if other == self.current_child else passed
                    if node.status == Status.SUCCESS:
                        self.stop(node.status)
                    else:
                        self.status = node.status
                    yield self
                    return

        self.stop(Status.FAILURE)
        try:
            self.current_child = children[-1]
        except IndexError:
            self.current_child = None
        yield self

    def tick_now(self) -> None:
        """:meth:`tick` without yielding the nodes ticked (see :func:`tick_now`)."""
        if _debugging():
            for _ in self.tick():
                pass
            return
        children = self.children
        if self.status != Status.RUNNING:
            self.current_child = children[0] if children else None
            self.initialise()

        if not children:
            self.current_child = None
            self.stop(Status.FAILURE)
            return

        if self.memory:
            assert self.current_child is not None
            index = children.index(self.current_child)
            for child in itertools.islice(children, None, index):
                if child.status != Status.INVALID:
                    child.stop(Status.INVALID)
        else:
            index = 0

        previous = self.current_child
        for child in itertools.islice(children, index, None):
            if getattr(child, "TICK_NOW", False):
                child.tick_now()  # type: ignore[attr-defined]
                chosen = child.status == Status.RUNNING or child.status == Status.SUCCESS
            else:
                chosen = False
                for node in child.tick():
                    if node is child and (node.status == Status.RUNNING
                                          or node.status == Status.SUCCESS):
                        chosen = True
                        break
            if chosen:
                self.current_child = child
                if previous is None or previous != self.current_child:
                    passed = False
                    for other in children:
                        if passed and other.status != Status.INVALID:
                            other.stop(Status.INVALID)
                        passed = True if other == self.current_child else passed
                if child.status == Status.SUCCESS:
                    self.stop(child.status)
                else:
                    self.status = child.status
                return

        self.stop(Status.FAILURE)
        try:
            self.current_child = children[-1]
        except IndexError:
            self.current_child = None

    def stop(self, new_status: Status = Status.INVALID) -> None:
        if _debugging():
            super().stop(new_status)
        else:
            _composite_stop(self, new_status)
