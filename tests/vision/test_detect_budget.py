"""The detector's reading budget (``DetectorConfig.max_readings``): a crowded frame stops after
the budget's blob readings, the largest blobs first, and says so; frames within it are read
whole. And suppression's shortcut for a crowded frame's far-apart marks."""

from __future__ import annotations

import logging
import math
from typing import Any

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from marknav.runs.benchmarks.crowded import crowded_frames, run_crowded_bench
from marknav.sim.synthetic.scene import SceneSpec, render_scene
from marknav.vision.detect import Detector, DetectorConfig, Mark, suppress
from marknav.vision.palette import DEFAULT_PALETTE


def _spy(detector: Detector) -> list[bool]:
    """Every budget decision the detector makes on its frames: True when a reading was made."""
    decisions: list[bool] = []
    original = detector._reading

    def reading() -> bool:
        decisions.append(original())
        return decisions[-1]

    detector._reading = reading  # type: ignore[method-assign]
    return decisions


def test_a_crowded_frame_stops_after_the_budget_and_says_so(
        caplog: pytest.LogCaptureFixture) -> None:
    mosaic = crowded_frames()["mosaic_8px_640"]
    detector = Detector(DEFAULT_PALETTE, DetectorConfig(max_readings=50))
    decisions = _spy(detector)
    with caplog.at_level(logging.WARNING, logger="marknav.vision.detect"):
        detector.detect(mosaic)
        detector.detect(mosaic)
    first = decisions[:len(decisions) // 2]
    assert first.count(True) == 50 == detector.last_readings
    assert first[:50] == [True] * 50 and not any(first[50:])  # nothing read past the budget
    assert detector.last_skipped >= first.count(False) > 1000  # ≈ 4,000 unread, counted
    assert detector.crowded_frames == 2
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1  # once per detector, not once per frame
    assert "crowded frame" in warnings[0] and "max_readings" in warnings[0]


def _discs(radii: list[int]) -> np.ndarray:
    image = np.full((480, 640, 3), 110, np.uint8)
    for k, r in enumerate(radii):
        cv2.circle(image, (70 + 150 * k, 240), r, (0, 0, 230), -1, cv2.LINE_AA)  # red
    return image


def test_the_largest_blob_is_read_first() -> None:
    image = _discs([12, 14, 60, 16])  # the third disc is the largest
    everything = Detector(DEFAULT_PALETTE).detect(image)
    # (an anti-aliased disc of radius r covers about r + 0.5)
    assert np.allclose(sorted(m.radius for m in everything), [12.5, 14.5, 16.5, 60.5], atol=1)
    one = Detector(DEFAULT_PALETTE, DetectorConfig(max_readings=1))
    marks = one.detect(image)
    assert len(marks) == 1 and abs(marks[0].radius - 60.5) < 1 and abs(marks[0].x - 370) < 1
    assert one.last_readings == 1 and one.last_skipped >= 3


def test_frames_within_the_budget_give_the_marks_of_reading_in_contour_order(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Reading largest first changes nothing while the budget lasts: the marks are those of
    reading the blobs in the contours' own order (as before the budget), and a budget of
    exactly the readings a frame needs leaves nothing unread and warns of nothing."""
    import marknav.vision.detect.detector as detector_module

    spec = SceneSpec(n_marks=4, n_clutter=8, occluded_share=0.3, touching_pairs=1)
    rng = np.random.default_rng(11)
    images = [render_scene(rng, spec).image for _ in range(8)]
    budgeted = Detector(DEFAULT_PALETTE)
    expected = []
    for image in images:
        expected.append((budgeted.detect(image), budgeted.last_readings))
        assert budgeted.last_skipped == 0 and budgeted.last_readings > 0

    def unsorted(items: Any, key: Any = None) -> list[Any]:
        return list(items)  # the candidates in contour order; the rest is sorted anyway

    in_order = Detector(DEFAULT_PALETTE)
    with monkeypatch.context() as m:
        m.setattr(detector_module, "sorted", unsorted, raising=False)
        for image, (marks, _) in zip(images, expected, strict=True):
            assert in_order.detect(image) == marks
    for image, (marks, readings) in zip(images, expected, strict=True):
        exact = Detector(DEFAULT_PALETTE, DetectorConfig(max_readings=readings))
        assert exact.detect(image) == marks
        assert exact.last_skipped == 0 and exact.crowded_frames == 0


def test_the_budget_must_allow_a_reading() -> None:
    with pytest.raises(ValueError, match="max_readings must be >= 1, got 0"):
        DetectorConfig(max_readings=0)


@pytest.mark.slow
def test_the_crowded_bench_reports_each_frame_within_the_budget() -> None:
    figures = run_crowded_bench(repeats=1)
    assert set(figures) == set(crowded_frames())
    budget = DetectorConfig().max_readings
    for row in figures.values():
        for label in ("detector", "robot"):
            cell = row[label]
            assert isinstance(cell, dict)
            assert 0 < cell["readings"] <= budget and cell["ms"] > 0
    mosaic = figures["mosaic_8px_640"]["detector"]
    assert isinstance(mosaic, dict) and mosaic["readings"] == budget and mosaic["unread"] > 0


_lengths = st.one_of(st.floats(0, 80), st.just(float("nan")))
_marks = st.builds(
    lambda x, y, r, a, b, angle: Mark("red", x, y, r, (a, b), angle, "ellipse", 0.5),
    st.floats(0, 200), st.floats(0, 200), _lengths, _lengths, _lengths, st.floats(0, 179.9))


@settings(max_examples=400, deadline=None)
@given(_marks, _marks)
def test_suppression_skips_only_pairs_that_cannot_be_duplicates(a: Mark, b: Mark) -> None:
    # Either test of a duplicate (centres close for their size, or one centre inside the other
    # ellipse) implies the cheap proximity test that lets a crowded frame's far pairs go —
    # whatever the axes' order, zero axes, NaN.
    close = math.hypot(a.x - b.x, a.y - b.y) < 0.5 * min(a.radius, b.radius)
    if close or suppress._centre_in(a, b) or suppress._centre_in(b, a):
        assert suppress._near(a, b)
