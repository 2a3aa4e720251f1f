"""``marknav palette`` warns about two colours whose ranges meet with a margin a change of light
crosses: a red and an orange painted 7 hue units apart leave ~3.5 units each side of the split."""

from __future__ import annotations

import math
import re
from pathlib import Path

import cv2
import numpy as np
import pytest

from marknav.cli.main import main
from marknav.cli.palette import WARN_MARGIN_HUE
from marknav.planning.kinematics import Pose
from marknav.sim.builtin_camera import Renderer
from marknav.sim.world import Background, MarkSpec, World
from marknav.vision.palette import ColourRange

LAYOUT = [("red", -700, 2000, 0), ("orange", -250, 1400, 10), ("blue", 0, 2500, 20),
          ("orange", 300, 3200, 0), ("red", 500, 1800, -30)]


def _frames(tmp_path: Path, orange_hue: int) -> list[str]:
    """Two simulated rooms whose red is painted at hue 0 and orange at ``orange_hue``."""
    palette = (ColourRange("red", 178, 2), ColourRange("orange", orange_hue - 1, orange_hue + 1),
               ColourRange("blue", 95, 130))
    paths = []
    for seed in (5, 6):
        world = World(marks=tuple(MarkSpec(colour=c, x_mm=x, y_mm=y, yaw_deg=yaw)
                                  for c, x, y, yaw in LAYOUT),
                      background=Background(seed=seed, clutter=8))
        image = Renderer(world, palette).render(Pose(0.0, 0.0, math.pi / 2),
                                                np.random.default_rng(seed))
        paths.append(str(tmp_path / f"room{seed}-orange{orange_hue}.png"))
        cv2.imwrite(paths[-1], image)
    return paths


@pytest.mark.parametrize("orange_hue", [7, 8])
def test_a_margin_of_a_few_hue_units_is_warned_about(
        orange_hue: int, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["palette", *_frames(tmp_path, orange_hue), "--colours",
                 "red,orange,blue"]) == 0
    out = capsys.readouterr().out
    margins = re.search(r"red \| orange .* margins\s+([\d.]+) /\s+([\d.]+)", out)
    assert margins is not None, out
    smallest = min(float(margins[1]), float(margins[2]))
    assert 2.5 <= smallest < WARN_MARGIN_HUE, out  # the case of the warning
    warnings = [line for line in out.splitlines() if line.startswith("warning:")]
    assert any(w.startswith("warning: red and orange") and "a change of light" in w
               for w in warnings), out
    # blue, far from both, is not said to be close to anything
    assert not any("blue and" in w or "and blue" in w for w in warnings), out
