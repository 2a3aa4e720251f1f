"""The safety chart (marknav.robot.safety_chart, shown in docs/explanation/safety.md) draws
exactly the transitions the safety layer's Machine holds: no more, no fewer."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from marknav.core.clock import ManualClock
from marknav.robot.safety import SafetyLayer, SafetyState
from marknav.robot.safety_chart import STAYS, machine_edges, render_chart, safety_chart

ROOT = Path(__file__).resolve().parents[2]
SAFETY_PAGE = ROOT / "docs" / "explanation" / "safety.md"

EdgeKey = tuple[str, str, str | None, tuple[str, ...]]
_LINE = re.compile(r"^(?P<sources>[a-z, ]+) --(?P<event>[a-z_]+)(?: \[(?P<guards>[^\]]*)\])?"
                   r"--> (?P<dest>[a-z]+|\(stays\))$")


class _Sink:
    def drive_direct(self, *, left: int, right: int) -> None:
        pass


def _layer() -> SafetyLayer:
    return SafetyLayer(_Sink(), clock=ManualClock())


def parse_chart(text: str) -> set[EdgeKey]:
    """The edges a chart draws, read back from its text: (source, event, dest|None, guards)."""
    edges: set[EdgeKey] = set()
    for line in text.strip().splitlines():
        m = _LINE.match(line)
        assert m, f"not a chart line: {line!r}"
        guards = tuple(g.strip() for g in m["guards"].split(",")) if m["guards"] else ()
        dest = None if m["dest"] == STAYS else m["dest"]
        for source in m["sources"].split(", "):
            edges.add((source, m["event"], dest, guards))
    return edges


def table_edges(machine: Any) -> set[EdgeKey]:
    """The Machine's transitions, read straight from transitions' own objects."""
    out: set[EdgeKey] = set()
    for name, event in machine.events.items():
        for transitions in event.transitions.values():
            for t in transitions:
                guards = tuple(c.func.__name__.lstrip("_") if c.target
                               else "not " + c.func.__name__.lstrip("_") for c in t.conditions)
                out.add((SafetyState[t.source].value, name,
                         None if t.dest is None else SafetyState[t.dest].value, guards))
    return out


def _charts_hook() -> ModuleType:
    spec = importlib.util.spec_from_file_location("charts_hook", ROOT / "docs/hooks/charts.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_chart_draws_exactly_the_machines_transitions() -> None:
    expected = table_edges(_layer()._machine)
    assert len(expected) == 31  # the table's edges counted per source state
    assert parse_chart(safety_chart()) == expected


def test_the_chart_names_states_and_guards_as_the_table_does() -> None:
    edges = parse_chart(safety_chart())
    assert ("disconnected", "connect", "ready", ()) in edges
    assert ("bumped", "backoff", None, ("is_backward",)) in edges
    assert ("fault", "reset", "bumped", ("clear_to_reset", "bump_pressed")) in edges
    assert {e[0] for e in edges if e[1] == "estop"} == {
        s.value for s in SafetyState if s is not SafetyState.ESTOPPED}


def test_an_edge_added_to_the_table_shows_in_its_chart_and_not_in_the_published_one() -> None:
    layer = _layer()
    layer._machine.add_transition("bump", "FAULT", "BUMPED")
    changed = table_edges(layer._machine)
    assert ("fault", "bump", "bumped", ()) in changed
    assert parse_chart(render_chart(machine_edges(layer._machine))) == changed
    assert parse_chart(safety_chart()) != changed  # the chart of the real table is not this one


def test_an_edge_left_out_of_the_rendering_is_caught() -> None:
    machine = _layer()._machine
    edges = machine_edges(machine)
    assert parse_chart(render_chart(edges[1:])) != table_edges(machine)


def test_the_safety_page_shows_the_chart_built_from_the_table() -> None:
    page = SAFETY_PAGE.read_text(encoding="utf-8")
    assert page.count("<!-- chart: safety -->") == 1
    built = _charts_hook().fill_charts(page)
    block = re.search(r"```text\n(?P<chart>(?:.*--.*-->.*\n)+)```", built)
    assert block, "the built page has no chart block"
    assert parse_chart(block["chart"]) == table_edges(_layer()._machine)
    assert "<!-- chart:" not in built


def test_a_marker_naming_no_chart_fails_the_build() -> None:
    with pytest.raises(ValueError, match="no chart 'nope'"):
        _charts_hook().fill_charts("text\n<!-- chart: nope -->\n")
