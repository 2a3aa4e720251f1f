"""``marknav palette``: colours taught from the real photographs in tests/data (see its README:
OpenCV's ``smarties.png`` and scikit-image's ``retina``) and from frames of the built-in
simulator, with marks at full and at half saturation."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt
import pytest
import yaml

from marknav.cli.main import main
from marknav.missions.schema import load_mission
from marknav.planning.kinematics import Pose
from marknav.sim.builtin_camera import Renderer
from marknav.sim.world import Background, Conditions, MarkSpec, World
from marknav.vision.detect import Detector
from marknav.vision.palette import ColourRange, Palette
from marknav.vision.palette_teach import (
    ColourRequest,
    cluster_marks,
    find_round_marks,
    parse_colours,
    propose_palette,
)

DATA = Path(__file__).resolve().parents[1] / "data"
SMARTIES = DATA / "smarties.png"
RETINA = DATA / "real" / "retina.jpg"
SLALOM = Path(__file__).resolve().parents[2] / "missions" / "slalom.yaml"
LABELS = json.loads((DATA / "labels.json").read_text())["images"]

Image = npt.NDArray[np.uint8]


def _teach(capsys: pytest.CaptureFixture[str], *argv: str) -> dict[str, Any]:
    assert main(["palette", *argv, "--json"]) == 0
    out: dict[str, Any] = json.loads(capsys.readouterr().out)
    return out


def _palette(result: dict[str, Any]) -> Palette:
    return tuple(ColourRange(c["name"], c["hue"][0], c["hue"][1], sat_min=c["sat_min"],
                             val_min=c["val_min"]) for c in result["colours"])


def _right_colour(marks: Any, truth: list[tuple[str, float, float, float]]) -> int:
    """How many true marks have a found/detected mark of their colour within a third of
    their radius of their centre."""
    return sum(any(m_colour(m) == colour and math.hypot(m_x(m) - x, m_y(m) - y) < r / 3
                   for m in marks) for colour, x, y, r in truth)


def m_colour(m: Any) -> str:
    return str(m["colour"] if isinstance(m, dict) else m.colour)


def m_x(m: Any) -> float:
    return float(m["x"] if isinstance(m, dict) else m.x)


def m_y(m: Any) -> float:
    return float(m["y"] if isinstance(m, dict) else m.y)


def _labelled(name: str) -> list[tuple[str, float, float, float]]:
    return [(m["colour"], m["x"], m["y"], m["radius"]) for m in LABELS[name]["marks"]]


# --- real photographs --------------------------------------------------------------------------

@pytest.mark.xfail(strict=True, reason="pipeline detector: a sweet whose shading spans two "
                   "adjacent palette hues is split pixel by pixel")
def test_smarties_taught_palette_finds_every_sweet_with_its_colour(
        capsys: pytest.CaptureFixture[str]) -> None:
    truth = _labelled("smarties.png")
    assert len(truth) == 11
    result = _teach(capsys, str(SMARTIES), "--colours", "red,orange,green,blue")
    found = result["images"][0]["marks"]
    # every labelled sweet found and named right, nothing else (brown and cut ones are not)
    assert len(found) == 11 and _right_colour(found, truth) == 11
    palette = _palette(result)
    # the robot's detector with the proposed palette: every sweet, with its colour
    detected = Detector(palette).detect(cv2.imread(str(SMARTIES)))
    assert _right_colour(detected, truth) == 11
    assert result["detector"]["right"] == 11 and result["detector"]["wrong"] == 0
    # red wraps; red/orange split between the red sweets' hues (179.2-179.8) and the orange
    # ones' (6.6-8.7): the margins say how much room the light has
    ranges = {c.name: c for c in palette}
    assert ranges["red"].wraps and ranges["red"].contains(179.5)
    assert ranges["orange"].contains(7.6) and not ranges["red"].contains(6.6)
    red_orange = next(g for g in result["gaps"] if {g["below"], g["above"]} == {"red", "orange"})
    assert red_orange["boundary"] is not None
    assert 2.0 < red_orange["margin_below"] < 5.0 and 2.0 < red_orange["margin_above"] < 5.0


def test_the_block_with_sides_pastes_into_a_mission(capsys: pytest.CaptureFixture[str],
                                                     tmp_path: Path) -> None:
    result = _teach(capsys, str(SMARTIES), "--colours",
                    "red:left,orange:right,green:right,blue:left")
    block = yaml.safe_load(result["yaml"])["marks"]["colours"]
    assert block["orange"]["side"] == "right"
    mission = yaml.safe_load(SLALOM.read_text())
    mission["marks"]["colours"] = block
    path = tmp_path / "taught.yaml"
    path.write_text(yaml.safe_dump(mission, sort_keys=False))
    loaded = load_mission(str(path))  # the schema's own checks: no overlap, valid hues
    assert [c.name for c in loaded.palette()] == ["red", "orange", "green", "blue"]


def test_retina_disc_taught_as_one_orange_mark(capsys: pytest.CaptureFixture[str]) -> None:
    truth = _labelled("real/retina.jpg")
    result = _teach(capsys, str(RETINA), "--colours", "orange")
    found = result["images"][0]["marks"]
    assert len(found) == 1 and _right_colour(found, truth) == 1
    assert abs(found[0]["radius"] - truth[0][3]) < 0.05 * truth[0][3]
    assert result["detector"]["right"] == 1


def test_no_round_mark_in_photos_without_any() -> None:
    for name in ("real/brick.jpg", "real/building.jpg", "real/coins.jpg"):
        assert find_round_marks(cv2.imread(str(DATA / name))) == []


# --- frames of the simulator --------------------------------------------------------------------

SIM_PALETTE = (ColourRange("red", 170, 10), ColourRange("green", 40, 85),
               ColourRange("blue", 95, 130))
#: (colour, x_mm, y_mm, yaw_deg): none hides another from the start pose.
LAYOUT = [("red", -700, 2000, 0), ("blue", -250, 1400, 10), ("green", 0, 2500, 20),
          ("red", 300, 3200, 0), ("blue", 500, 1800, -30), ("green", 1000, 2500, 0)]


def _desaturated(bgr: tuple[float, float, float], share: float) -> tuple[float, float, float]:
    hsv = cv2.cvtColor(np.array([[bgr]], np.uint8), cv2.COLOR_BGR2HSV)[0, 0].astype(float)
    hsv[1] *= share
    out = cv2.cvtColor(np.array([[np.round(hsv)]], np.uint8), cv2.COLOR_HSV2BGR)[0, 0]
    return float(out[0]), float(out[1]), float(out[2])


def sim_frame(seed: int, *, saturation: float = 1.0, palette: Palette = SIM_PALETTE,
              layout: list[tuple[str, int, int, int]] = LAYOUT,
              conditions: Conditions | None = None) -> tuple[Image, list[
                  tuple[str, float, float, float]]]:
    """One frame from the start pose and the marks' true (colour, u, v, radius px). Marks are
    painted at ``saturation`` times full saturation (printed marks are paler than the
    simulator's), everything else as the simulator renders it."""
    world = World(marks=tuple(MarkSpec(colour=c, x_mm=x, y_mm=y, yaw_deg=yaw)
                              for c, x, y, yaw in layout),
                  conditions=conditions or Conditions(),
                  background=Background(seed=seed, clutter=8))
    renderer = Renderer(world, palette)
    if saturation != 1.0:
        renderer._colours = [_desaturated(c, saturation) for c in renderer._colours]
    pose = Pose(0.0, 0.0, math.pi / 2)
    image = renderer.render(pose, np.random.default_rng(seed))
    f = renderer.config.focal_px
    truth = [(world.marks[p.index].colour, p.u, p.v, f * 100.0 / p.depth_mm)
             for p in renderer.project(pose)]
    assert len(truth) == len(layout)
    return image, truth


@pytest.fixture(scope="module")
def sim_frames(tmp_path_factory: pytest.TempPathFactory) -> list[tuple[Path, list[Any]]]:
    """Three rooms, each at full and at half saturation, one under a warm light."""
    folder = tmp_path_factory.mktemp("sim-frames")
    out = []
    for seed, cond in ((5, Conditions()), (6, Conditions(cast="warm")),
                       (7, Conditions(floor="wood"))):
        for saturation in (1.0, 0.5):
            image, truth = sim_frame(seed, saturation=saturation, conditions=cond)
            path = folder / f"room{seed}-sat{saturation}.png"
            cv2.imwrite(str(path), image)
            out.append((path, truth))
    return out


def test_sim_frames_taught_palette_finds_every_mark_with_its_colour(
        capsys: pytest.CaptureFixture[str], sim_frames: list[tuple[Path, list[Any]]]) -> None:
    result = _teach(capsys, *(str(p) for p, _ in sim_frames), "--colours", "red,green,blue")
    # no two colours too close (a blue poster in one room may be named: it has blue's hue)
    assert not [w for w in result["warnings"] if "hue units apart" in w]
    detector = Detector(_palette(result))
    for (path, truth), entry in zip(sim_frames, result["images"], strict=True):
        assert len(entry["marks"]) == 6 and _right_colour(entry["marks"], truth) == 6, path
        assert _right_colour(detector.detect(cv2.imread(str(path))), truth) == 6, path
    assert result["detector"]["right"] == result["detector"]["marks"] == 36
    # the half-saturation marks (median S ≈ 128, less under the warm light) lower the
    # saturation floors below the default 100
    assert all(40 <= c["sat_min"] <= 85 for c in result["colours"])


def test_two_colours_chosen_to_overlap_are_warned_about(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    # red painted at hue 0, orange at hue 3: a change of light swaps them
    palette = (ColourRange("red", 178, 2), ColourRange("orange", 2, 4),
               ColourRange("blue", 95, 130))
    layout = [("red", -700, 2000, 0), ("orange", -250, 1400, 10), ("blue", 0, 2500, 20),
              ("orange", 300, 3200, 0), ("red", 500, 1800, -30)]
    paths = []
    for seed in (5, 6):
        image, _truth = sim_frame(seed, palette=palette, layout=layout)
        paths.append(tmp_path / f"close{seed}.png")
        cv2.imwrite(str(paths[-1]), image)
    assert main(["palette", *map(str, paths), "--colours", "red,orange,blue"]) == 0
    out = capsys.readouterr().out
    warning = next(line for line in out.splitlines() if line.startswith("warning:"))
    assert "red and orange" in warning and "hue units apart" in warning
    # the far colour gets no warning
    assert "blue" not in warning and sum(line.startswith("warning:")
                                         for line in out.splitlines()) == 1


def test_frames_from_a_camera_source(capsys: pytest.CaptureFixture[str],
                                     sim_frames: list[tuple[Path, list[Any]]]) -> None:
    folder = sim_frames[0][0].parent
    result = _teach(capsys, "--camera", str(folder), "--frames", "3", "--interval", "0",
                    "--colours", "red,green,blue")
    assert len(result["images"]) == 3
    assert all(len(e["marks"]) == 6 for e in result["images"])


# --- --check MISSION ----------------------------------------------------------------------------

def test_check_reports_how_a_mission_separates_the_marks(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    # slalom's red (170..10) takes the orange sweets (hues 6.6-8.5) as red: separated
    result = _teach(capsys, str(SMARTIES), "--check", str(SLALOM))
    by = {c["name"]: c for c in result["check"]["colours"]}
    assert (by["red"]["marks"], by["green"]["marks"], by["blue"]["marks"]) == (6, 2, 3)
    assert all(c["in_other"] == c["in_none"] == 0 for c in by.values())
    assert result["check"]["separated"] and 1.0 < by["red"]["min_margin"] < 2.0
    # a red that ends at 5 leaves the orange sweets in no colour: exit 1, the count said
    text = SLALOM.read_text().replace("red:   {hue: [170, 10]", "red:   {hue: [170, 5]")
    assert text != SLALOM.read_text()
    narrow = tmp_path / "narrow.yaml"
    narrow.write_text(text)
    assert main(["palette", str(SMARTIES), "--check", str(narrow)]) == 1
    captured = capsys.readouterr()
    red = next(line for line in captured.out.splitlines() if line.strip().startswith("red"))
    assert "in none   2" in red
    assert "does not separate the marks found" in captured.err


# --- the library's pieces and bad input ---------------------------------------------------------

def test_grouping_is_circular() -> None:
    labels = cluster_marks([178.0, 1.0, 2.5, 60.0, 61.0, 179.5], 2)
    assert labels[0] == labels[1] == labels[2] == labels[5] != labels[3] == labels[4]


def test_parse_colours() -> None:
    assert parse_colours("red,teal=85:right") == [ColourRequest("red", 0.0),
                                                  ColourRequest("teal", 85.0, "right")]
    for bad in ("brown", "red,red", "red=200", "red:up", ""):
        with pytest.raises(ValueError):
            parse_colours(bad)


def test_names_follow_hues_not_the_order_given() -> None:
    image, _ = sim_frame(5)
    marks = find_round_marks(image)
    proposal = propose_palette(marks, parse_colours("blue,red,green"))
    by = {c.name: c.range() for c in proposal.colours}
    assert by["red"].contains(0.0) and by["green"].contains(62.5) and by["blue"].contains(112.5)


def test_bad_input_exits_2_naming_it(capsys: pytest.CaptureFixture[str],
                                     tmp_path: Path) -> None:
    junk = tmp_path / "junk.png"
    junk.write_text("not a PNG")
    cases = [
        ([str(SMARTIES), str(tmp_path / "missing.png"), "--colours", "red"], "missing.png"),
        ([str(junk), "--colours", "red"], f"{junk}: not an image"),
        ([str(SMARTIES), "--colours", "red,brown"], "'brown' is not a colour name"),
        ([str(SMARTIES)], "--colours"),
        ([str(DATA / "real" / "brick.jpg"), "--colours", "red,blue"],
         "found 0 round saturated marks but 2 colours"),
        (["--camera", str(tmp_path / "nowhere"), "--colours", "red"], "nowhere"),
    ]
    for argv, message in cases:
        assert main(["palette", *argv]) == 2, argv
        err = capsys.readouterr().err
        assert message in err and "Traceback" not in err, (argv, err)


@pytest.mark.slow
def test_held_out_rooms_random_layouts_and_light() -> None:
    """20 simulator rooms never looked at while the finder was built (seeds 200-219): random
    layouts (two marks of each colour, 1.5-3.8 m, yaw ±40°), light gain 0.7-1.3, no/warm/cool
    cast, noise σ 1-5, blur σ 0-1 px, plain/wood/carpet floors, every other room's marks at half
    saturation. Measured: the finder 120/120 marks with their colour, none extra; the detector
    with the taught palette 116/120 (it misses two half-saturated blue marks in each of the two
    cool rooms with a blue-violet carpet, and the proposal warns that other surfaces share
    blue's hues)."""
    from marknav.vision.palette_teach import scene_hues

    rng = np.random.default_rng(2027)
    frames = []
    for seed in range(200, 220):
        cond = Conditions(cast=("none", "warm", "cool")[seed % 3],
                          lighting_gain=float(rng.uniform(0.7, 1.3)),
                          noise_sigma=float(rng.uniform(1, 5)),
                          floor=("plain", "wood", "carpet")[seed % 3 if seed % 2 else 0],
                          blur_sigma_px=float(rng.uniform(0.0, 1.0)))
        colours = ["red", "red", "green", "green", "blue", "blue"]
        rng.shuffle(colours)
        azimuths = np.linspace(-24, 24, 6) + rng.uniform(-0.5, 0.5, 6)
        layout = []
        for colour, az in zip(colours, azimuths, strict=True):
            d = rng.uniform(1500, 3800)
            layout.append((colour, int(d * math.sin(math.radians(az))),
                           int(d * math.cos(math.radians(az))), int(rng.uniform(-40, 40))))
        image, truth = sim_frame(seed, saturation=(1.0, 0.5)[seed % 2], layout=layout,
                                 conditions=cond)
        frames.append((image, truth, find_round_marks(image)))
    marks = [m for _, _, ms in frames for m in ms]
    clutter = np.mean([scene_hues(img, ms) for img, _, ms in frames], axis=0)
    proposal = propose_palette(marks, parse_colours("red,green,blue"), clutter=clutter)
    detector = Detector(proposal.palette())
    labels = iter(proposal.labels)
    found = detected = extra = 0
    for image, truth, ms in frames:
        named = [{"colour": next(labels), "x": m.x, "y": m.y} for m in ms]
        right = _right_colour(named, truth)
        found += right
        extra += len(ms) - right
        detected += _right_colour(detector.detect(image), truth)
    assert (found, extra) == (120, 0)
    assert detected >= 116
