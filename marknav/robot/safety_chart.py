"""The safety layer's state chart, drawn from the transition table of its ``transitions.Machine``.

The chart is plain text, one line per group of edges::

    ready, driving --bump--> bumped
    fault, estopped --reset [clear_to_reset, bump_pressed]--> bumped
    bumped --stop--> (stays)

``SOURCES --EVENT [GUARDS]--> DEST``: the states an event leaves (in :class:`SafetyState`
order), the guards that must all hold (a condition method's name without its underscore,
``not NAME`` for an ``unless``), and the state entered. ``(stays)`` marks an internal transition:
the state is neither left nor entered again, so no zero is written on the way (the edge's own
callback may still write one). Edges that share an event, a destination and guards share a line.
Of an event's edges from one state, the first in the chart whose guards hold is taken.

Text rather than a Mermaid diagram: the documentation theme would load Mermaid from a CDN. The
documentation build puts :func:`safety_chart` into ``docs/explanation/safety.md``
(``docs/hooks/charts.py``), so the page cannot disagree with the table.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any, NamedTuple

from marknav.core.clock import ManualClock
from marknav.robot.safety import SafetyLayer, SafetyState

__all__ = ["STAYS", "Edge", "machine_edges", "render_chart", "safety_chart"]

#: The destination written for an internal transition.
STAYS = "(stays)"


class Edge(NamedTuple):
    """One transition: from ``source`` on ``event`` to ``dest`` (None: internal) if ``guards``."""

    source: str
    event: str
    dest: str | None
    guards: tuple[str, ...] = ()


def _state_name(name: str) -> str:
    return SafetyState[name].value  # the Machine names Enum states by member name


def _guard(condition: Any) -> str:
    name = getattr(condition.func, "__name__", str(condition.func)).lstrip("_")
    return name if condition.target else f"not {name}"


def machine_edges(machine: Any) -> list[Edge]:
    """Every transition of a ``transitions.Machine`` over :class:`SafetyState`, in table order."""
    out = []
    for event_name, event in machine.events.items():
        for transitions in event.transitions.values():
            for t in transitions:
                out.append(Edge(_state_name(t.source), event_name,
                                None if t.dest is None else _state_name(t.dest),
                                tuple(_guard(c) for c in t.conditions)))
    return out


def render_chart(edges: Iterable[Edge]) -> str:
    """``edges`` as the text chart of the module docstring, one line per (event, dest, guards)."""
    order = {s.value: i for i, s in enumerate(SafetyState)}
    groups: dict[tuple[str, str | None, tuple[str, ...]], list[str]] = {}
    for e in edges:
        sources = groups.setdefault((e.event, e.dest, e.guards), [])
        if e.source not in sources:
            sources.append(e.source)
    lines = []
    for (event, dest, guards), sources in groups.items():
        label = event + (f" [{', '.join(guards)}]" if guards else "")
        names = ", ".join(sorted(sources, key=order.__getitem__))
        lines.append(f"{names} --{label}--> {STAYS if dest is None else dest}")
    return "\n".join(lines) + "\n"


class _NoWheels:
    def drive_direct(self, *, left: int, right: int) -> None:
        pass  # the chart only reads the table: nothing is ever driven


def safety_chart() -> str:
    """The chart of :class:`~marknav.robot.safety.SafetyLayer`'s own transition table."""
    layer = SafetyLayer(_NoWheels(), clock=ManualClock())
    return render_chart(machine_edges(layer._machine))
