"""Colour classification: each palette colour's HSV box, floors relative to the palette's."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from marknav.vision.detect.classify import ClassifyConfig, classify, floors, hue_table
from marknav.vision.detect.scene import Scene
from marknav.vision.palette import ColourRange

RED = ColourRange("red", 175, 3, sat_min=100, val_min=50)
GREEN = ColourRange("green", 40, 85, sat_min=100, val_min=50)


def _hsv_pixel(h: int, s: int, v: int) -> np.ndarray:
    return np.array([[[h, s, v]]], np.uint8)


@pytest.mark.parametrize(("hsv", "red", "green"), [
    ((179, 255, 200), True, False),   # saturated red
    ((1, 200, 200), True, False),     # red past the wrap
    ((5, 200, 200), True, False),     # inside the hue margin (3 + 2)
    ((6, 200, 200), False, False),    # beyond it: orange
    ((179, 75, 200), True, False),    # pale: 0.7 of the floor of 100 is 70
    ((179, 65, 200), False, False),   # paler: grey
    ((179, 255, 45), False, False),   # under the value floor: shadow
    ((60, 255, 200), False, True),
])
def test_pixel_classes(hsv: tuple[int, int, int], red: bool, green: bool) -> None:
    scene = Scene(image=np.zeros((2, 2, 3), np.uint8), palette=(RED, GREEN),
                  hsv=_hsv_pixel(*hsv))
    masks = classify(scene, ClassifyConfig()).masks
    assert [bool(m[0, 0]) for m in masks] == [red, green]


ORANGE = ColourRange("orange", 6, 20)


@pytest.mark.parametrize(("hue", "colour"), [
    (179, 1), (0, 1), (3, 1), (174, 1),  # red, past the wrap, within its margin
    (4, 1), (5, 2),                       # between red and orange: the nearer
    (6, 2), (22, 2), (23, 0),             # orange and its margin
    (60, 3), (38, 3), (37, 0),
])
def test_each_hue_has_one_colour(hue: int, colour: int) -> None:
    assert hue_table((RED, ORANGE, GREEN), 2)[hue] == colour


def test_floors_scale_the_palettes_saturation() -> None:
    assert floors(GREEN, ClassifyConfig(sat_share=1.0)) == (100, 50)
    assert floors(GREEN, ClassifyConfig()) == (70, 50)


def test_masks_match_opencv_hsv_of_a_painted_frame() -> None:
    frame = np.zeros((4, 8, 3), np.uint8)
    frame[:, :4] = (0, 0, 220)
    frame[:, 4:] = (0, 200, 0)
    scene = Scene(image=frame, palette=(RED, GREEN), hsv=cv2.cvtColor(frame, cv2.COLOR_BGR2HSV))
    red, green = classify(scene, ClassifyConfig()).masks
    assert red[:, :4].all() and not red[:, 4:].any()
    assert green[:, 4:].all() and not green[:, :4].any()
