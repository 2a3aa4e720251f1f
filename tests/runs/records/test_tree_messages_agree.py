"""The live view's words agree tick by tick: replaying a real run's log, what the panel says
of the target, what Perception says of it and what the tree's nodes say never contradict each
other, and a node the tick did not reach says when its words are from."""

from __future__ import annotations

import re
from typing import Any

import py_trees
import pytest

from marknav.cli.main import main
from marknav.runs.records.runlog import Replay, read_log
from marknav.runs.records.tree_state import INVALID, RUNNING, SUCCESS, TreeState

DATED = re.compile(r"^at t=(\d+\.\d\d) s: ")
#: The panel keeps the range in whole mm, the message in cm: they may differ by a rounding.
RANGE_ROUNDING_M = 0.011
TARGET_WORDS = re.compile(r"; target (\S+ #\d+): (.*)$")


@pytest.fixture(scope="module")
def replay(tmp_path_factory: pytest.TempPathFactory) -> Replay:
    folder = tmp_path_factory.mktemp("run")
    code = main(["run", "slalom", "--tree", "none", "--report", str(folder / "report.json")])
    assert code == 0
    return Replay(read_log(folder / "report.events.jsonl"))


def _named(state: TreeState, name: str) -> list[int]:
    return [i for i, n in enumerate(state.names) if n == name]


def test_perception_says_of_the_target_what_the_panel_shows(replay: Replay) -> None:
    checked = explained = 0
    for rec, state in replay.states():
        panel = rec["panel"]
        (perception,) = _named(state, "Perception")
        found = TARGET_WORDS.search(state.message[perception])
        if found is None or not str(panel.get("target", "")).startswith(found[1] + ","):
            continue  # no target yet, or a new waypoint chose another in this tick
        words = found[2]
        checked += 1
        if "range_mm" in panel and panel["seen_s_ago"] == 0:
            said = float(words.split(" m,")[0])  # "1.03 m, 0° right"
            assert abs(said - panel["range_mm"] / 1000) <= RANGE_ROUNDING_M, (rec["t"], words)
        else:
            assert not words[0].isdigit(), (rec["t"], words, panel)
            colour = found[1].split()[0]
            if any(m.startswith(colour + " ") for m in panel["marks"]):
                # a mark of its colour in view that is not taken says why
                assert words != "not in view", (rec["t"], state.message[perception])
                explained += 1
    assert checked > 500
    assert explained > 0  # the run has such ticks (a search turning to a remembered mark)


def test_no_current_word_contradicts_a_target_seen_this_tick(replay: Replay) -> None:
    contradictions = ("out of view", "not seen", "not in view")
    fresh_ticks = 0
    for rec, state in replay.states():
        panel = rec["panel"]
        if "range_mm" not in panel or panel["seen_s_ago"] > 0:
            continue
        fresh_ticks += 1
        for i, msg in enumerate(state.message):
            if state.status[i] == INVALID or DATED.match(msg):
                continue
            assert not any(w in msg for w in contradictions), (rec["t"], state.names[i], msg)
    assert fresh_ticks > 300


def test_a_node_under_a_memory_sequence_that_moved_on_is_dated(replay: Replay) -> None:
    start = TreeState.from_structure(replay.info["tree"])
    passes = [i for i in _named(start, "Pass") if start.memory[i]]
    assert passes
    dated = 0
    began: dict[int, float] = {}
    for rec, state in replay.states():
        t = float(rec["t"])
        for p in passes:
            if state.status[p] != RUNNING:
                began.pop(p, None)
                continue
            began.setdefault(p, t)
            select = state.children[p][0]
            msg = state.message[select]
            when = DATED.match(msg)
            if t == began[p]:
                assert when is None, (t, msg)  # ticked this tick: current
            elif state.status[select] == SUCCESS:
                assert when is not None, (t, msg)  # not reached since the sequence moved on
                assert began[p] <= float(when[1]) < t
                dated += 1
    assert dated > 100


def test_capture_dates_exactly_the_nodes_a_tick_did_not_reach() -> None:
    class Say(py_trees.behaviour.Behaviour):
        def __init__(self, name: str, results: list[py_trees.common.Status]) -> None:
            super().__init__(name)
            self.results = results

        def update(self) -> py_trees.common.Status:
            self.feedback_message = f"{self.name} ticked"
            return self.results.pop(0) if len(self.results) > 1 else self.results[0]

    S, R = py_trees.common.Status.SUCCESS, py_trees.common.Status.RUNNING
    first, second = Say("first", [S]), Say("second", [R])
    root = py_trees.composites.Sequence("seq", memory=True, children=[first, second])
    tree = py_trees.trees.BehaviourTree(root)
    state = TreeState.of_tree(root)
    tree.add_visitor(state.ticked)
    messages: list[dict[str, Any]] = []
    for t in (0.0, 0.05, 0.1):
        tree.tick()
        state.capture(t)
        messages.append(dict(zip(state.names, state.message, strict=True)))
    assert messages[0] == {"seq": "", "first": "first ticked", "second": "second ticked"}
    # the sequence resumes at its running child: 'first' is not ticked again
    assert messages[1]["first"] == "at t=0.00 s: first ticked"
    assert messages[2]["first"] == "at t=0.00 s: first ticked"
    assert messages[2]["second"] == "second ticked"
    # without the visitor on a tree (a caller's own loop), nothing is dated
    plain = TreeState.of_tree(root)
    tree.tick()
    plain.capture(0.15)
    assert not any(DATED.match(m) for m in plain.message)
