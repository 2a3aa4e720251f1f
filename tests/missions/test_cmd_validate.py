"""``marknav validate MISSION...``: output, every error, world checks and exit codes."""

from __future__ import annotations

from pathlib import Path

import pytest

from marknav.cli.main import main

MISSIONS = Path(__file__).resolve().parents[2] / "missions"

MISSION = """\
name: t
route: [red, green]
marks:
  colours:
    red: {hue: [170, 10], side: left}
    green: {hue: [40, 85], side: right}
"""

WORLD = """\
marks:
  - {colour: red, x_mm: 0, y_mm: 1500}
  - {colour: green, x_mm: 0, y_mm: 3500}
"""


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(["validate", *argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_valid_examples(capsys: pytest.CaptureFixture[str]) -> None:
    paths = [str(MISSIONS / f"{n}.yaml") for n in ("slalom", "figure-eight", "long-course")]
    code, out, err = run(paths, capsys)
    assert code == 0
    assert err == ""
    assert out.splitlines() == [
        f"{paths[0]}: ok (route: red → green → red → blue, 4 waypoints)",
        f"{paths[1]}: ok (route: red → green → red → green → red → green, 6 waypoints)",
        f"{paths[2]}: ok (route: red → green → blue → yellow → red → green → blue → green → red "
        "→ yellow → blue → green, 12 waypoints)",
    ]


def test_one_waypoint_is_singular(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "one.yaml"
    path.write_text(MISSION.replace("[red, green]", "[green]"))
    assert run([str(path)], capsys) == (0, f"{path}: ok (route: green, 1 waypoint)\n", "")


def test_every_error_of_every_file_then_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(MISSION.replace("[red, green]", "[red, gren]")
                   + "robot: {max_speed_mm_s: 200, wheelbase_mm: 235}\n")
    good = tmp_path / "good.yaml"
    good.write_text(MISSION)
    missing = tmp_path / "missing.yaml"
    code, out, err = run([str(bad), str(good), str(missing)], capsys)
    assert code == 2
    assert out == f"{good}: ok (route: red → green, 2 waypoints)\n"
    assert err.splitlines() == [
        f"{bad}:2:14: route[1]: colour 'gren' is not defined in marks.colours; did you mean "
        "'green'?",
        f"{bad}:7:30: robot.wheelbase_mm: unknown key 'wheelbase_mm'; did you mean "
        "'wheel_base_mm'?",
        f"{missing}: no such file",
        "marknav validate: 2 of 3 mission files invalid",
    ]


def test_world_is_checked_against_the_mission(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("marknav.sim.world")
    (tmp_path / "w.yaml").write_text(WORLD.replace("colour: green", "colour: purple"))
    mission = tmp_path / "m.yaml"
    mission.write_text(MISSION + "sim: {world: w.yaml}\n")
    code, out, err = run([str(mission)], capsys)
    assert (code, out) == (2, "")
    lines = err.splitlines()
    assert lines[0].startswith(
        f"{tmp_path / 'w.yaml'}:3:14: marks[1].colour: colour 'purple' is not in the mission's "
        "palette")
    # reported with it, not in a second round: the route's green has no mark either
    assert lines[1:] == [
        f"{mission}:2:14: route[1]: no green mark in the world {tmp_path / 'w.yaml'}",
        "marknav validate: 1 of 1 mission file invalid"]


def test_route_colour_without_a_mark_in_the_world(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("marknav.sim.world")
    (tmp_path / "w.yaml").write_text(WORLD.replace("colour: green", "colour: red"))
    mission = tmp_path / "m.yaml"
    mission.write_text(MISSION.replace("[red, green]", "[red, green, red, green]")
                       + "sim: {world: w.yaml}\n")
    code, _, err = run([str(mission)], capsys)
    assert code == 2
    assert err.splitlines() == [
        f"{mission}:2:14: route[1]: no green mark in the world {tmp_path / 'w.yaml'}",
        "marknav validate: 1 of 1 mission file invalid",
    ]


def test_invalid_world_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("marknav.sim.world")
    world = tmp_path / "w.yaml"
    world.write_text(WORLD + "robot: {x_mm: 0, heading: 90}\n")
    mission = tmp_path / "m.yaml"
    mission.write_text(MISSION + "sim: {world: w.yaml}\n")
    code, _, err = run([str(mission)], capsys)
    assert code == 2
    assert err.splitlines()[0].startswith(f"{world}:4:18: robot.heading: unknown key 'heading'")


def test_missing_world_file_points_at_sim_world(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    mission = tmp_path / "m.yaml"
    mission.write_text(MISSION + "sim:\n  world: worlds/none.yaml\n")
    code, _, err = run([str(mission)], capsys)
    assert code == 2
    assert err.splitlines() == [
        f"{mission}:8:10: sim.world: no such world file: {tmp_path / 'worlds' / 'none.yaml'}",
        "marknav validate: 1 of 1 mission file invalid",
    ]



def test_usage_needs_a_mission(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["validate"])
    assert exc.value.code == 2
    assert "MISSION" in capsys.readouterr().err
