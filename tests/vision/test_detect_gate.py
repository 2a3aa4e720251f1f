"""The coarse gate (``marknav.vision.detect.gate``): searching only around the quarter-resolution
seeds finds what searching the whole frame finds, and the horizon band prunes there."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from marknav.sim.synthetic.scene import SceneSpec, render_scene
from marknav.vision.detect import Detector, DetectorConfig, Mark, gate
from marknav.vision.detect.gate import SearchBuffers, search_products
from marknav.vision.palette import DEFAULT_PALETTE

SCENES = SceneSpec(width=640, height=480, n_marks=3, radius=(6.0, 150.0), ellipse_share=0.3,
                   axis_ratio=(0.5, 0.95), n_clutter=6, occluded_share=0.3,
                   occlusion=(0.05, 0.25), cut_share=0.15, touching_pairs=1, gain=(0.4, 1.6),
                   cast=0.2, blur_sigma=(0.0, 1.2), noise_sigma=(1.0, 3.0))


def _key(marks: list[Mark]) -> list[tuple[str, float, float, float]]:
    return [(m.colour, m.x, m.y, m.radius) for m in marks]


@pytest.mark.slow
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


def _opencv_products(image: np.ndarray, balance: np.ndarray | None, sat_min: int,
                     v_floor: int, gate_lut: np.ndarray | None, kernel: np.ndarray | None,
                     band: tuple[float, float] | None,
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, list | None]:
    """The gated search products as OpenCV calls made them before the compiled pass: the seeds
    from the quarter sample, each rectangle resized, balanced, converted and thresholded."""
    h, w = image.shape[:2]
    sw, sh = w // 2, h // 2
    seeds = gate._classify(gate.coarse_sample(image), balance, sat_min, v_floor, gate_lut,
                           None)[2]
    boxes = gate._boxes(seeds, 2, sw, sh, band)
    small = np.zeros((sh, sw, 3), np.uint8)
    hsv = np.zeros_like(small)
    mask = np.zeros((sh, sw), np.uint8)
    for x0, y0, x1, y1 in boxes or []:
        part = cv2.resize(image[2 * y0:2 * y1, 2 * x0:2 * x1], (x1 - x0, y1 - y0),
                          interpolation=cv2.INTER_AREA)
        b, c, m = gate._classify(part, balance, sat_min, v_floor, gate_lut, kernel)
        small[y0:y1, x0:x1], hsv[y0:y1, x0:x1] = b, c
        mask[y0:y1, x0:x1] |= m
    return small, hsv, mask, boxes


@pytest.mark.slow
def test_the_compiled_search_gives_the_opencv_search_products_exactly() -> None:
    """Frames of any size (odd, not multiples of 4), regions of larger frames, read-only
    frames; with and without white balance, hue gate, opening and horizon band; buffers used
    twice (a second frame's rectangles clear the first's)."""
    det = Detector(DEFAULT_PALETTE)
    rng = np.random.default_rng(17)
    gated_frames = 0
    for _ in range(40):
        w, h = int(rng.integers(130, 700)), int(rng.integers(130, 520))
        if rng.random() < 0.3:
            w -= w % 4
        scene = SceneSpec(width=w, height=h, n_marks=int(rng.integers(0, 5)),
                          n_clutter=int(rng.integers(0, 4)), radius=(4.0, 60.0))
        image = render_scene(rng, scene).image
        if rng.random() < 0.3:
            big = np.zeros((h + 3, w + 5, 3), np.uint8)
            big[1:1 + h, 2:2 + w] = image
            image = big[1:1 + h, 2:2 + w]
        elif rng.random() < 0.2:
            image = image.copy()
            image.setflags(write=False)
        gains = rng.uniform(0.6, 1.6, 3).astype(np.float32)
        balance = None if rng.random() < 0.3 else np.diag(gains).astype(np.float32)
        sat_min, v_floor = int(rng.integers(20, 120)), int(rng.integers(0, 120))
        lut = det._gate_lut if rng.random() < 0.7 else None
        kernel = det._kernel if rng.random() < 0.7 else None
        band = None if rng.random() < 0.5 else (float(rng.uniform(0, h / 4)),
                                                 float(rng.uniform(h / 4, h / 2)))
        buffers = SearchBuffers()
        for _ in range(2):
            got = search_products(image, (w // 2, h // 2), 2, True, None, balance, sat_min,
                                  v_floor, lut, kernel, buffers, band)
            want = _opencv_products(image, balance, sat_min, v_floor, lut, kernel, band)
            assert got.boxes == want[3]
            if got.boxes is None:
                continue  # a large candidate area: the whole frame, searched with OpenCV
            gated_frames += 1
            for a, b in zip((got.small, got.hsv, got.mask), want[:3], strict=True):
                assert np.array_equal(a, b), (w, h)
    assert gated_frames >= 40
