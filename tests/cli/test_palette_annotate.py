"""``marknav palette --annotate DIR``: each picture with its marks outlined in their taught
colour, and the hue histogram of the colours with their ranges."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from marknav.cli.main import main
from marknav.vision.palette import ColourRange
from marknav.vision.palette_pictures import colour_bgr

SMARTIES = Path(__file__).resolve().parents[1] / "data" / "smarties.png"


def test_each_mark_is_outlined_in_its_taught_colour(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("matplotlib")
    out = tmp_path / "pictures"
    assert main(["palette", str(SMARTIES), "--colours", "red,orange,yellow,green,blue",
                 "--annotate", str(out), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert sorted(Path(p).name for p in result["pictures"]) == ["00-smarties.palette.png",
                                                                "hues.png"]
    picture = cv2.imread(str(out / "00-smarties.palette.png"))
    original = cv2.imread(str(SMARTIES))
    assert picture.shape == original.shape
    ranges = {c["name"]: ColourRange(c["name"], *c["hue"]) for c in result["colours"]}
    marks = result["images"][0]["marks"]
    assert len(marks) >= 10
    for mark in marks:
        want = np.array(colour_bgr(ranges[mark["colour"]]))
        # the outline: pixels on the mark's fitted circle that now have its colour
        ring = [(round(mark["x"] + mark["radius"] * math.cos(a)),
                 round(mark["y"] + mark["radius"] * math.sin(a)))
                for a in np.linspace(0, 2 * math.pi, 72, endpoint=False)]
        inside = [(x, y) for x, y in ring
                  if 0 <= x < picture.shape[1] and 0 <= y < picture.shape[0]]
        hits = sum(int(np.abs(picture[y, x].astype(int) - want).max() <= 40)
                   for x, y in inside)
        assert hits >= 0.5 * len(inside), (mark["colour"], hits, len(inside))
    assert (out / "hues.png").stat().st_size > 10_000


def test_annotate_without_matplotlib_is_refused_before_the_work(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    out = tmp_path / "pictures"
    assert main(["palette", str(SMARTIES), "--colours", "red,blue",
                 "--annotate", str(out)]) == 2
    assert "--annotate: needs matplotlib" in capsys.readouterr().err
    assert not out.exists()
