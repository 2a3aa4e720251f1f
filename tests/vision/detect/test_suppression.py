"""Suppression: the horizon band, one mark per object of a colour, largest first."""

from __future__ import annotations

import numpy as np
import pytest

from marknav.vision.detect.model import Mark
from marknav.vision.detect.scene import Scene
from marknav.vision.detect.suppression import SuppressConfig, centre_inside, suppress


def _mark(colour: str, x: float, y: float, r: float) -> Mark:
    return Mark(colour, x, y, r, (r, r), 0.0, "circle", 1.0)


def _run(marks: list[Mark], **config: float) -> list[tuple[str, float]]:
    scene = Scene(image=np.zeros((1, 1, 3), np.uint8), palette=(), marks=tuple(marks))
    return [(m.colour, m.radius) for m in suppress(scene, SuppressConfig(**config)).marks]


@pytest.mark.parametrize(("marks", "expected"), [
    ([_mark("red", 0, 0, 5), _mark("red", 100, 0, 20)], [("red", 20), ("red", 5)]),
    ([_mark("red", 0, 0, 20), _mark("red", 5, 0, 6)], [("red", 20)]),      # a piece of it
    ([_mark("red", 0, 0, 20), _mark("blue", 5, 0, 6)], [("red", 20)]),   # of any colour
    ([_mark("red", 0, 0, 10), _mark("red", 25, 0, 10)], [("red", 10), ("red", 10)]),
])
def test_one_mark_per_object(marks: list[Mark], expected: list[tuple[str, float]]) -> None:
    assert _run(marks) == expected


def test_horizon_band() -> None:
    marks = [_mark("red", 0, 240, 10), _mark("red", 100, 300, 10), _mark("red", 200, 262, 10)]
    assert len(_run(marks, horizon_row=240.0, horizon_tolerance_px=24.0)) == 2


def test_centre_inside_honours_the_angle() -> None:
    tall = Mark("red", 0, 0, 20, (20, 5), 90.0, "ellipse", 1.0)
    assert centre_inside(_mark("red", 0, 15, 3), tall)
    assert not centre_inside(_mark("red", 15, 0, 3), tall)
