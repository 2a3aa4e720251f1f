"""The live view on small and large terminals: the whole screen fits (so rich never redraws its
top twice), the legend keeps every symbol, the running node is always on screen with finished
waypoints folded first; and a simulated run under the live view goes at wall-clock speed unless
told otherwise."""

from __future__ import annotations

import io

import pytest
from rich.console import Console

from marknav.behaviours.tree import build_mission_tree
from marknav.missions.examples import EXAMPLES_DIR
from marknav.missions.schema import load_mission
from marknav.runs.loop.run import RunRequest, paced
from marknav.runs.records.tree_state import FAILURE, INVALID, RUNNING, SUCCESS, TreeState
from marknav.runs.views.display import LiveView, PlainView, render, tree_rows

#: The running branch of a waypoint closing in on its mark, by node name.
CLOSING_IN = {"Passed?": FAILURE, "Pass": RUNNING, "SelectTarget": SUCCESS, "Reach": RUNNING,
              "Bypassing?": FAILURE, "CloseIn": RUNNING, "Seen?|Search": SUCCESS,
              "Seen?": SUCCESS, "Search": INVALID, "Approach": RUNNING, "Bypass": INVALID}


def _subtree(state: TreeState, i: int) -> list[int]:
    out, stack = [], [i]
    while stack:
        j = stack.pop()
        out.append(j)
        stack.extend(state.children[j])
    return out


def long_course_at(waypoint: int) -> TreeState:
    """The long course's tree with ``waypoint`` (0-based) closing in, those before passed."""
    mission = load_mission(str(EXAMPLES_DIR / "long-course.yaml"))
    state = TreeState.of_tree(build_mission_tree(mission))
    state.status = [SUCCESS] * len(state.names)
    state.message = [f"{n} said something long enough to be cut at eighty columns, twice over"
                     for n in state.names]
    route = state.names.index("Route")
    state.status[0] = state.status[route] = RUNNING
    for k, wp in enumerate(state.children[route]):
        below = _subtree(state, wp)
        if k > waypoint:
            for j in below:
                state.status[j], state.message[j] = INVALID, ""
        elif k == waypoint:
            state.status[wp] = RUNNING
            for j in below[1:]:
                state.status[j] = CLOSING_IN[state.names[j]]
    return state


def screen(state: TreeState, width: int, height: int) -> list[str]:
    console = Console(file=io.StringIO(), width=width, height=height, force_terminal=False)
    style = "unicode"
    with console.capture() as cap:
        console.print(render(state, {"t": 1.0, "tick": 20, "target": "green #8, pass on its "
                                     "right", "marks": ["green 1.05 m"]},
                             style=style, max_rows=tree_rows(height, width, style),
                             title="marknav run long-course", width=width))
    return cap.get().rstrip("\n").split("\n")


@pytest.mark.parametrize(("width", "height"), [(80, 24), (120, 40), (60, 20)])
@pytest.mark.parametrize("waypoint", [0, 7, 11])
def test_the_screen_fits_and_keeps_the_running_node_and_the_legend(
        width: int, height: int, waypoint: int) -> None:
    lines = screen(long_course_at(waypoint), width, height)
    assert len(lines) <= height - 1, "\n".join(lines)  # the cursor's row stays free
    assert all(len(line) <= width for line in lines)
    legend = " ".join(lines[:3])
    for symbol in ("▶ running", "✔ success", "✘ failure", "· idle", "→ sequence", "? selector",
                   "⇉ parallel", "◇ decorator", "(m) memory", "▸ folded"):
        assert symbol in legend, legend
    text = "\n".join(lines)
    assert "▶ Approach" in text and "▶ → CloseIn" in text, text
    assert f"Waypoint {waypoint + 1}:" in text, text


def test_finished_waypoints_fold_before_the_running_branch_is_touched() -> None:
    state = long_course_at(7)
    rows = [t for t, _ in state.lines(max_rows=tree_rows(24, 80, "unicode"))]
    text = "\n".join(rows)
    assert "7 × ▸ Waypoint 1" in text, text
    assert "4 × ▸ Waypoint 9" in text, text
    # every node of the running branch keeps its own row, with its words
    for name in ("Pass (m)", "Reach", "CloseIn", "Approach"):
        assert any(name in r and "said something" in r for r in rows), (name, text)
    # a tall terminal shows the tree unfolded but for the grouped waypoints
    tall = state.text(max_rows=tree_rows(60, 160, "unicode"))
    assert "Perception said something" in tall and "rows not shown" not in tall


def test_a_tiny_screen_cuts_rows_off_the_running_branch_first() -> None:
    state = long_course_at(3)
    rows = [t for t, _ in state.lines(max_rows=9)]
    assert len(rows) == 9
    assert rows[0].startswith("… ") and "rows not shown" in rows[0]
    assert any("▶ Approach" in r for r in rows)


def test_a_simulated_run_under_the_live_view_is_paced_unless_told() -> None:
    mission = load_mission(str(EXAMPLES_DIR / "slalom.yaml"))

    class Watching:
        def __init__(self, view: object) -> None:
            self.view = view

    live = LiveView.__new__(LiveView)  # what make_view returns on a terminal (not started)
    plain = PlainView(io.StringIO())
    auto = RunRequest(mission=mission, realtime=None)
    assert paced(auto, Watching(live)) is True  # type: ignore[arg-type]
    assert paced(auto, Watching(plain)) is False  # type: ignore[arg-type]
    assert paced(auto, None) is False
    fast = RunRequest(mission=mission, realtime=False)
    assert paced(fast, Watching(live)) is False  # type: ignore[arg-type]
    slow = RunRequest(mission=mission, realtime=True)
    assert paced(slow, Watching(plain)) is True  # type: ignore[arg-type]
