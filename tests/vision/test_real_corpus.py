"""The detector on real photographs (``tests/data/labels.json``) and on marks composited into
them (:mod:`marknav.sim.synthetic.composite`), and the detector changes those frames asked for."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest

from marknav.runs.benchmarks.photos import real_false_marks
from marknav.runs.metrics.matching import match_marks
from marknav.runs.metrics.photo_corpus import (
    LabelledPhoto,
    default_corpus,
    load_corpus,
    real_recall,
)
from marknav.sim.synthetic.composite import (
    COMPOSITE_PALETTE,
    CompositeSpec,
    composite_frame,
    load_photos,
)
from marknav.vision.detect import Detector, DetectorConfig
from marknav.vision.palette import Palette

DATA = Path(__file__).resolve().parents[1] / "data"
#: Small frames keep the compositing cheap (it paints at 4×).
SMALL = CompositeSpec(width=320, height=240, focal_px=295.0, radius=(8.0, 30.0),
                      horizon_tolerance_px=6.0)


@pytest.fixture(scope="module")
def corpus() -> tuple[list[LabelledPhoto], Palette, Palette]:
    return load_corpus(DATA)


def test_the_corpus_is_found_from_the_source_tree() -> None:
    assert default_corpus() == DATA


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="pipeline detector: 3 orange objects missed (two smarties, "
                   "retina.jpg's orange): their shaded sides read hue 1-3, inside red's range, so "
                   "each splits into a bitten orange piece and a red sliver (colour is chosen per "
                   "pixel, not per blob)")
def test_every_labelled_round_object_is_found_with_colour_centre_and_radius(
        corpus: tuple[list[LabelledPhoto], Palette, Palette]) -> None:
    photos, palette, _ = corpus
    result = real_recall(photos, palette)
    assert result["labelled"] >= 12
    assert result["recall"] == 1.0, result["missed"]


@pytest.mark.slow
def test_false_marks_with_the_horizon_prior_stay_below_a_tenth_per_photo_at_both_sizes(
        corpus: tuple[list[LabelledPhoto], Palette, Palette]) -> None:
    photos, _, negative = corpus
    at_640 = real_false_marks(photos, negative, 640, horizon=True)
    at_1280 = real_false_marks(photos, negative, 1280, horizon=True)
    assert at_640["photos"] >= 20
    assert at_640["per_photo"] <= 0.1, at_640["where"]
    assert at_1280["false_marks"] <= at_640["false_marks"], at_1280["where"]


def test_the_minimum_radius_grows_with_the_frame_so_1280_px_finds_no_more_clutter(
        corpus: tuple[list[LabelledPhoto], Palette, Palette]) -> None:
    photos, _, negative = corpus
    at_640 = real_false_marks(photos, negative, 640)
    at_1280 = real_false_marks(photos, negative, 1280)
    assert at_1280["false_marks"] <= at_640["false_marks"], (at_640["where"], at_1280["where"])


def test_config_for_a_camera_and_for_a_frame_width() -> None:
    small = DetectorConfig.for_camera(focal_px=147.5, mark_radius_mm=100.0, max_range_mm=8000.0)
    assert small.shape.min_radius_px == 2.5
    assert small.reference_width is None and small.for_width(1280) is small
    near = DetectorConfig.for_camera(focal_px=590.0, mark_radius_mm=100.0, max_range_mm=3000.0)
    assert near.shape.min_radius_px == pytest.approx(0.9 * 590.0 * 100.0 / 3000.0)
    wide = DetectorConfig().for_width(1280)
    assert wide.shape.min_radius_px == 10.0
    assert DetectorConfig().for_width(320) == DetectorConfig()
    with pytest.raises(ValueError, match="positive"):
        DetectorConfig.for_camera(focal_px=0.0, mark_radius_mm=100.0, max_range_mm=1.0)


def _disc_scene(back: tuple[int, int, int], mark: tuple[int, int, int], *, bar_px: int = 0,
                back_rows: slice = slice(None)) -> np.ndarray:
    img = np.full((480, 640, 3), 128, np.uint8)
    img[back_rows] = back
    big = cv2.resize(img, (640 * 4, 480 * 4), interpolation=cv2.INTER_NEAREST)
    cv2.circle(big, (300 * 4 + 2, 240 * 4 + 2), 40 * 4, mark, -1, cv2.LINE_8)
    if bar_px:
        x0 = (300 - bar_px // 2) * 4
        big[:, x0:x0 + bar_px * 4] = (90, 90, 90)
    out = cv2.resize(big, (640, 480), interpolation=cv2.INTER_AREA)
    rng = np.random.default_rng(0)
    return np.clip(out + rng.normal(0, 2, out.shape), 0, 255).astype(np.uint8)


def test_a_red_mark_against_a_blue_sky_is_cut_out_by_its_own_outline() -> None:
    # The sky (a palette colour) fills the top half and touches the mark: one blob of both.
    image = _disc_scene((200, 90, 30), (30, 30, 220), back_rows=slice(0, 250))
    found = [m for m in Detector(COMPOSITE_PALETTE).detect(image) if m.colour == "red"]
    assert len(found) == 1
    assert math.hypot(found[0].x - 300.5, found[0].y - 240.5) < 1.5
    assert found[0].radius == pytest.approx(40.0, rel=0.05)


@pytest.mark.parametrize("bar_px", [3, 6, 8])
def test_a_mark_cut_in_two_by_a_thin_pole_is_one_mark(bar_px: int) -> None:
    image = _disc_scene((128, 128, 128), (40, 200, 40), bar_px=bar_px)
    found = Detector(COMPOSITE_PALETTE).detect(image)
    assert [m.colour for m in found] == ["green"]
    assert math.hypot(found[0].x - 300.5, found[0].y - 240.5) < 1.5
    assert found[0].radius == pytest.approx(40.0, rel=0.05)
    no_joining = DetectorConfig().with_(segment={"bridge_px": 0})
    off = Detector(COMPOSITE_PALETTE, no_joining).detect(image)
    assert not any(abs(m.radius - 40.0) < 2.0 for m in off)  # the joining is what finds it


def test_composited_frames_are_deterministic_and_carry_their_truth() -> None:
    photos = load_photos(DATA / "real")[:4]
    a = composite_frame(np.random.default_rng(3), photos, ("floor", "board"), SMALL)
    b = composite_frame(np.random.default_rng(3), photos, ("floor", "board"), SMALL)
    assert np.array_equal(a.image, b.image) and a.marks == b.marks
    assert a.conditions == ("floor", "board") and len(a.ranges_mm) == len(a.marks)
    for mark, rng_mm in zip(a.marks, a.ranges_mm, strict=True):
        assert rng_mm == pytest.approx(295.0 * 100.0 / mark.a)
        assert abs(mark.y - 119.5) <= 6.0  # at the horizon row
    with pytest.raises(ValueError, match="unknown composite conditions"):
        composite_frame(np.random.default_rng(3), photos, ("fog",), SMALL)


def test_marks_on_photographs_and_saturated_floors_are_found_with_their_range() -> None:
    photos = load_photos(DATA / "real")
    rng = np.random.default_rng(4)
    detector = Detector(COMPOSITE_PALETTE)
    found: dict[str, int] = {"plain": 0, "floor": 0}
    total: dict[str, int] = {"plain": 0, "floor": 0}
    errors: list[float] = []
    for kind in ["plain", "floor"] * 5:
        frame = composite_frame(rng, photos, (kind,), SMALL)
        pairs, _, _ = match_marks(detector.detect(frame.image), frame.marks)
        found[kind] += len(pairs)
        total[kind] += len(frame.marks)
        if kind == "plain":
            errors += [abs(t.a / m.radius - 1.0) for t, m in pairs]
    assert min(total.values()) >= 8
    assert found["plain"] == total["plain"]
    assert found["floor"] >= 0.9 * total["floor"], (found, total)
    assert float(np.percentile(errors, 95)) <= 0.03
