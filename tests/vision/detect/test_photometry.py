"""Photometry: the gain brings the frame's bright end to the target, the cast comes out."""

from __future__ import annotations

import numpy as np
import pytest

from marknav.vision.detect.photometry import PhotometryConfig, correction_table, photometry
from marknav.vision.detect.scene import Scene
from marknav.vision.palette import DEFAULT_PALETTE


def _frame(bgr: tuple[int, int, int], size: int = 16) -> np.ndarray:
    return np.full((size, size, 3), bgr, np.uint8)


@pytest.mark.parametrize(("grey", "expected"), [
    (25, 200),    # dim: 8× brings 25 to 200
    (50, 200),    # 4×
    (100, 200),   # 2×
    (230, 230),   # never darkened
    (10, 80),     # at most 8×
])
def test_gain_brings_bright_end_to_target(grey: int, expected: int) -> None:
    table = correction_table(_frame((grey, grey, grey)), PhotometryConfig())
    assert table[grey, 0].tolist() == [expected] * 3


@pytest.mark.parametrize(("cast", "balanced"), [
    ((75, 100, 125), True),     # a warm lamp on a grey room: greys come back grey
    ((125, 100, 75), True),     # a cool one
    ((40, 100, 160), False),    # beyond MAX_CAST: corrected only so far
])
def test_grey_world_takes_out_the_light_colour(cast: tuple[int, int, int],
                                               balanced: bool) -> None:
    frame = _frame(cast)
    out = photometry(Scene(image=frame, palette=DEFAULT_PALETTE), PhotometryConfig()).small
    assert out is not None
    spread = int(out[0, 0].max()) - int(out[0, 0].min())
    assert (spread <= 3) is balanced


def test_tint_limit_keeps_a_green_room_green() -> None:
    green_room = _frame((90, 140, 90))
    plain = correction_table(green_room, PhotometryConfig())[90:141:50, 0].astype(int)
    held = correction_table(green_room, PhotometryConfig(tint_limit=0.05))[90:141:50, 0]
    # Plain grey world pulls green down to the others; the limit leaves most of the excess.
    assert plain[1, 1] - plain[0, 0] < 10
    assert int(held[1, 1]) - int(held[0, 0]) > 40


def test_stage_fills_search_image_and_hsv_at_half_size() -> None:
    scene = photometry(Scene(image=_frame((50, 50, 50), 32), palette=DEFAULT_PALETTE),
                       PhotometryConfig())
    assert scene.small is not None and scene.hsv is not None and scene.lut is not None
    assert scene.small.shape == (16, 16, 3) and scene.hsv.shape == (16, 16, 3)
    assert scene.lut.shape == (256, 1, 3)
