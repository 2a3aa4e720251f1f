"""``marknav tree``: the live view's notation and legend, and dot output with the same labels
that Graphviz reads without warnings."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pydot
import pytest

from marknav.behaviours.tree import build_mission_tree
from marknav.cli.main import main
from marknav.missions.schema import load_mission
from marknav.runs.records.tree_state import TreeState, legend

MISSIONS = Path(__file__).resolve().parents[2] / "missions"


@pytest.mark.filterwarnings("ignore::DeprecationWarning")  # pydot's parser on new pyparsing
def test_dot_has_simple_ids_unique_labels_and_says_where_it_went(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out_file = tmp_path / "tree.dot"
    assert main(["tree", str(MISSIONS / "slalom.yaml"), "--dot", str(out_file)]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[-1] == (
        f"# wrote {out_file} (Graphviz dot; render with: dot -Tpng {out_file} -o tree.png)")
    text = out_file.read_text(encoding="utf-8")
    [graph] = pydot.graph_from_dot_data(text)
    nodes = [n for n in graph.get_nodes() if n.get_name() not in ("node", "edge", "graph")]
    assert len(nodes) == 7 + 4 * 16  # Mission, its guards (5), Route; 16 nodes a waypoint
    assert all(re.fullmatch(r"n\d+", n.get_name()) for n in nodes)
    labels = [n.get("label") for n in nodes]
    assert len(set(labels)) == len(labels)  # repeated nodes told apart
    assert all(label.isascii() for label in labels)  # no glyph a default font lacks
    assert '"Passed?\\nin Waypoint 2: green"' in labels
    assert '"-> Route (m)"' in labels  # the text drawing's label, ASCII style
    for edge in graph.get_edges():  # no ports: every edge joins two node ids
        assert re.fullmatch(r"n\d+", edge.get_source())
        assert re.fullmatch(r"n\d+", edge.get_destination())


@pytest.mark.skipif(shutil.which("dot") is None, reason="Graphviz is not installed")
def test_graphviz_renders_it_without_a_warning(tmp_path: Path) -> None:
    out_file = tmp_path / "tree.dot"
    assert main(["tree", str(MISSIONS / "pause-at-each-mark.yaml"), "--dot", str(out_file)]) == 0
    done = subprocess.run(["dot", "-Tsvg", str(out_file)], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 0 and done.stderr == ""
    assert done.stdout.count("<g id=\"node") == 7 + 4 * 16 + 4  # and the 4 Photo pauses


def test_tree_draws_in_the_live_views_notation(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["tree", str(MISSIONS / "pause-at-each-mark.yaml"), "--tree", "unicode"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[1] == f"# legend: {legend('unicode')}"  # the live view's and replay's legend
    assert lines[2:8] == [
        "· → Mission",
        "  · Perception",
        "  · SafetyGuard",
        "  · ? BumpRecovery",
        "    · NotBumped?",
        "    · BackOff",
    ]
    assert "  · → Route with pauses (m)" in lines
    assert "    · Photo 1" in lines and "    · Photo 4" in lines
    # what a run shows before its first tick, row for row (the live view folds; tree does not)
    mission = load_mission(MISSIONS / "pause-at-each-mark.yaml")
    state = TreeState.of_tree(build_mission_tree(mission))
    assert lines[2:] == state.text(style="unicode", full=True).splitlines()
    assert state.lines(style="unicode")[1][0] == lines[3]
    assert main(["tree", str(MISSIONS / "pause-at-each-mark.yaml"), "--tree", "ascii"]) == 0
    ascii_lines = capsys.readouterr().out.splitlines()
    assert "\n".join(ascii_lines).isascii()
    assert ascii_lines[1] == f"# legend: {legend('ascii')}"
    assert "  -    -> Route with pauses (m)" in ascii_lines


@pytest.mark.filterwarnings("ignore::DeprecationWarning")  # pydot's parser on new pyparsing
def test_dot_labels_are_the_text_labels(tmp_path: Path) -> None:
    out_file = tmp_path / "tree.dot"
    assert main(["tree", str(MISSIONS / "slalom.yaml"), "--dot", str(out_file)]) == 0
    [graph] = pydot.graph_from_dot_data(out_file.read_text(encoding="utf-8"))
    first_lines = [n.get("label").strip('"').split("\\n")[0] for n in graph.get_nodes()
                   if n.get_name() not in ("node", "edge", "graph")]
    mission = load_mission(MISSIONS / "slalom.yaml")
    state = TreeState.of_tree(build_mission_tree(mission))
    assert first_lines == [state.label(i, "ascii") for i in range(len(state.names))]
    assert "(m) memory" in graph.get("label")  # the legend under the graph
