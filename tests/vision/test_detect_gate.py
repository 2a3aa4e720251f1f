"""The coarse gate (``marknav.vision.detect.gate``): searching only around the quarter-resolution
seeds finds what searching the whole frame finds, and the horizon band prunes there."""

from __future__ import annotations

import cv2
import numpy as np

from marknav.vision.bench import SceneSpec, render_scene
from marknav.vision.detect import Detector, DetectorConfig, Mark
from marknav.vision.detect.gate import SearchBuffers, search_products
from marknav.vision.palette import DEFAULT_PALETTE

SCENES = SceneSpec(width=640, height=480, n_marks=3, radius=(6.0, 150.0), ellipse_share=0.3,
                   axis_ratio=(0.5, 0.95), n_clutter=6, occluded_share=0.3,
                   occlusion=(0.05, 0.25), cut_share=0.15, touching_pairs=1, gain=(0.4, 1.6),
                   cast=0.2, blur_sigma=(0.0, 1.2), noise_sigma=(1.0, 3.0))


def _key(marks: list[Mark]) -> list[tuple[str, float, float, float]]:
    return [(m.colour, m.x, m.y, m.radius) for m in marks]


def test_the_gated_search_finds_what_the_whole_frame_search_finds() -> None:
    gated = Detector(DEFAULT_PALETTE)
    whole = Detector(DEFAULT_PALETTE, DetectorConfig(coarse_gate=False))
    rng = np.random.default_rng(7)
    found = 0
    for _ in range(12):
        image = render_scene(rng, SCENES).image
        a, b = gated.detect(image), whole.detect(image)
        assert [m.colour for m in a] == [m.colour for m in b]
        for p, q in zip(_key(a), _key(b), strict=True):
            assert np.allclose(p[1:], q[1:], atol=0.1), (p, q)
        found += len(a)
    assert found >= 24


def test_the_gate_searches_a_small_share_of_a_frame_with_a_few_marks() -> None:
    rng = np.random.default_rng(3)
    image = render_scene(rng, SceneSpec(n_marks=3, n_clutter=0)).image
    det = Detector(DEFAULT_PALETTE)
    det.detect(image)  # the gate's tables and buffers
    products = search_products(image, (320, 240), 2, True, None,
                               None, det._sat_min, 40, det._gate_lut, det._kernel,
                               SearchBuffers())
    assert products.boxes is not None and 1 <= len(products.boxes) <= 6
    area = sum((x1 - x0) * (y1 - y0) for x0, y0, x1, y1 in products.boxes)
    assert area < 0.4 * 320 * 240
    # Outside the rectangles the search arrays hold nothing.
    outside = np.ones((240, 320), bool)
    for x0, y0, x1, y1 in products.boxes:
        outside[y0:y1, x0:x1] = False
    assert not products.mask[outside].any() and not products.hsv[outside].any()


def test_with_the_horizon_prior_only_marks_near_the_row_are_reported() -> None:
    image = np.full((480, 640, 3), 128, np.uint8)
    cv2.circle(image, (200, 240), 20, (0, 0, 255), -1)  # on the horizon: red
    cv2.circle(image, (450, 80), 20, (255, 0, 0), -1)  # far above it: blue
    prior = Detector(DEFAULT_PALETTE, DetectorConfig(horizon_row=239.5,
                                                     horizon_tolerance_px=30.0))
    assert [m.colour for m in prior.detect(image)] == ["red"]
    assert sorted(m.colour for m in Detector(DEFAULT_PALETTE).detect(image)) == ["blue", "red"]
