"""The detector on a real photograph: OpenCV's ``smarties.png`` (see tests/data/README.md).

14 sweets on white: red ×4, orange ×2, green ×3, blue ×3, dark brown ×2; a green and a brown
one are cut by the bottom edge; several touch. The truth below was measured once, by hand and
without the detector: for each sweet, a crop around its eyeballed centre was thresholded halfway
between the white background's chroma (max − min of B, G, R) and the sweet's core chroma
(darkness for the brown ones); the crack edge between that mask and its outside pixels was kept
only where the pixel 3 px further out is white background (not a neighbour, a shadow or the image
edge); a least-squares circle through it (points more than 1.5 px off dropped, refitted) gave the
centre and radius. Each fit was drawn on a 4× zoom of its crop and checked by eye. The fits' RMS
residuals are 0.2-0.9 px (the sweets are not perfect discs).
"""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt
import pytest

from marknav.vision.detect import Detector, Mark
from marknav.vision.palette import ColourRange

SMARTIES = Path(__file__).resolve().parents[1] / "data" / "smarties.png"

#: Measured circular mean hues: red sweets 179.2-179.8, orange 6.7-8.7, green 67-68,
#: blue 107-113; the palette splits red from orange between them.
PALETTE = (
    ColourRange("red", 160, 3),
    ColourRange("orange", 4, 25),
    ColourRange("green", 40, 85),
    ColourRange("blue", 95, 130),
)

#: The pipeline classifies pixel by pixel: an orange sweet's shaded side has red's hues (1-3),
#: so it splits into an orange piece with a bite out of it (no ellipse) and a red sliver.
HUE_SPLIT = pytest.mark.xfail(strict=True, reason="pipeline detector: a sweet whose shading "
                              "spans two adjacent palette hues is split pixel by pixel")

#: (colour, x, y, radius) in px, pixel centres at integers.
WHOLE = [
    ("red", 33.2, 228.3, 25.9),
    ("red", 98.6, 259.1, 27.1),
    ("red", 287.5, 213.2, 26.0),
    ("red", 219.3, 306.0, 28.0),
    ("orange", 205.0, 211.2, 26.5),
    ("orange", 134.2, 327.2, 27.2),
    ("green", 268.6, 117.0, 26.5),
    ("green", 386.9, 170.0, 26.7),
    ("blue", 377.1, 81.3, 26.8),
    ("blue", 347.1, 237.9, 26.8),
    ("blue", 294.0, 320.0, 27.6),
]
#: Cut by the bottom edge (only 22 % of its outline inside the image): it may be found or not.
CUT_GREEN = ("green", 6.4, 356.4, 28.1)
BROWN = [("brown", 151.7, 271.3, 27.0), ("brown", 77.4, 361.1, 24.6)]


def smarties() -> npt.NDArray[np.uint8]:
    image = cv2.imread(str(SMARTIES))
    assert image is not None and image.shape == (356, 413, 3)
    return np.asarray(image, dtype=np.uint8)


@pytest.fixture(scope="module")
def marks() -> list[Mark]:
    return Detector(PALETTE).detect(smarties())


def nearest(marks: list[Mark], x: float, y: float) -> Mark:
    return min(marks, key=lambda m: math.hypot(m.x - x, m.y - y))


@pytest.mark.parametrize(("colour", "x", "y", "radius"), [
    pytest.param(*w, marks=HUE_SPLIT) if w[0] == "orange" else w for w in WHOLE])
def test_every_whole_sweet_is_found_with_its_colour_centre_and_radius(
        marks: list[Mark], colour: str, x: float, y: float, radius: float) -> None:
    mark = nearest(marks, x, y)
    assert mark.colour == colour
    assert math.hypot(mark.x - x, mark.y - y) <= 3.0
    assert abs(mark.radius - radius) <= 2.0


@HUE_SPLIT
def test_nothing_else_is_reported(marks: list[Mark]) -> None:
    """No mark on the white background, none on the brown sweets (red hue, but dark), and one
    mark per sweet."""
    known = [*WHOLE, CUT_GREEN]
    for mark in marks:
        colour, x, y, _ = min(known, key=lambda s: math.hypot(mark.x - s[1], mark.y - s[2]))
        assert math.hypot(mark.x - x, mark.y - y) <= 3.0, mark
        assert mark.colour == colour, mark
    assert len(marks) == len({(round(m.x), round(m.y)) for m in marks}) <= len(known)
    for _, x, y, r in BROWN:
        assert all(math.hypot(m.x - x, m.y - y) > r for m in marks)


@HUE_SPLIT
def test_the_same_marks_from_a_jpeg_of_the_photograph() -> None:
    """Camera-like compression (quality 90) moves nothing by more than a pixel."""
    ok, jpeg = cv2.imencode(".jpg", smarties(), [cv2.IMWRITE_JPEG_QUALITY, 90])
    assert ok
    image = cv2.imdecode(jpeg, cv2.IMREAD_COLOR)
    found = Detector(PALETTE).detect(np.asarray(image, dtype=np.uint8))
    for colour, x, y, radius in WHOLE:
        mark = nearest(found, x, y)
        assert mark.colour == colour
        assert math.hypot(mark.x - x, mark.y - y) <= 3.0 and abs(mark.radius - radius) <= 2.0
