"""The default mission tree, built from a mission's ``route`` (``docs/architecture.md``).

::

    Mission                      Sequence(memory=False)  reactive: every tick starts here
    ├── Perception               frame → marks → blackboard; FAILURE: camera lost (abort)
    ├── SafetyGuard              FAILURE on fault / e-stop (abort), else SUCCESS
    ├── BumpRecovery             Selector(memory=False)
    │   ├── NotBumped?           SUCCESS unless bumped or a recovery is under way
    │   └── BackOff              reverse 150 mm; FAILURE after max_bump_recoveries (abort)
    └── Route                    Sequence(memory=True)
        ├── Waypoint 1: red      Selector(memory=False)
        │   ├── Passed?          route progress from the blackboard (survives interruptions)
        │   └── Pass             Sequence(memory=True)
        │       ├── SelectTarget route colour; nearest visible mark of it
        │       ├── Reach        Selector(memory=False)
        │       │   ├── Bypassing?   this waypoint's bypass already started: resume it
        │       │   └── CloseIn      Sequence(memory=False)   reactive lost check
        │       │       ├── Seen?|Search  Selector(memory=False)
        │       │       │   ├── Seen?     target seen within lost_after_s
        │       │       │   └── Search    Selector(memory=True): the steps of a search
        │       │       │       ├── Spin     a full turn on the spot toward where it should be
        │       │       │       ├── Return   face where it was last seen, drive there, turn
        │       │       │       └── Advance  drive on along the course, turn
        │       │       └── Approach      centre the mark and drive; SUCCESS at the threshold
        │       ├── Bypass       Bézier bypass on the colour's side; records the waypoint passed
        │       └── Verify       a doubtful pass: look back at the mark, decide its side
        └── Waypoint 2 ...

Preemption: Perception, SafetyGuard and BumpRecovery are re-evaluated every tick ahead of the
Route (the root has no memory), so a fault, an e-stop, a lost camera or a bump halts whatever the
Route was running on the tick it is seen; the halted behaviour's ``terminate`` stops the wheels
unless the recovery already took them over (see :mod:`marknav.behaviours.base`). The Route and
each Pass keep their place (memory) between ticks; after an interruption the Route restarts, the
``Passed?`` checks skip the waypoints already done and ``Bypassing?`` resumes a bypass under way.

:func:`failure_reason` says why a finished tree failed, from the chain of failed nodes.
"""

from __future__ import annotations

import uuid
from dataclasses import dataclass
from typing import TYPE_CHECKING

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import Status
from py_trees.composites import Selector, Sequence

from marknav.behaviours.approach import ApproachWhileCentring
from marknav.behaviours.bypass import BezierBypass
from marknav.behaviours.keys import Side
from marknav.behaviours.perception import Perception
from marknav.behaviours.safety import BackOff, NotBumped, SafetyGuard
from marknav.behaviours.search import SearchLog, SearchWhenLost
from marknav.behaviours.search_steps import AdvanceAlongCourse, ReturnToSighting
from marknav.behaviours.target import (
    SelectTarget,
    TargetLocked,
    TargetSeen,
    WaypointPassed,
    waypoint_id_for,
)
from marknav.behaviours.verify import VerifyPass

if TYPE_CHECKING:
    from marknav.missions.schema import Mission

__all__ = ["Failure", "build_route_tree", "bump_recovery", "failure_reason", "route",
           "search_strategy", "waypoint"]


def waypoint(
    colour: str,
    *,
    side: Side | None = None,
    index: int | None = None,
    name: str | None = None,
) -> Behaviour:
    """One waypoint's subtree: ``Passed?`` or (select, reach, bypass) the mark of ``colour``.

    ``side`` defaults to the mission's side for the colour (resolved at setup); ``index`` is the
    waypoint's place in the route (0-based) — without one the waypoint gets a unique identity.
    """
    if index is None:
        wid = f"waypoint-{uuid.uuid4().hex[:8]}-{colour}"
        number = -1
    else:
        if index < 0:
            raise ValueError(f"waypoint index must be >= 0, got {index}")
        wid = waypoint_id_for(index, colour)
        number = index
    if name is None:
        where = f" (pass on its {side})" if side is not None else ""
        name = (f"Waypoint {index + 1}: {colour}{where}" if index is not None
                else f"Waypoint: {colour}{where}")
    seen_or_search = Selector(
        "Seen?|Search", memory=False, children=[TargetSeen(), search_strategy()])
    close_in = Sequence(
        "CloseIn", memory=False, children=[seen_or_search, ApproachWhileCentring()])
    reach = Selector(
        "Reach", memory=False, children=[TargetLocked(waypoint_id=wid), close_in])
    pass_ = Sequence("Pass", memory=True, children=[
        SelectTarget(colour=colour, side=side, waypoint=number, waypoint_id=wid),
        reach,
        BezierBypass(),
        VerifyPass(),
    ])
    return Selector(name, memory=False, children=[
        WaypointPassed(waypoint_id=wid, wait_for_check=True), pass_])


def search_strategy(name: str = "Search") -> Behaviour:
    """``Search``: Selector(memory=True) of the search's steps, each a leaf
    (:mod:`marknav.behaviours.search_steps`): ``Spin`` (a full turn on the spot), ``Return``
    (to where the target was last seen or is predicted), ``Advance`` (on along the course),
    sharing one :class:`~marknav.behaviours.search.SearchLog` so the step that gives up says
    what the whole search did."""
    log = SearchLog()
    return Selector(name, memory=True, children=[
        SearchWhenLost("Spin", log=log),
        ReturnToSighting(log=log),
        AdvanceAlongCourse(log=log),
    ])


def route(mission: Mission, *, name: str = "Route") -> Behaviour:
    """``Route``: Sequence(memory=True) of one :func:`waypoint` per entry of ``mission.route``."""
    return Sequence(name, memory=True, children=[
        waypoint(colour, side=mission.side_of(colour), index=i)
        for i, colour in enumerate(mission.route)
    ])


def bump_recovery(name: str = "BumpRecovery", *, backoff: BackOff | None = None) -> Behaviour:
    """``BumpRecovery``: Selector(memory=False) of ``NotBumped?`` and ``BackOff``."""
    return Selector(name, memory=False, children=[
        NotBumped(), backoff if backoff is not None else BackOff()])


def build_route_tree(
    mission: Mission,
    *,
    perception: Behaviour | None = None,
    name: str = "Mission",
) -> Behaviour:
    """The default mission tree for ``mission`` (see the module docstring).

    ``perception`` replaces the camera :class:`~marknav.behaviours.perception.Perception` (tests
    pass :class:`marknav.testing.FakePerception`). Set the tree up with
    ``BehaviourTree.setup(robot=..., clock=..., mission=..., camera=...)``.
    """
    return Sequence(name, memory=False, children=[
        perception if perception is not None else Perception(),
        SafetyGuard(),
        bump_recovery(),
        route(mission),
    ])


@dataclass(frozen=True)
class Failure:
    """Why a tree failed: the failed leaf, the path to it, its message, whether it aborts."""

    node: Behaviour
    path: str
    message: str
    aborted: bool

    @property
    def reason(self) -> str:
        """``Search: red #2 not found in 15 s (turned 300°)`` — one line for reports."""
        return f"{self.node.name}: {self.message}" if self.message else f"{self.node.name} failed"


def failure_reason(root: Behaviour) -> Failure | None:
    """Follow the failed children from ``root`` down to the leaf that caused the failure.

    py_trees composites keep ``current_child`` after a FAILURE (a Selector's is its last child),
    decorators have one child. Returns ``None`` when ``root`` did not fail.
    """
    if root.status != Status.FAILURE:
        return None
    node = root
    names = [root.name]
    while True:
        if isinstance(node, py_trees.decorators.Decorator):
            child: Behaviour | None = node.decorated
        elif isinstance(node, py_trees.composites.Composite):
            child = node.current_child
        else:
            child = None
        if child is None or child.status != Status.FAILURE:
            break
        node = child
        names.append(node.name)
    message = node.feedback_message or ""
    aborted = bool(getattr(node, "ABORTS", False)) or "abort" in message.lower()
    return Failure(node=node, path="/".join(names), message=message, aborted=aborted)
