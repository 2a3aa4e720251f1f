"""The cost table of ``marknav bench vision``: the least OpenCV detector is a detector, and the
table has every baseline on every frame set (no assertion depends on this machine's speed)."""

from __future__ import annotations

import shutil
from pathlib import Path

import cv2
import numpy as np

from marknav.runs.benchmarks.cost import run_cost_bench, time_functions
from marknav.vision.detect.least import least_opencv_detector
from marknav.vision.palette import DEFAULT_PALETTE

REAL = Path(__file__).resolve().parents[2] / "data" / "real"


def test_the_least_detector_finds_discs_of_each_colour_including_wrapping_red() -> None:
    image = np.full((480, 640, 3), 110, np.uint8)
    cv2.circle(image, (150, 200), 30, (0, 0, 220), -1)  # red (hue 0)
    cv2.circle(image, (330, 240), 20, (200, 60, 0), -1)  # blue
    cv2.rectangle(image, (450, 100), (600, 130), (120, 120, 120), -1)  # grey: nothing
    found = least_opencv_detector(DEFAULT_PALETTE)(image)
    got = sorted((name, round(x), round(y), round(a)) for name, x, y, a, _b in found)
    assert [g[0] for g in got] == ["blue", "red"]
    assert abs(got[1][1] - 150) <= 2 and abs(got[1][2] - 200) <= 2 and abs(got[1][3] - 30) <= 2


def test_time_functions_gives_one_least_time_per_frame_and_function() -> None:
    calls: list[str] = []
    frames = [np.zeros((8, 8, 3), np.uint8)] * 3
    times = time_functions({"a": lambda im: calls.append("a"), "b": lambda im: calls.append("b")},
                           frames, repeats=2)
    assert [len(v) for v in times.values()] == [3, 3]
    assert calls.count("a") == calls.count("b") == 3 * (1 + 2)


def test_the_cost_table_has_every_baseline_on_every_set(tmp_path: Path) -> None:
    for name in ("board.jpg", "coffee.jpg"):
        shutil.copy(REAL / name, tmp_path / name)
    result = run_cost_bench(synthetic=2, sim=2, photos=tmp_path, repeats=1)
    for key in ("synthetic", "real_640", "simulator"):
        row = result[key]
        assert row["frames"] == 2
        for fn in ("detector", "least", "hough", "hsv"):
            assert 0 < row[f"{fn}_ms"]["p50"] <= row[f"{fn}_ms"]["p95"]
        for base in ("least", "hough", "hsv"):
            assert row[f"detector_over_{base}"]["p50"] > 0
    assert result["real_640"]["sizes"] == ["640x427", "640x480"]  # long side at 640
    assert result["synthetic"]["sizes"] == result["simulator"]["sizes"] == ["640x480"]
