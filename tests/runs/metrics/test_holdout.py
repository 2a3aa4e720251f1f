"""The held-out split and the scoring of ``tools/perception_holdout.py``."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from marknav.runs.metrics.holdout import Frame, Truth, half, score
from marknav.vision.detect import Detector
from marknav.vision.palette import DEFAULT_PALETTE


def test_the_split_is_fixed_by_name_and_about_even() -> None:
    names = [f"photo-{k}.jpg" for k in range(400)]
    halves = [half("real", n) for n in names]
    assert halves == [half("real", n) for n in names]  # no state, no seed
    assert 160 < halves.count("held_out") < 240
    assert {half("real", "x.jpg"), half("composite", "x.jpg")} <= {"tuning", "held_out"}


def test_score_counts_found_marks_false_marks_and_the_range_error() -> None:
    image = np.full((240, 320, 3), 120, np.uint8)
    cv2.circle(image, (80, 120), 30, (0, 0, 230), -1, cv2.LINE_AA)  # the red mark
    cv2.circle(image, (240, 120), 20, (200, 60, 0), -1, cv2.LINE_AA)  # an unlabelled blue disc
    truth = Truth("red", 80.0, 120.0, 30.0, 30.0, 0.0)
    frames = [Frame("t", "a", image, DEFAULT_PALETTE, (truth,))]
    result = score(frames, lambda palette: Detector(palette).detect)
    assert result["recall"] == 1.0 and result["false_per_frame"] == 1.0
    assert result["range_err_p95"] < 0.03
    wrong = Truth("green", 80.0, 120.0, 30.0, 30.0, 0.0)
    missed = score([Frame("t", "a", image, DEFAULT_PALETTE, (wrong,), counts_false=False)],
                   lambda palette: Detector(palette).detect)
    assert missed["recall"] == 0.0 and missed["false_per_frame"] is None


def test_the_mujoco_corpus_has_truth_where_the_marks_are_drawn() -> None:
    """Frames MuJoCo renders, with truths from the shared pinhole projection: each truth's
    centre lies on paint of its colour (hue within the palette's range, saturated)."""
    from marknav.runs.metrics.holdout import _mujoco
    from marknav.sim.mujoco import gl

    gl.backend()  # the headless renderer, chosen before anything imports mujoco
    pytest.importorskip("mujoco")

    frames = _mujoco(3)
    assert len(frames) == 3 and all(f.corpus == "mujoco" for f in frames)
    palette = {c.name: c for c in frames[0].palette}
    checked = 0
    for f in frames:
        hsv = cv2.cvtColor(f.image, cv2.COLOR_BGR2HSV)
        for t in f.marks:
            if t.b < 4.0:
                continue  # edge-on: the centre pixel may be the rim
            h, s, _ = (int(v) for v in np.median(
                hsv[int(t.y) - 1:int(t.y) + 2, int(t.x) - 1:int(t.x) + 2].reshape(-1, 3), axis=0))
            assert palette[t.colour].contains(h) and s > 100, (f.name, t, h, s)
            checked += 1
    assert checked >= 2


@pytest.mark.parametrize("part", ["photometry (gain and light colour)", "suppression",
                                  "cut along colour edges"])
def test_the_pipeline_ablation_switches_one_part_off(part: str) -> None:
    from marknav.runs.metrics.holdout import ABLATIONS, ablated

    dim = np.full((240, 320, 3), 12, np.uint8)
    cv2.circle(dim, (160, 120), 25, (0, 0, 40), -1, cv2.LINE_AA)  # a red mark in a dim room
    found = ablated(DEFAULT_PALETTE)(dim)
    assert [m.colour for m in found] == ["red"]
    off = ablated(DEFAULT_PALETTE, ABLATIONS[part])(dim)
    # Without the exposure gain the mark is under its value floor; the other parts do not
    # change an isolated mark.
    assert [m.colour for m in off] == ([] if part.startswith("photometry") else ["red"])
