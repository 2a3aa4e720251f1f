"""World files, generated worlds, contacts and pass measures (marknav.sim.world)."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest

from marknav.core.errors import InputError
from marknav.planning.kinematics import Pose
from marknav.runs.metrics.passes import min_clearance_mm, pass_crossings, passed_on
from marknav.sim import world as w
from marknav.sim.builtin_camera import CameraConfig, project_marks
from marknav.sim.world import (
    Box,
    Conditions,
    MarkSpec,
    Wall,
    World,
    bumps,
    check_against_palette,
    contacts,
    generate_world,
    load_world,
    push_out,
)
from marknav.vision.palette import DEFAULT_PALETTE, ColourRange

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "missions" / "worlds" / "slalom-world.yaml"
NORTH = math.pi / 2


def write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "world.yaml"
    p.write_text(text, encoding="utf-8")
    return p


# --- world files ------------------------------------------------------------------------------


def test_example_world_loads() -> None:
    world = load_world(EXAMPLE)
    assert [m.colour for m in world.marks] == ["red", "green", "red", "blue"]
    xs = [m.x_mm for m in world.marks]
    assert all(a * b < 0 for a, b in itertools.pairwise(xs))  # alternating lateral offsets
    ys = [m.y_mm for m in world.marks]
    assert ys == sorted(ys)
    assert world.robot.pose() == Pose(0.0, 0.0, NORTH)
    assert len(world.walls) == 4
    assert world.conditions.latency_frames == 1
    assert world.source == str(EXAMPLE)
    check_against_palette(world, DEFAULT_PALETTE)  # every colour exists


def test_defaults_and_yaw_convention(tmp_path: Path) -> None:
    world = load_world(write(tmp_path, "marks: [{colour: red, x_mm: 0, y_mm: 1500}]\n"))
    (mark,) = world.marks
    assert mark.yaw_deg == 0.0 and mark.radius_mm is None and mark.radius() == 100.0
    assert mark.normal == pytest.approx((0.0, -1.0))  # faces a robot at the origin
    turned = MarkSpec(colour="red", x_mm=0, y_mm=0, yaw_deg=90)
    assert turned.normal == pytest.approx((1.0, 0.0))  # counter-clockwise seen from above
    assert world.robot.pose() == Pose(0.0, 0.0, NORTH)
    assert world.conditions == Conditions()
    assert world.with_mark_radius(150.0).marks[0].radius_mm == 150.0
    explicit = World(marks=(MarkSpec(colour="red", x_mm=0, y_mm=1, radius_mm=80),))
    assert explicit.with_mark_radius(150.0).marks[0].radius_mm == 80.0


def test_bad_world_file_unknown_key_and_range(tmp_path: Path) -> None:
    path = write(tmp_path, (
        "marks:\n"
        "  - {colour: red, x_mm: 0, y_mm: 1500}\n"
        "  - {colour: green, x_mm: 300, y_mm: 3000, yaw: 10}\n"
        "conditions:\n"
        "  noise_sigma: -1\n"
    ))
    with pytest.raises(InputError) as exc:
        load_world(path)
    assert str(exc.value) == (
        f"{path}:3:44: marks[1].yaw: unknown key 'yaw'; did you mean 'yaw_deg'?\n"
        f"{path}:5:16: conditions.noise_sigma: Input should be greater than or equal to 0"
    )


def test_bad_world_file_type_and_cast(tmp_path: Path) -> None:
    path = write(tmp_path, (
        "marks:\n"
        "  - {colour: red, x_mm: 0, y_mm: 1500}\n"
        "robot: {x_mm: 0, y_mm: zero}\n"
        "conditions: {cast: purple}\n"
    ))
    with pytest.raises(InputError) as exc:
        load_world(path)
    assert str(exc.value) == (
        f"{path}:3:24: robot.y_mm: Input should be a valid number, not the text 'zero'\n"
        f"{path}:4:20: conditions.cast: unknown cast 'purple': use none, warm, cool or "
        "[b, g, r] channel gains"
    )


def test_overlapping_marks_and_bad_walls_are_rejected(tmp_path: Path) -> None:
    path = write(tmp_path, (
        "marks:\n"
        "  - {colour: red, x_mm: 0, y_mm: 1500}\n"
        "  - {colour: blue, x_mm: 50, y_mm: 1550}\n"
        "walls: [{x1_mm: 1, y1_mm: 2, x2_mm: 1, y2_mm: 2}]\n"
    ))
    with pytest.raises(InputError) as exc:
        load_world(path)
    text = str(exc.value)
    assert "marks[1] (blue at 50, 1550) overlaps marks[0]" in text
    assert f"{path}:4:9: walls[0]: a wall needs two different end points" in text


def test_cast_triple_and_gains() -> None:
    c = Conditions(lighting_gain=0.5, cast=(1.0, 1.0, 1.2))
    assert c.channel_gains_bgr() == pytest.approx((0.5, 0.5, 0.6))
    assert Conditions(cast="warm").cast_gains_bgr() == w.CAST_GAINS_BGR["warm"]
    with pytest.raises(ValueError):
        Conditions(cast=(1.0, 0.0, 1.0))  # gains must be positive


def test_missing_file_is_input_error(tmp_path: Path) -> None:
    with pytest.raises(InputError) as exc:
        load_world(tmp_path / "nope.yaml")
    assert str(exc.value) == f"{tmp_path / 'nope.yaml'}: no such file"


def test_check_against_palette_names_the_line(tmp_path: Path) -> None:
    path = write(tmp_path, (
        "marks:\n"
        "  - {colour: red, x_mm: 0, y_mm: 1500}\n"
        "  - colour: gren\n"
        "    x_mm: 200\n"
        "    y_mm: 3000\n"
    ))
    world = load_world(path)
    palette = (ColourRange("red", 170, 10), ColourRange("green", 40, 85))
    with pytest.raises(InputError) as exc:
        check_against_palette(world, palette, path)
    assert str(exc.value) == (
        f"{path}:3:13: marks[1].colour: colour 'gren' is not in the mission's palette "
        "(green, red); did you mean 'green'?"
    )
    check_against_palette(world.model_copy(update={"marks": world.marks[:1]}), palette)


# --- generated worlds -------------------------------------------------------------------------

ROUTE = ["red", "green", "red", "blue", "green", "red"]


def test_generate_world_is_deterministic() -> None:
    a = generate_world(ROUTE, seed=3, clearance_mm=300, conditions="randomised")
    b = generate_world(ROUTE, seed=3, clearance_mm=300, conditions="randomised")
    c = generate_world(ROUTE, seed=4, clearance_mm=300, conditions="randomised")
    assert a == b
    assert a != c
    assert [m.colour for m in a.marks] == ROUTE
    assert a.background.seed == 3


@pytest.mark.parametrize("seed", range(25))
def test_generated_course_is_feasible(seed: int) -> None:
    clearance, bypass = 300.0, 800.0
    camera = CameraConfig()
    world = generate_world(ROUTE, seed=seed, clearance_mm=clearance, radius_mm=100.0,
                           bypass_distance_mm=bypass, conditions="default")
    marks = world.marks
    assert all(m.radius_mm == 100.0 and m.yaw_deg == 0.0 for m in marks)
    lo, hi = w.FIRST_MARK_RANGE_MM
    assert lo <= marks[0].y_mm <= hi
    for a, b in itertools.pairwise(marks):
        assert w.SPACING_RANGE_MM[0] <= b.y_mm - a.y_mm <= w.SPACING_RANGE_MM[1]
    for m in marks:
        assert m.x_mm == 0 or (
            w.LATERAL_OFFSET_RANGE_MM[0] <= abs(m.x_mm) <= w.LATERAL_OFFSET_RANGE_MM[1])
    # The first mark is wholly in view from the start.
    seen = project_marks(world, world.robot.pose(), camera)
    first = [p for p in seen if p.index == 0]
    assert first and first[0].inside(camera)
    # From the end of each bypass (beside the mark at the clearance, on either side, heading
    # as when coming from the previous mark), the next mark is far enough to be re-acquired
    # and at most a short search turn outside the field of view.
    limit = camera.hfov_rad / 2 + math.radians(w.MAX_SEARCH_TURN_DEG)
    prev = (0.0, 0.0)
    for a, b in itertools.pairwise(marks):
        heading = math.atan2(a.y_mm - prev[1], a.x_mm - prev[0])
        for side in (1.0, -1.0):
            end = (a.x_mm - side * clearance * math.sin(heading),
                   a.y_mm + side * clearance * math.cos(heading))
            assert math.dist(end, b.xy) >= bypass + w.REACQUIRE_MARGIN_MM
            bearing = math.atan2(b.y_mm - end[1], b.x_mm - end[0]) - heading
            assert abs(bearing) <= limit
        prev = a.xy


def test_generated_offsets_mostly_alternate() -> None:
    pairs = alternating = 0
    for seed in range(40):
        marks = generate_world(ROUTE, seed=seed, clearance_mm=300).marks
        pairs += len(marks) - 1
        alternating += sum(a.x_mm * b.x_mm < 0 for a, b in itertools.pairwise(marks))
    assert alternating >= 0.6 * pairs


def test_known_sides_only_constrain_their_own_side() -> None:
    # Passing every mark on its left (robot to the west of each) is an easy course: the
    # offsets then always alternate.
    marks = generate_world(ROUTE, seed=5, clearance_mm=300, sides=["left"] * len(ROUTE)).marks
    assert all(a.x_mm * b.x_mm < 0 for a, b in itertools.pairwise(marks))


def test_randomised_conditions_stay_in_range() -> None:
    casts, gains, latencies, yaws, views = set(), [], set(), [], []
    for seed in range(60):
        world = generate_world(["red", "blue"], seed=seed, clearance_mm=300,
                               conditions="randomised")
        c = world.conditions
        casts.add(c.cast)
        gains.append(c.lighting_gain)
        latencies.add(c.latency_frames)
        assert 0.5 <= c.lighting_gain <= 1.5
        assert abs(c.wheel_mismatch) <= 0.05
        assert 0 <= c.wheel_slip <= w.WHEEL_SLIP_MAX
        assert w.NOISE_SIGMA_RANGE[0] <= c.noise_sigma <= w.NOISE_SIGMA_RANGE[1]
        assert w.BLUR_SIGMA_RANGE_PX[0] <= c.blur_sigma_px <= w.BLUR_SIGMA_RANGE_PX[1]
        first, second = world.marks
        yaws.append(first.yaw_deg)
        # The second mark is turned relative to the line of sight from where the robot looks for
        # it (beside the first mark), never edge-on: within 45° of facing it, plus the spread
        # of the two pass sides seen from 1.2-2 m.
        los = math.atan2(first.y_mm - second.y_mm, first.x_mm - second.x_mm)
        normal = math.radians(second.yaw_deg) - math.pi / 2  # (sin yaw, -cos yaw)
        view = math.degrees(abs(math.remainder(los - normal, 2 * math.pi)))
        views.append(view)
        assert view <= 45.0 + 15.0
    assert max(views) > 30.0
    assert {"warm", "cool"} <= casts
    assert latencies == {0, 1, 2}
    assert min(gains) < 0.7 and max(gains) > 1.3
    assert max(abs(y) for y in yaws) <= 45.0 and max(abs(y) for y in yaws) > 30.0


def test_generate_world_respects_a_long_bypass_distance() -> None:
    world = generate_world(["red", "green", "blue"], seed=1, clearance_mm=400,
                           bypass_distance_mm=1500, conditions="default")
    ys = [m.y_mm for m in world.marks]
    assert ys[0] >= 1500 + w.REACQUIRE_MARGIN_MM
    assert all(b - a >= 1500 + w.REACQUIRE_MARGIN_MM + 400 for a, b in itertools.pairwise(ys))


def test_generate_world_rejects_nonsense() -> None:
    with pytest.raises(ValueError):
        generate_world(["red"], seed=0, clearance_mm=0)
    with pytest.raises(ValueError):
        generate_world(["red", "blue"], seed=0, clearance_mm=300, sides=["left"])


# --- contacts ---------------------------------------------------------------------------------

R_ROBOT = w.CREATE_RADIUS_MM


def mark_at(angle_from_heading_deg: float, gap_mm: float, pose: Pose) -> World:
    """A world with one mark (radius 100) whose edge is ``gap_mm`` from the robot's rim
    (negative: overlapping), in the direction ``angle`` from the heading."""
    d = R_ROBOT + 100.0 + gap_mm
    a = pose.theta + math.radians(angle_from_heading_deg)
    return World(marks=(MarkSpec(colour="red", x_mm=pose.x + d * math.cos(a),
                                 y_mm=pose.y + d * math.sin(a), radius_mm=100.0),))


@pytest.mark.parametrize("theta", [NORTH, 0.3, -2.0])
def test_straight_ahead_presses_both_bumpers(theta: float) -> None:
    pose = Pose(100.0, -50.0, theta)
    found = contacts(mark_at(0.0, -2.0, pose), pose)
    assert len(found) == 1
    c = found[0]
    assert c.kind == "mark" and c.index == 0
    assert c.angle_rad == pytest.approx(0.0, abs=1e-9)
    assert c.depth_mm == pytest.approx(2.0)
    assert (c.x_mm, c.y_mm) == pytest.approx((pose.x + R_ROBOT * math.cos(theta),
                                              pose.y + R_ROBOT * math.sin(theta)))
    assert bumps(found) == w.Bumps(left=True, right=True)


@pytest.mark.parametrize(("angle", "expected"), [
    (45.0, (True, False)),
    (-45.0, (False, True)),
    (80.0, (True, False)),
    (9.0, (True, True)),
    (-11.0, (False, True)),
    (150.0, (False, False)),  # behind the bumper's arc
    (-179.0, (False, False)),
])
def test_bumper_side_follows_the_contact_angle(angle: float, expected: tuple[bool, bool]) -> None:
    pose = Pose(0.0, 0.0, NORTH)
    found = contacts(mark_at(angle, -1.0, pose), pose)
    assert len(found) == 1
    assert math.degrees(found[0].angle_rad) == pytest.approx(angle)
    b = bumps(found)
    assert (b.left, b.right) == expected


def test_no_contact_when_apart_and_touching_counts() -> None:
    pose = Pose(0.0, 0.0, NORTH)
    assert contacts(mark_at(30.0, 0.5, pose), pose) == []
    assert len(contacts(mark_at(30.0, 0.0, pose), pose)) == 1
    assert bumps([]) == w.Bumps(left=False, right=False)


def test_wall_and_box_contacts() -> None:
    world = World(
        walls=(Wall(x1_mm=-1000, y1_mm=500, x2_mm=1000, y2_mm=500),),
        boxes=(Box(x_mm=1000, y_mm=0, width_mm=400, depth_mm=400),),
    )
    near_wall = Pose(0.0, 500.0 - R_ROBOT + 10.0, NORTH)
    (c,) = contacts(world, near_wall)
    assert c.kind == "wall" and c.depth_mm == pytest.approx(10.0)
    assert bumps([c]) == w.Bumps(left=True, right=True)
    # The box's west face at x = 800; the robot faces north, so the box is on its right.
    beside_box = Pose(800.0 - R_ROBOT + 5.0, 0.0, NORTH)
    (c,) = contacts(world, beside_box)
    assert c.kind == "box" and c.index == 0
    assert math.degrees(c.angle_rad) == pytest.approx(-90.0)
    assert bumps([c]) == w.Bumps(left=False, right=True)
    inside = contacts(world, Pose(1000.0, 50.0, NORTH))
    assert [x.kind for x in inside] == ["box"] and inside[0].depth_mm > R_ROBOT


def test_push_out_separates_the_robot() -> None:
    pose = Pose(0.0, 0.0, NORTH)
    world = mark_at(20.0, -30.0, pose)
    moved = push_out(world, pose)
    assert contacts(world, moved) == [] or all(c.depth_mm < 1e-3 for c in contacts(world, moved))
    assert math.dist(moved.xy, world.marks[0].xy) == pytest.approx(R_ROBOT + 100.0, abs=1e-3)
    assert moved.theta == pose.theta


# --- pass measures ----------------------------------------------------------------------------


def line(x0: float, y0: float, x1: float, y1: float, n: int = 31) -> list[Pose]:
    th = math.atan2(y1 - y0, x1 - x0)
    return [Pose(x0 + (x1 - x0) * t, y0 + (y1 - y0) * t, th) for t in np.linspace(0, 1, n)]


def test_passed_on_straight_lines() -> None:
    mark = (0.0, 1500.0)
    assert passed_on(line(-300, 0, -300, 3000), mark) == "left"  # mark on the robot's right
    assert passed_on(line(300, 0, 300, 3000), mark) == "right"
    assert passed_on(line(-300, 3000, -300, 0), mark) == "right"  # driving south, west of it
    assert passed_on(line(-300, 0, -300, 1000), mark) is None  # never got there
    assert passed_on(line(-1500, 0, -1500, 3000), mark) is None  # too far to count as a pass
    assert passed_on(line(-1500, 0, -1500, 3000), mark, within_mm=2000) == "left"


def test_passed_on_a_curved_bypass_and_first_crossing_counts() -> None:
    mark = (200.0, 1500.0)
    # Swing round the mark's east side on a half circle (mark abeam all along: one pass), go on
    # north, then come back south along x = 700, east of it: a second pass, on its other side.
    arc = [(200.0 + 400.0 * math.sin(a), 1500.0 - 400.0 * math.cos(a))
           for a in np.linspace(0, math.pi, 40)]
    back = [(700.0, 2500.0 - k * 250.0) for k in range(11)]
    path = [(200.0, 900.0), *arc, (200.0, 2500.0), *back]
    crossings = pass_crossings(path, mark)
    assert [c.side for c in crossings] == ["right", "left"]
    assert crossings[0].lateral_mm == pytest.approx(400.0, abs=1.0)
    assert crossings[1].lateral_mm == pytest.approx(-500.0)
    assert passed_on(path, mark) == "right"
    assert min_clearance_mm(path, mark) == pytest.approx(400.0, abs=0.5)


def test_min_clearance_between_sparse_samples() -> None:
    mark = (0.0, 1500.0)
    assert min_clearance_mm([(-300.0, 0.0), (-300.0, 3000.0)], mark) == pytest.approx(300.0)
    assert min_clearance_mm(line(250, 0, 250, 3000, n=7), mark) == pytest.approx(250.0)
    assert min_clearance_mm(np.array([[0.0, 0.0]]), mark) == pytest.approx(1500.0)
    assert min_clearance_mm([], mark) == math.inf
    # A diagonal: the closest point is the foot of the perpendicular.
    assert min_clearance_mm([(0.0, 0.0), (3000.0, 3000.0)], (0.0, 1500.0)) == pytest.approx(
        1500.0 / math.sqrt(2))
