"""Segmentation: blobs from masks; a mark touching a surface of its own hue cut off by its edge."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from marknav.vision.detect.scene import Blob, Ellipse, Scene
from marknav.vision.detect.segment import SegmentConfig, cut_along_edges, segment
from marknav.vision.detect.shape import ShapeConfig, screen
from marknav.vision.palette import ColourRange

RED = ColourRange("red", 175, 3)


def _whole(blob: Blob) -> Ellipse | None:
    return screen(blob, ShapeConfig())


def _scene(small: np.ndarray, mask: np.ndarray) -> Scene:
    return Scene(image=np.zeros((2, 2, 3), np.uint8), palette=(RED,), small=small,
                 masks=(mask,))


def test_cut_removes_edge_pixels_only() -> None:
    mask = np.full((5, 5), 255, np.uint8)
    edges = np.zeros((5, 5), np.uint8)
    edges[2, 2] = 255
    cut = cut_along_edges(mask, edges)
    assert (cut == 0).sum() == 5  # the edge pixel and its four neighbours


@pytest.mark.parametrize(("edge_step", "blobs"), [(40.0, 1), (0.0, 0)])
def test_mark_on_carpet_of_its_hue(edge_step: float, blobs: int) -> None:
    """A bright red disc standing on a darker red carpet: one blob in the mask; the grey step
    at the disc's outline separates it (a disc's blob), without the cut nothing is a disc."""
    small = np.full((60, 80, 3), (120, 120, 120), np.uint8)
    small[40:] = (20, 20, 120)                      # carpet: darker red
    cv2.circle(small, (40, 30), 12, (0, 0, 250), -1)  # the mark, touching the carpet
    mask = np.zeros((60, 80), np.uint8)
    mask[40:] = 255
    cv2.circle(mask, (40, 30), 12, 255, -1)
    out = segment(_scene(small, mask), SegmentConfig(edge_step=edge_step), _whole)
    discs = [b for b in out.blobs if b.ellipse is not None]
    assert len(discs) == blobs
    for b in discs:
        (x, y), (a, _), _ = b.ellipse  # type: ignore[misc]
        assert abs(x - 40) < 1.5 and abs(y - 29) < 2.5 and 9 < a < 13.5
        assert b.cut_px > 0


def test_isolated_disc_is_one_blob_uncut() -> None:
    small = np.full((40, 40, 3), 120, np.uint8)
    mask = np.zeros((40, 40), np.uint8)
    cv2.circle(mask, (20, 20), 8, 255, -1)
    out = segment(_scene(small, mask), SegmentConfig(), _whole)
    assert len(out.blobs) == 1 and out.blobs[0].ellipse is not None
    assert out.blobs[0].cut_px == 0


def test_noise_pixels_are_opened_away() -> None:
    small = np.full((40, 40, 3), 120, np.uint8)
    mask = np.zeros((40, 40), np.uint8)
    mask[::4, ::4] = 255
    assert segment(_scene(small, mask), SegmentConfig(), _whole).blobs == ()
