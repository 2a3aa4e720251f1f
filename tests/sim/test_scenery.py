"""Harder rooms in the simulator (``marknav.sim.scenery``): floors, photo walls, a dominant
colour, near-colour distractors and thin poles, and the randomised worlds that draw them."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from marknav.planning.kinematics import Pose
from marknav.sim.builtin_camera import CameraConfig, Renderer
from marknav.sim.scenery import PALETTE_MARGIN, PHOTOS, near_hues, off_palette_hue, random_room
from marknav.sim.world import (
    Conditions,
    MarkSpec,
    World,
    generate_world,
    random_conditions,
    random_realism,
)
from marknav.vision.detect import Detector
from marknav.vision.palette import ColourRange

PALETTE = (ColourRange("red", 170, 10), ColourRange("green", 40, 85),
           ColourRange("blue", 95, 130))
AHEAD = Pose(0.0, 0.0, math.pi / 2)


def _frame(conditions: Conditions, marks: tuple[MarkSpec, ...] = ()) -> np.ndarray:
    world = World(marks=marks, conditions=conditions)
    return Renderer(world, PALETTE, CameraConfig()).render(AHEAD, None)


def test_a_wood_floor_is_as_saturated_as_asked_and_the_wall_is_not() -> None:
    image = _frame(Conditions(floor="wood", floor_saturation=150.0, noise_sigma=0.0))
    hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)
    floor_sat = float(np.median(hsv[400:, :, 1]))
    wall_sat = float(np.median(hsv[:150, :, 1]))
    assert 120.0 <= floor_sat <= 175.0, floor_sat
    assert wall_sat < 60.0
    assert 8 <= float(np.median(hsv[400:, :, 0])) <= 24  # a wood hue


def test_a_photo_wall_comes_from_the_packaged_photographs() -> None:
    assert len(list(PHOTOS.glob("*.jpg"))) >= 3
    plain = _frame(Conditions(noise_sigma=0.0))
    photo = _frame(Conditions(wall="photo", noise_sigma=0.0))
    assert not np.array_equal(plain[:200], photo[:200])
    assert np.array_equal(plain[300:], photo[300:])  # the floor is unchanged


def test_a_dominant_hue_tints_the_wall() -> None:
    image = _frame(Conditions(wall_hue=150.0, noise_sigma=0.0))
    hsv = cv2.cvtColor(image[:150], cv2.COLOR_BGR2HSV)
    assert abs(float(np.median(hsv[:, :, 0])) - 150.0) <= 4.0
    assert float(np.median(hsv[:, :, 1])) >= 50.0


def test_a_tint_of_a_mark_colour_moves_just_past_its_range() -> None:
    image = _frame(Conditions(wall_hue=60.0, noise_sigma=0.0))  # green's range is 40..85
    hue = float(np.median(cv2.cvtColor(image[:150], cv2.COLOR_BGR2HSV)[:, :, 0]))
    assert 30.0 <= hue < 40.0 - PALETTE_MARGIN + 1.0 or 85.0 + PALETTE_MARGIN - 1.0 < hue <= 95.0
    assert off_palette_hue(101.0, [(c.hue_lo, c.hue_hi) for c in PALETTE]) == 90.5
    assert off_palette_hue(150.0, [(c.hue_lo, c.hue_hi) for c in PALETTE]) == 150.0


def test_a_photo_wall_holds_no_mark_coloured_surface() -> None:
    image = _frame(Conditions(wall="photo", noise_sigma=0.0))
    hsv = cv2.cvtColor(image[:200], cv2.COLOR_BGR2HSV)
    saturated = hsv[:, :, 1] >= 100  # the detector's mask floor
    for colour in PALETTE:
        inside = np.vectorize(colour.contains)(hsv[:, :, 0])
        assert np.count_nonzero(saturated & inside) < 0.001 * saturated.size, colour.name
    assert np.count_nonzero(hsv[:, :, 1] >= 60) > 0  # the photograph keeps its other colours


def test_distractors_have_near_colours_and_are_not_marks() -> None:
    hues = near_hues([(c.hue_lo, c.hue_hi) for c in PALETTE])
    assert hues and all(not c.contains(h) and c.distance(h) >= 8 for h in hues for c in PALETTE)
    found = 0
    for seed in range(4):
        world = World(conditions=Conditions(distractors=30, noise_sigma=1.0))
        world = world.model_copy(update={"background": world.background.model_copy(
            update={"seed": seed})})
        image = Renderer(world, PALETTE, CameraConfig()).render(AHEAD, None)
        hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)
        assert np.count_nonzero(hsv[:, :, 1] > 200) > 0 or seed > 0  # something was drawn
        found += len(Detector(PALETTE).detect(image))
    assert found == 0


@pytest.mark.slow
def test_a_pole_hides_a_stripe_of_a_mark_and_the_mark_is_still_found() -> None:
    mark = (MarkSpec(colour="green", x_mm=0.0, y_mm=1200.0, radius_mm=100.0),)
    clear = _frame(Conditions(noise_sigma=0.0), mark)
    for seed in range(40):  # a world whose pole crosses the middle of the frame
        world = World(marks=mark, conditions=Conditions(occluders=8, noise_sigma=0.0))
        world = world.model_copy(update={"background": world.background.model_copy(
            update={"seed": seed})})
        image = Renderer(world, PALETTE, CameraConfig()).render(AHEAD, None)
        changed = np.flatnonzero(np.any(image[239] != clear[239], axis=1))
        if len(changed) and np.any(np.abs(changed - 319.5) < 40):
            break
    else:
        raise AssertionError("no pole crossed the mark in 40 worlds")
    found = Detector(PALETTE).detect(image)
    assert [m.colour for m in found] == ["green"]
    expected = 590.0 * 100.0 / 1200.0
    assert abs(found[0].radius - expected) <= 0.05 * expected


def test_randomised_worlds_draw_rooms_on_their_own_stream() -> None:
    rooms = [random_room(seed) for seed in range(40)]
    assert rooms[3] == random_room(3)
    assert {r["floor"] for r in rooms} == {"plain", "wood", "carpet"}
    assert any(r["wall"] == "photo" for r in rooms) and any(r["wall_hue"] for r in rooms)
    assert max(r["floor_saturation"] for r in rooms) <= 160.0
    assert any(r["occluders"] for r in rooms) and any(r["distractors"] for r in rooms)
    world = generate_world(["red", "green"], seed=5, clearance_mm=300, conditions="randomised")
    assert world.conditions.model_dump(include=set(random_room(5))) == random_room(5)
    # The other conditions are drawn as before (the room, like the lens and the realism
    # conditions, has its own stream).
    before = random_conditions(np.random.default_rng([5, 0x5EED]))
    own_streams = {*random_room(5), "lens", *random_realism(np.random.default_rng(0))}
    assert world.conditions.model_dump(exclude=own_streams) == \
        before.model_dump(exclude=own_streams)
