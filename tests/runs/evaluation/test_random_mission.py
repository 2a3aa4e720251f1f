"""The random-mission generator's palette is what the camera sees (issue 11): every colour is
read as itself over the whole randomised lighting range, and a near mark standing on a floor of
its own hue, as saturated as the room gets, is still found."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from marknav.cli.main import main
from marknav.planning.kinematics import Pose
from marknav.runs.evaluation.random_mission import PALETTE, random_mission
from marknav.sim import scenery
from marknav.sim.builtin_camera import CameraConfig, Renderer
from marknav.sim.world import (
    LIGHTING_GAIN_RANGE,
    Background,
    Conditions,
    MarkSpec,
    World,
    load_world,
)
from marknav.vision.detect import Detector
from marknav.vision.palette import ColourRange

GENERATOR_PALETTE = tuple(ColourRange(name, lo, hi, sat_min=sat)
                          for name, ((lo, hi), sat) in PALETTE.items())
CAMERA = CameraConfig()
AHEAD = Pose(0.0, 0.0, math.pi / 2.0)


def _found(world: World, pose: Pose, seed: int) -> list[tuple[str, float]]:
    """(colour, horizontal offset from the mark's expected column) of every detection."""
    image = Renderer(world, GENERATOR_PALETTE, CAMERA).render(pose, np.random.default_rng(seed))
    return [(m.colour, m.x) for m in Detector(GENERATOR_PALETTE).detect(image)]


@pytest.mark.slow
@pytest.mark.parametrize("colour", list(PALETTE))
def test_every_colour_is_read_as_itself_over_the_randomised_light(colour: str) -> None:
    # The corners of the randomised conditions: the dimmest and brightest light under each cast
    # (bright warm light clips orange's red channel and pushes its hue towards yellow), in the
    # noisiest image the evaluation draws.
    for gain in LIGHTING_GAIN_RANGE:
        for cast in ("none", "warm", "cool"):
            world = World(
                marks=(MarkSpec(colour=colour, x_mm=0.0, y_mm=2000.0 + CAMERA.forward_offset_mm,
                                radius_mm=100.0),),
                conditions=Conditions(lighting_gain=gain, cast=cast, noise_sigma=6.0),
                background=Background(seed=3))
            centre = [c for c, x in _found(world, AHEAD, seed=1) if abs(x - CAMERA.cx) < 8.0]
            assert centre == [colour], f"{colour} at gain {gain}, cast {cast}: read as {centre}"


@pytest.mark.parametrize(("colour", "floor", "room_seed"),
                         [("orange", "wood", 4), ("purple", "carpet", 8)])
def test_a_near_mark_on_a_floor_of_its_hue_is_found(colour: str, floor: str,
                                                    room_seed: int) -> None:
    # Random missions 4 and 29: a mark 1.1 m away, turned 55° from the line of sight, its lower
    # half against a floor of its own hue (room seed 4: wood of hue 17.7; 8: carpet of hue 147)
    # as saturated as randomised rooms get. With a saturation floor of 100 the floor joined the
    # mark in one blob and the search turned past the mark.
    _lo, sat_max = scenery.FLOOR_SATURATION_RANGE
    world = World(
        marks=(MarkSpec(colour=colour, x_mm=0.0, y_mm=1100.0 + CAMERA.forward_offset_mm,
                        yaw_deg=55.0, radius_mm=63.0),),
        conditions=Conditions(lighting_gain=0.7, noise_sigma=2.0, floor=floor,
                              floor_saturation=sat_max),
        background=Background(seed=room_seed))
    centre = [c for c, x in _found(world, AHEAD, seed=2) if abs(x - CAMERA.cx) < 10.0]
    assert centre == [colour]


def test_a_seed_gives_one_mission_and_its_files_replay_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    a, b = random_mission(17), random_mission(17)
    assert a.mission_doc == b.mission_doc and a.world_doc == b.world_doc
    assert random_mission(18).world_doc != a.world_doc
    cond = a.world.conditions
    palest = cond.mark_saturation - cond.mark_saturation_spread  # the palest printed mark
    for name, spec in a.mission_doc["marks"]["colours"].items():
        hue, full_paint_floor = PALETTE[name]
        assert tuple(spec["hue"]) == hue
        # the floor a user would calibrate for these printed marks
        assert spec["sat_min"] == round(full_paint_floor * min(1.0, palest))
    assert {c: spec.sat_min for c, spec in a.mission.marks.colours.items()} == {
        c: spec["sat_min"] for c, spec in a.mission_doc["marks"]["colours"].items()}
    out = tmp_path / "m"
    assert main(["random-mission", "--seed", "17", "--out", str(out)]) == 0
    assert f"replay: marknav run {out / 'mission.yaml'} --seed 17" in capsys.readouterr().out
    assert main(["validate", str(out / "mission.yaml")]) == 0  # its sim.world is world.yaml
    written = load_world(out / "world.yaml")
    assert written.marks == a.world.marks and written.course == a.world.course


def test_a_negative_seed_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["random-mission", "--seed", "-1", "--out", "x"]) == 2
    err = capsys.readouterr().err
    assert "--seed" in err and "≥ 0" in err and "Traceback" not in err
