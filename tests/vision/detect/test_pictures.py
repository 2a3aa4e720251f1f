"""The detector page's stage pictures: drawn from the pipeline, and the drawn scene's marks."""

from __future__ import annotations

import cv2
import numpy as np

from marknav.vision.detect.pictures import demo_scene, stage_pictures
from marknav.vision.detect.pipeline import Detector


def test_each_stage_gives_a_half_size_png() -> None:
    pictures = stage_pictures()
    assert list(pictures) == ["frame", "photometry", "classify", "segment", "marks"]
    for png in pictures.values():
        image = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR)
        assert image.shape == (240, 320, 3)


def test_the_drawn_scene_shows_what_each_stage_is_for() -> None:
    """The red mark on its carpet, the pale green one and the blue one behind a pole are found;
    the yellow bar and the faint orange blob are not."""
    marks = Detector().detect(demo_scene())
    assert sorted((m.colour, round(m.x / 10), round(m.y / 10)) for m in marks) == [
        ("blue", 47, 24), ("green", 30, 24), ("red", 12, 26)]
