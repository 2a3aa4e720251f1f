"""Tick a tree in a test and keep a record: statuses tick by tick and the active node path."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import Status

from marknav.core.clock import ManualClock

__all__ = ["TickLog", "TickRecord", "active_path", "tick_until"]


def active_path(root: Behaviour) -> str:
    """``Mission/Route/Waypoint 1: red/Pass/Reach/...``: from the root down to the deepest node
    that is RUNNING (or, when nothing runs, the root alone)."""
    names = [root.name]
    node = root
    while True:
        running = [c for c in node.children if c.status == Status.RUNNING]
        if isinstance(node, py_trees.decorators.Decorator):
            running = [node.decorated] if node.decorated.status == Status.RUNNING else []
        if not running:
            return "/".join(names)
        node = running[0]
        names.append(node.name)


@dataclass(frozen=True)
class TickRecord:
    """One tick: its number (from 0), clock time, root status, active path, tip feedback."""

    index: int
    t: float
    status: Status
    active: str
    feedback: str


@dataclass
class TickLog:
    """What :func:`tick_until` saw. ``reached`` tells whether the wanted status came."""

    wanted: Status
    records: list[TickRecord] = field(default_factory=list)
    reached: bool = False

    @property
    def statuses(self) -> list[Status]:
        return [r.status for r in self.records]

    @property
    def active(self) -> list[str]:
        return [r.active for r in self.records]

    @property
    def final(self) -> Status:
        """The root status after the last tick (INVALID if never ticked)."""
        return self.records[-1].status if self.records else Status.INVALID

    @property
    def ticks(self) -> int:
        return len(self.records)

    def __iter__(self) -> Iterator[TickRecord]:
        return iter(self.records)

    def first(self, path_part: str) -> TickRecord | None:
        """The first tick whose active path contains ``path_part``."""
        return next((r for r in self.records if path_part in r.active), None)

    def visited(self, path_part: str) -> bool:
        """Whether any tick's active path contained ``path_part``."""
        return self.first(path_part) is not None

    def __str__(self) -> str:
        lines = [f"tick_until({self.wanted.value}): {'reached' if self.reached else 'not reached'}"
                 f" after {self.ticks} ticks"]
        last: tuple[str, Status] | None = None
        for i, r in enumerate(self.records):
            key = (r.active, r.status)
            if key != last or i == len(self.records) - 1:  # one line per change, and the end
                lines.append(f"  #{r.index:4d} t={r.t:7.3f}  {r.active} [{r.status.value}] "
                             f"{r.feedback}")
                last = key
        return "\n".join(lines)


def tick_until(
    tree: py_trees.trees.BehaviourTree | Behaviour,
    status: Status = Status.SUCCESS,
    *,
    max_ticks: int,
    clock: ManualClock | None = None,
    dt: float = 0.05,
) -> TickLog:
    """Tick ``tree`` until its root has ``status``, it finishes otherwise, or ``max_ticks``.

    With ``clock``, the clock advances by ``dt`` before every tick but the first, so tick k
    happens at t0 + k·dt (without one, records carry t = k). Stops early when the root ends with
    another status than ``status`` (ticking again would restart it). Returns the
    :class:`TickLog`; assert on ``log.reached`` (``print(log)`` shows the run, one line per
    change).
    """
    if max_ticks < 1:
        raise ValueError(f"max_ticks must be at least 1, got {max_ticks}")
    root = tree.root if isinstance(tree, py_trees.trees.BehaviourTree) else tree
    log = TickLog(wanted=status)
    for i in range(max_ticks):
        if clock is not None and i > 0:
            clock.advance(dt)
        if isinstance(tree, py_trees.trees.BehaviourTree):
            tree.tick()
        else:
            tree.tick_once()
        tip = root.tip()
        log.records.append(TickRecord(
            index=i,
            t=clock.now() if clock is not None else float(i),
            status=root.status,
            active=active_path(root),
            feedback=tip.feedback_message if tip is not None else "",
        ))
        if root.status == status:
            log.reached = True
            break
        if root.status != Status.RUNNING:
            break
    return log
