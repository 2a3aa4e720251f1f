"""Mission files: the examples load, defaults, palette, and every kind of error with its exact
``FILE:LINE:COLUMN: field: message`` text."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from marknav.core.errors import InputError
from marknav.missions.schema import Mission, PinholeRange, PowerRange, load_mission
from marknav.sim.camera_model import SIM_RANGE_A, SIM_RANGE_B
from marknav.vision.palette import ColourRange

MISSIONS = Path(__file__).resolve().parents[2] / "missions"

MINIMAL = """\
name: t
route: [red, green]
marks:
  colours:
    red: {hue: [170, 10], side: left}
    green: {hue: [40, 85], side: right}
"""


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "m.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def errors_of(tmp_path: Path, text: str) -> list[str]:
    """Every error line for the mission ``text``, with the file written as ``M``."""
    path = write(tmp_path, text)
    with pytest.raises(InputError) as exc:
        load_mission(path)
    return [line.replace(str(path), "M") for line in str(exc.value).splitlines()]


# --- the examples --------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("name", "route", "world_marks"),
    [
        ("slalom", ["red", "green", "red", "blue"], 4),
        ("figure-eight", ["red", "green"] * 3, 2),
        ("long-course", ["red", "green", "blue", "yellow", "red", "green", "blue", "green",
                         "red", "yellow", "blue", "green"], 12),
    ],
)
def test_examples_load(name: str, route: list[str], world_marks: int) -> None:
    mission = load_mission(MISSIONS / f"{name}.yaml")
    assert mission.name == name
    assert mission.route == route
    assert mission.source_path == MISSIONS / f"{name}.yaml"
    assert mission.sim is not None and mission.sim.world is not None
    assert mission.sim.world == MISSIONS / "worlds" / f"{name}-world.yaml"
    assert mission.sim.world.is_file()
    # Both pass sides are used, and every colour of the route has a side.
    assert {mission.side_of(c) for c in route} == {"left", "right"}
    world = pytest.importorskip("marknav.sim.world").load_world(mission.sim.world)
    assert len(world.marks) == world_marks
    assert {m.colour for m in world.marks} == set(route)


def test_slalom_is_the_briefs_mission() -> None:
    m = load_mission(MISSIONS / "slalom.yaml")
    assert m.marks.radius_mm == 100
    assert {n: (c.hue, c.side) for n, c in m.marks.colours.items()} == {
        "red": ((170, 10), "left"), "green": ((40, 85), "right"), "blue": ((95, 130), "left")}
    assert (m.robot.wheel_base_mm, m.robot.max_speed_mm_s) == (235, 300)
    assert (m.camera.width, m.camera.height) == (640, 480)
    # The simulator's own calibration (marknav calibrate --sim), not the paper's camera.
    assert m.camera.range == PowerRange(model="power", a=SIM_RANGE_A, b=SIM_RANGE_B)
    nav = m.navigation
    assert (nav.bypass_distance_mm, nav.clearance_mm, nav.approach_speed_mm_s) == (800, 300, 250)
    assert (nav.lost_after_s, nav.search.turn_speed_deg_s, nav.search.timeout_s) == (0.5, 40, 15)
    s = m.safety
    assert (s.command_timeout_s, s.sensor_timeout_s, s.max_bump_recoveries) == (0.3, 0.2, 2)
    assert m.control.rate_hz == 20


def test_long_course_uses_a_pinhole_range() -> None:
    m = load_mission(MISSIONS / "long-course.yaml")
    assert m.camera.range == PinholeRange(model="pinhole", focal_px=590)
    assert m.marks.colours["yellow"].sat_min == 120
    assert len(m.route) >= 10


# --- defaults and derived values -------------------------------------------------------------


def test_minimal_mission_gets_the_defaults(tmp_path: Path) -> None:
    m = load_mission(write(tmp_path, MINIMAL))
    assert m.marks.radius_mm == 100
    assert (m.robot.model, m.robot.wheel_base_mm, m.robot.radius_mm) == ("create2", 235, 165)
    assert m.robot.max_speed_mm_s == 300
    assert m.camera.focal_px == 590
    assert m.camera.range == PowerRange(model="power", a=58958, b=-0.9434)
    # 2·atan(320/590) and 2·atan(240/590)
    assert m.camera.hfov_deg == pytest.approx(56.948, abs=1e-3)
    assert m.camera.vfov_deg == pytest.approx(44.271, abs=1e-3)
    assert m.navigation.lookahead_mm == 150
    assert m.navigation.search.timeout_s == 15
    assert m.control.rate_hz == 20
    assert m.sim is None and m.tree is None


def test_create1_gets_its_own_wheel_base(tmp_path: Path) -> None:
    m = load_mission(write(tmp_path, MINIMAL + "robot: {model: create1}\n"))
    assert m.robot.wheel_base_mm == 258
    m = load_mission(write(tmp_path, MINIMAL + "robot: {model: create1, wheel_base_mm: 250}\n"))
    assert m.robot.wheel_base_mm == 250


def test_palette_and_sides(tmp_path: Path) -> None:
    text = MINIMAL.replace("side: right}", "side: right, sat_min: 90, val_min: 40}")
    m = load_mission(write(tmp_path, text))
    assert m.palette() == (
        ColourRange("red", 170, 10, sat_min=100, val_min=50),
        ColourRange("green", 40, 85, sat_min=90, val_min=40),
    )
    assert m.palette()[0].wraps and m.palette()[0].contains(2)
    assert m.side_of("red") == "left" and m.side_of("green") == "right"
    with pytest.raises(KeyError, match=r"'blue' is not in the mission's marks\.colours"):
        m.side_of("blue")
    assert m.route_summary() == "red → green, 2 waypoints"


def test_positions_are_kept_for_later_errors(tmp_path: Path) -> None:
    path = write(tmp_path, MINIMAL)
    m = load_mission(path)
    assert m.document is not None and m.document.path == str(path)
    pos = m.position(("route", 1))
    assert pos is not None and (pos.line, pos.column) == (2, 14)
    err = m.input_error(("marks", "colours", "green", "side"), "never seen")
    assert str(err) == f"{path}:6:34: marks.colours.green.side: never seen"
    # A field left to its default points at its nearest written ancestor (here the file).
    assert str(m.input_error(("navigation", "clearance_mm"), "x")) == (
        f"{path}:1:1: navigation.clearance_mm: x")


def test_document_is_not_dumped_and_a_dump_reloads(tmp_path: Path) -> None:
    m = load_mission(write(tmp_path, MINIMAL + "sim: {world: w.yaml, seed: 3}\n"))
    dumped = m.model_dump(mode="json")
    assert set(dumped) == {"name", "marks", "route", "robot", "camera", "navigation", "safety",
                           "control", "sim", "plugins", "tree"}
    assert "document" not in dumped and "_document" not in dumped
    # (Mission equality would compare the private document too.)
    assert Mission.model_validate(dumped).model_dump(mode="json") == dumped


def test_world_is_resolved_relative_to_the_mission(tmp_path: Path) -> None:
    sub = tmp_path / "deep"
    sub.mkdir()
    path = sub / "m.yaml"
    path.write_text(MINIMAL + "sim: {world: worlds/w.yaml}\n", encoding="utf-8")
    m = load_mission(path)
    assert m.sim is not None
    assert m.sim.world == sub / "worlds" / "w.yaml"
    assert m.sim.seed == 0


# --- errors: one kind per test, exact text ------------------------------------------------


def test_unknown_key_with_did_you_mean(tmp_path: Path) -> None:
    text = MINIMAL + "navigation:\n  clearence_mm: 300\n"
    assert errors_of(tmp_path, text) == [
        "M:8:3: navigation.clearence_mm: unknown key 'clearence_mm'; did you mean 'clearance_mm'?"
    ]


def test_unknown_top_level_key(tmp_path: Path) -> None:
    assert errors_of(tmp_path, MINIMAL + "rout: [red]\n") == [
        "M:7:1: rout: unknown key 'rout'; did you mean 'route'?"
    ]


def test_route_colour_not_in_palette_points_at_the_item(tmp_path: Path) -> None:
    text = MINIMAL.replace("route: [red, green]", "route: [red, gren, purple]")
    assert errors_of(tmp_path, text) == [
        "M:2:14: route[1]: colour 'gren' is not defined in marks.colours; did you mean 'green'?",
        "M:2:20: route[2]: colour 'purple' is not defined in marks.colours (colours: red, green)",
    ]


def test_route_colour_error_in_a_block_list(tmp_path: Path) -> None:
    text = MINIMAL.replace("route: [red, green]", "route:\n  - red\n  - blue\n")
    assert errors_of(tmp_path, text) == [
        "M:4:5: route[1]: colour 'blue' is not defined in marks.colours (colours: red, green)"
    ]


def test_hue_out_of_range(tmp_path: Path) -> None:
    text = MINIMAL.replace("[40, 85]", "[40, 185]")
    assert errors_of(tmp_path, text) == [
        "M:6:23: marks.colours.green.hue[1]: Input should be less than or equal to 179"
    ]


def test_speed_above_the_create_limit(tmp_path: Path) -> None:
    text = MINIMAL + "robot:\n  max_speed_mm_s: 650\n"
    assert errors_of(tmp_path, text) == [
        "M:8:19: robot.max_speed_mm_s: 650 mm/s is more than the Create's wheel speed limit of "
        "500 mm/s"
    ]


@pytest.mark.parametrize(
    ("extra", "expected"),
    [
        ("control: {rate_hz: 0.5}\n",
         "M:7:20: control.rate_hz: Input should be greater than or equal to 1"),
        ("control: {rate_hz: 200}\n",
         "M:7:20: control.rate_hz: Input should be less than or equal to 100"),
        ("colour: red\n", "M:7:1: colour: unknown key 'colour' (allowed: camera, control, marks, "
         "name, navigation, plugins, robot, route, safety, sim, tree)"),
        ("safety: {command_timeout_s: 0}\n",
         "M:7:29: safety.command_timeout_s: Input should be greater than 0"),
        ("navigation: {search: {timeout_s: -1}}\n",
         "M:7:34: navigation.search.timeout_s: Input should be greater than 0"),
        ("robot: {radius_mm: .nan}\n", "M:7:20: robot.radius_mm: Input should be a finite number"),
        ("robot: {model: create3}\n",
         "M:7:16: robot.model: Input should be 'create1' or 'create2'"),
    ],
)
def test_ranges(tmp_path: Path, extra: str, expected: str) -> None:
    assert errors_of(tmp_path, MINIMAL + extra) == [expected]


def test_side_must_be_left_or_right(tmp_path: Path) -> None:
    text = MINIMAL.replace("side: right", "side: up")
    assert errors_of(tmp_path, text) == [
        "M:6:34: marks.colours.green.side: Input should be 'left' or 'right'"
    ]


def test_python_tag_is_rejected(tmp_path: Path) -> None:
    text = MINIMAL.replace("name: t", 'name: !!python/object/apply:os.system ["echo hi"]')
    assert errors_of(tmp_path, text) == [
        "M:1:7: could not determine a constructor for the tag "
        "'tag:yaml.org,2002:python/object/apply:os.system' (only plain YAML is accepted: no "
        "Python tags)"
    ]


def test_duplicate_key(tmp_path: Path) -> None:
    assert errors_of(tmp_path, MINIMAL + "name: again\n") == [
        "M:7:1: name: duplicate key 'name' (first at line 1)"
    ]


def test_wrong_type(tmp_path: Path) -> None:
    text = MINIMAL.replace("marks:\n", "marks:\n  radius_mm: big\n")
    assert errors_of(tmp_path, text) == [
        "M:4:14: marks.radius_mm: Input should be a valid number, not the text 'big'"
    ]


def test_missing_required_keys(tmp_path: Path) -> None:
    assert errors_of(tmp_path, "name: t\n") == [
        "M:1:1: marks: Field required",
        "M:1:1: route: Field required",
    ]


def test_not_a_mapping(tmp_path: Path) -> None:
    assert errors_of(tmp_path, "- red\n- green\n") == [
        "M:1:1: a mission is a mapping of keys (name: ..., route: [...], marks: {...}), not a list"
    ]


def test_overlapping_hues(tmp_path: Path) -> None:
    text = MINIMAL.replace("[40, 85]", "[5, 85]")
    assert errors_of(tmp_path, text) == [
        "M:6:18: marks.colours.green.hue: hue range 5..85 overlaps red's 170..10: a mark in the "
        "overlap could be either colour"
    ]


def test_bad_colour_name(tmp_path: Path) -> None:
    text = MINIMAL.replace("    green:", "    light green:")
    errors = errors_of(tmp_path, text)
    assert len(errors) == 1
    assert errors[0].startswith("M:6:18: marks.colours.light green: String should match pattern")


# --- range model ---------------------------------------------------------------------------


def test_range_model_errors(tmp_path: Path) -> None:
    assert errors_of(tmp_path, MINIMAL + "camera:\n  range: {model: powr, a: 1, b: -1}\n") == [
        "M:8:18: camera.range.model: unknown range model 'powr'; did you mean 'power'?"
    ]
    assert errors_of(tmp_path, MINIMAL + "camera:\n  range: {model: pinhole}\n") == [
        "M:8:10: camera.range.focal_px: Field required"
    ]
    power = "camera:\n  range: {model: power, a: 50000, b: 0.9}\n"
    assert errors_of(tmp_path, MINIMAL + power) == [
        "M:8:38: camera.range.b: Input should be less than 0"
    ]
    assert errors_of(tmp_path, MINIMAL + "camera:\n  range: {a: 5e4, b: -0.9}\n") == [
        "M:8:10: camera.range.model: missing 'model': power or pinhole"
    ]
    assert errors_of(tmp_path, MINIMAL + "camera:\n  range: {model: pinhole, focal_px: 590, "
                     "f: 1}\n") == [
        "M:8:42: camera.range.f: unknown key 'f' (allowed: focal_px, model)"
    ]


# --- cross-field checks point at the field to change ---------------------------------------


def test_clearance_must_clear_robot_and_mark(tmp_path: Path) -> None:
    text = MINIMAL + "navigation:\n  clearance_mm: 250\n"
    assert errors_of(tmp_path, text) == [
        "M:8:17: navigation.clearance_mm: clearance_mm 250 must exceed robot.radius_mm + "
        "marks.radius_mm = 165 + 100 = 265: clearance is robot centre to mark centre, so with "
        "less the robot touches the mark"
    ]


def test_clearance_error_blames_the_written_radius(tmp_path: Path) -> None:
    # The clearance is left at its default (300): the robot's radius is what the author changed.
    text = MINIMAL + "robot:\n  radius_mm: 220\n"
    assert errors_of(tmp_path, text) == [
        "M:8:14: robot.radius_mm: clearance_mm 300 must exceed robot.radius_mm + "
        "marks.radius_mm = 220 + 100 = 320: clearance is robot centre to mark centre, so with "
        "less the robot touches the mark"
    ]


def test_clearance_exactly_touching_is_rejected_and_one_more_mm_is_fine(tmp_path: Path) -> None:
    assert errors_of(tmp_path, MINIMAL + "navigation: {clearance_mm: 265}\n")[0].startswith(
        "M:7:28: navigation.clearance_mm: clearance_mm 265 must exceed")
    load_mission(write(tmp_path, MINIMAL + "navigation: {clearance_mm: 266}\n"))


def test_approach_speed_above_max_speed(tmp_path: Path) -> None:
    text = MINIMAL + "robot: {max_speed_mm_s: 200}\n"
    assert errors_of(tmp_path, text) == [
        "M:7:25: robot.max_speed_mm_s: approach_speed_mm_s 250 exceeds robot.max_speed_mm_s 200"
    ]
    text = MINIMAL + "robot: {max_speed_mm_s: 200}\nnavigation: {approach_speed_mm_s: 210}\n"
    assert errors_of(tmp_path, text) == [
        "M:8:35: navigation.approach_speed_mm_s: approach_speed_mm_s 210 exceeds "
        "robot.max_speed_mm_s 200"
    ]


def test_bypass_must_start_beyond_the_clearance(tmp_path: Path) -> None:
    text = MINIMAL + "navigation:\n  clearance_mm: 400\n  bypass_distance_mm: 400\n"
    assert errors_of(tmp_path, text) == [
        "M:9:23: navigation.bypass_distance_mm: bypass_distance_mm 400 must exceed clearance_mm "
        "400: the bypass starts farther from the mark than it passes it"
    ]


def test_search_turn_needs_feasible_wheel_speeds(tmp_path: Path) -> None:
    # 300 °/s × 117.5 mm = 615 mm/s at each wheel, more than 300.
    text = MINIMAL + "navigation: {search: {turn_speed_deg_s: 300}}\n"
    assert errors_of(tmp_path, text) == [
        "M:7:41: navigation.search.turn_speed_deg_s: turn_speed_deg_s 300 needs wheel speeds of "
        "615 mm/s (turn rate × wheel_base_mm / 2), more than robot.max_speed_mm_s 300"
    ]


def test_command_timeout_must_span_two_control_periods(tmp_path: Path) -> None:
    text = MINIMAL + "control: {rate_hz: 5}\n"
    assert errors_of(tmp_path, text) == [
        "M:7:20: control.rate_hz: command_timeout_s 0.3 must be at least two control periods "
        "(2 / control.rate_hz = 0.4 s), or the watchdog stops the wheels between commands"
    ]


def test_every_error_is_reported_in_file_order(tmp_path: Path) -> None:
    text = """\
name: ""
route: [red]
marks:
  radius_mm: -1
  colours:
    red: {hue: [170, 10], side: left, sat: 3}
robot: {max_speed_mm_s: 900}
control: {rate_hz: 0}
"""
    assert errors_of(tmp_path, text) == [
        "M:1:7: name: String should have at least 1 character",
        "M:4:14: marks.radius_mm: Input should be greater than 0",
        "M:6:39: marks.colours.red.sat: unknown key 'sat'; did you mean 'sat_min'?",
        "M:7:25: robot.max_speed_mm_s: 900 mm/s is more than the Create's wheel speed limit of "
        "500 mm/s",
        "M:8:20: control.rate_hz: Input should be greater than or equal to 1",
    ]


def test_hfov_formula() -> None:
    cam = Mission.model_validate({
        "name": "x", "route": ["a"], "marks": {"colours": {"a": {"hue": [1, 2], "side": "left"}}},
        "camera": {"width": 1180, "focal_px": 590},
    }).camera
    assert cam.hfov_deg == pytest.approx(90.0)
    assert math.isclose(cam.vfov_deg, math.degrees(2 * math.atan(240 / 590)))
