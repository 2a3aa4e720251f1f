"""One validator: a corpus of broken missions through ``validate``, ``tree`` and ``run``.

Whatever ``run`` or ``tree`` refuses, ``validate`` refuses first, with the same message and a
location (FILE:LINE[:COLUMN] or the ``--set`` setting); every error of a file comes at once;
nothing gives a traceback (the commands run in-process, so one would fail the test).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from marknav.cli.main import main

CORPUS = Path(__file__).resolve().parents[1] / "data" / "broken-missions"
BROKEN = sorted(CORPUS.glob("*.yaml"))
#: FILE:LINE:COLUMN: field: message (FILE:LINE: for YAML errors without a column).
LOCATED = re.compile(r"^(?P<file>[^:]+\.yaml):(?P<line>\d+)(:(?P<col>\d+))?: .+")


def _errors(stderr: str, command: str) -> list[str]:
    """The error lines of a command's stderr (the CLI prefix and the summary line dropped)."""
    lines = stderr.splitlines()
    prefix = f"marknav {command}: error: "
    out = []
    for line in lines:
        if line.startswith(f"marknav {command}: ") and not line.startswith(prefix):
            continue  # "marknav validate: 1 of 1 mission file invalid"
        out.append(line.removeprefix(prefix))
    return out


def test_the_corpus_is_broad() -> None:
    assert len(BROKEN) >= 18


@pytest.mark.parametrize("path", BROKEN, ids=[p.stem for p in BROKEN])
def test_validate_refuses_first_what_tree_and_run_refuse(
    path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(["validate", str(path)])
    err = capsys.readouterr().err
    assert code == 2
    validate_errors = _errors(err, "validate")
    assert validate_errors, err
    for line in validate_errors:
        assert LOCATED.match(line), line
        assert "Traceback" not in line

    code = main(["tree", str(path)])
    out = capsys.readouterr()
    assert code == 2 and "Traceback" not in out.err
    tree_errors = _errors(out.err, "tree")
    assert tree_errors == validate_errors

    report = tmp_path / "report.json"
    code = main(["run", str(path), "--max-time", "2", "--report", str(report)])
    out = capsys.readouterr()
    assert code == 2 and "Traceback" not in out.err
    assert _errors(out.err, "run") == validate_errors
    assert not report.exists()  # refused before anything ran


def _validate(path: Path, capsys: pytest.CaptureFixture[str], *extra: str) -> list[str]:
    assert main(["validate", str(path), *extra]) == 2
    return _errors(capsys.readouterr().err, "validate")


def test_four_mistakes_in_one_round(capsys: pytest.CaptureFixture[str]) -> None:
    path = CORPUS / "four-mistakes.yaml"
    f = str(path)
    w = CORPUS / "worlds" / "ok.yaml"
    assert _validate(path, capsys) == [
        f"{f}:12:17: camera.width: Input should be less than or equal to 4096",
        f"{f}:12:32: camera.height: Input should be less than or equal to 4096",
        f"{f}:22:45: tree.children[2].children[0].params.colour: Waypoint colour 'purple', "
        "but route[0] is 'yellow' (index: 0)",
        f"{f}:23:45: tree.children[2].children[1].params.colour: colour 'yelow' is not in "
        "marks.colours (yellow, green, blue, purple); did you mean 'yellow'?",
        f"{f}:24:58: tree.children[2].children[2].params.index: index 7, but the route has 3 "
        "waypoints (indices 0..2)",
        f"{f}:5:14: marks.radius_mm: with marks 900 mm in radius, the marks of the world {w} "
        "overlap: marks[1] (green at 0, 3000) overlaps marks[0] (yellow at 0, 1500): centres "
        "1500 mm apart, radii 900 + 900 mm",
    ]


def test_tree_without_waypoints_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    path = CORPUS / "tree-success-only.yaml"
    assert _validate(path, capsys) == [
        f"{path}:11:7: tree: the tree drives none of the route's 3 waypoints (no Waypoint, "
        "SelectTarget or Route node): the run could only end with every waypoint pending; add "
        "one Waypoint per route entry (indices follow their order) or a Route node"]


def test_set_fixes_and_breaks_with_the_setting_as_location(
    capsys: pytest.CaptureFixture[str]
) -> None:
    path = CORPUS / "clearance-too-small.yaml"
    assert main(["validate", str(path), "--set", "navigation.clearance_mm=300"]) == 0
    assert capsys.readouterr().out == f"{path}: ok (route: yellow → green → blue, 3 waypoints)\n"
    assert _validate(path, capsys, "--set", "navigation.clearance_mm=-5",
                     "--set", "camera.widht=320") == [
        "--set camera.widht=320: camera.widht: unknown key 'widht'; did you mean 'width'?",
        "--set navigation.clearance_mm=-5: navigation.clearance_mm: Input should be greater "
        "than 0",
    ]
    # a --set that breaks a rule checked against another file is blamed on the setting
    ok = CORPUS.parents[2] / "missions" / "slalom.yaml"
    [error] = _validate(ok, capsys, "--set", "marks.radius_mm=850",
                        "--set", "navigation.clearance_mm=1100",
                        "--set", "navigation.bypass_distance_mm=1500")
    assert error.startswith("--set marks.radius_mm=850: marks.radius_mm: with marks 850 mm in "
                            "radius, the marks of the world ")


@pytest.mark.parametrize(("setting", "message"), [
    ("navigation", "--set: expected KEY=VALUE (e.g. navigation.clearance_mm=350), got "
                   "'navigation'"),
    ("navigation..x=1", "--set: 'navigation..x' is not a dotted key such as "
                        "navigation.clearance_mm"),
    ("route.7=red", "--set route.7=red: route[7]: route has 3 entries: no index 7"),
    ("name.x=1", "--set name.x=1: name.x: name is not a mapping"),
    ("route.x=red", "--set route.x=red: route.x: route is a list: use an index (e.g. route.0)"),
    ("camera.width=[1", "--set: the value of camera.width is not valid YAML: expected ',' or "
                        "']', but got '<stream end>'"),
])
def test_malformed_settings_exit_2(
    setting: str, message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    path = CORPUS / "clearance-too-small.yaml"
    assert main(["validate", str(path), "--set", setting]) == 2
    err = capsys.readouterr().err.strip()
    if message.startswith("--set: "):  # the command line itself: refused before any file
        assert err == f"marknav validate: error: {message}"
    else:
        assert err.splitlines() == [message, "marknav validate: 1 of 1 mission file invalid"]


def test_run_records_its_settings_in_the_report(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    report = tmp_path / "report.json"
    slalom = CORPUS.parents[2] / "missions" / "slalom.yaml"
    code = main(["run", str(slalom), "--tree", "none", "--max-time", "0.5", "--report",
                 str(report), "--set", "navigation.approach_speed_mm_s=200",
                 "--set", "sim.seed=4"])
    assert code == 1  # 0.5 s cannot pass a mark
    data = json.loads(report.read_text())
    assert data["overrides"] == ["navigation.approach_speed_mm_s=200", "sim.seed=4"]
    assert data["seed"] == 4  # the setting took effect
    capsys.readouterr()


def test_validate_with_the_world_run_would_use(capsys: pytest.CaptureFixture[str]) -> None:
    path = CORPUS / "clearance-too-small.yaml"
    fixed = ["--set", "navigation.clearance_mm=300"]
    world = CORPUS / "worlds" / "foreign-colours.yaml"
    assert _validate(path, capsys, *fixed, "--world", str(world)) == [
        f"{world}:4:14: marks[1].colour: colour 'magenta' is not in the mission's palette "
        "(blue, green, purple, yellow)",
        f"{path}:3:17: route[1]: no green mark in the world {world}",
    ]
    assert main(["run", str(path), *fixed, "--world", str(world), "--max-time", "1"]) == 2
    assert _errors(capsys.readouterr().err, "run") == [
        f"{world}:4:14: marks[1].colour: colour 'magenta' is not in the mission's palette "
        "(blue, green, purple, yellow)",
        f"{path}:3:17: route[1]: no green mark in the world {world}",
    ]
