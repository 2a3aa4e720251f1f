"""The compact tree drawing: folding, grouping to fit the screen, symbols, no stale messages."""

from __future__ import annotations

import io

import py_trees
from py_trees.common import Status

from marknav.runs.records.tree_state import (
    FAILURE,
    INVALID,
    KIND_SYMBOLS,
    RUNNING,
    STATUS_SYMBOLS,
    SUCCESS,
    TreeState,
)
from marknav.runs.views.display import PlainView, make_view, status_text


def _route(n: int, done: int) -> TreeState:
    """Mission → Route → n waypoints (selector: Passed?, Pass), the first ``done`` passed and
    waypoint ``done`` running."""
    names, kinds, parents = ["Mission", "Perception", "Route"], ["sequence", "leaf", "sequence"], \
        [-1, 0, 0]
    for w in range(n):
        names += [f"Waypoint {w + 1}", "Passed?", "Pass"]
        kinds += ["selector", "leaf", "leaf"]
        base = len(parents)
        parents += [2, base, base]
    state = TreeState(names=names, kinds=kinds, parents=parents)
    state.status[0] = state.status[2] = RUNNING
    state.status[1], state.message[1] = SUCCESS, "frame 9: red 1.2 m"
    for w in range(n):
        i = 3 + 3 * w
        if w < done:
            state.status[i:i + 3] = [SUCCESS, FAILURE, SUCCESS]
            state.message[i + 2] = f"passed #{w + 1}"
        elif w == done:
            state.status[i:i + 3] = [RUNNING, FAILURE, RUNNING]
            state.message[i + 2] = "approaching"
    return state


def test_finished_waypoints_fold_to_one_line_with_their_result() -> None:
    rows = _route(4, 2).lines(style="unicode")
    texts = [t for t, _ in rows]
    assert texts[3] == "    ✔ ? Waypoint 1 ▸ — passed #1"
    assert "    ▶ ? Waypoint 3" in texts and "      ▶ Pass — approaching" in texts
    assert texts[-1] == "    · ? Waypoint 4 ▸"  # pending: folded, no message
    assert len(rows) == 9


def test_a_long_route_is_grouped_to_fit_25_rows() -> None:
    state = _route(50, 30)
    rows = state.lines(style="unicode", max_rows=25)
    assert len(rows) <= 25
    texts = [t for t, _ in rows]
    assert "    ✔ 30 × ▸ Waypoint 1 … Waypoint 30" in texts
    assert "    · 19 × ▸ Waypoint 32 … Waypoint 50" in texts
    assert "    ▶ ? Waypoint 31" in texts  # the active branch stays open


def test_status_symbols_differ_from_composite_symbols() -> None:
    for style in ("unicode", "ascii"):
        status = {s.strip() for s in STATUS_SYMBOLS[style].values()}
        kinds = {k.strip() for k in KIND_SYMBOLS[style].values() if k}
        assert not status & kinds and len(status) == 4


def test_idle_nodes_keep_no_stale_message() -> None:
    root = py_trees.composites.Selector("Root", memory=False)
    a = py_trees.behaviours.Success("A")
    b = py_trees.behaviours.Running("B")
    root.add_children([a, b])
    state = TreeState.of_tree(root)
    b.feedback_message = "looking for green #2"
    root.tick_once()  # A succeeds: B is not ticked
    b.status = Status.INVALID
    changes = state.capture()
    assert changes["0"] == [SUCCESS, ""] and "2" not in changes
    assert state.message[2] == "" and state.status[2] == INVALID
    assert "looking" not in state.text()


def test_piped_output_is_change_only_text() -> None:
    out = io.StringIO()
    view = make_view(out, "ascii")
    assert isinstance(view, PlainView)
    state = _route(2, 0)
    panel = {"t": 0.05, "tick": 1, "target": "red #1, pass on its left", "range_mm": 1500.0,
             "bearing_deg": 8.0, "wheels_mm_s": [200, 250], "safety": "driving",
             "marks": ["red 1.50 m"], "camera_hz": None, "overruns": 0}
    assert view.update(state, panel)
    assert not view.update(state, {**panel, "t": 0.1})  # only a figure moved: no reprint
    state.status[5] = SUCCESS
    assert view.update(state, panel)
    text = out.getvalue()
    assert text.count("RUN  -> Mission") == 2
    assert "range 1.50 m  bearing 8 deg left" in text
    assert status_text(panel)[3] == ("marks in view: red 1.50 m  camera: waiting for frames  "
                                     "overruns 0")
