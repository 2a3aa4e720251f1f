"""The white balance's compiled loops (marknav/vision/detect/kernels.py) give OpenCV's numbers:
saturation and value on every 8-bit colour, gains as cv2.transform applies them, block means as
INTER_AREA rounds them, and the same gains as the chain of OpenCV calls they replaced."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from marknav.vision.detect import kernels
from marknav.vision.detect.colour import _CLIPPED_S_MAX, _diagonal, balance_subsample
from marknav.vision.detect.detector import Detector
from marknav.vision.detect.model import DetectorConfig
from marknav.vision.palette import DEFAULT_PALETTE


@pytest.fixture(scope="module")
def every_colour() -> np.ndarray:
    """All 2²⁴ BGR colours as a 4096 × 4096 image."""
    v = np.arange(256, dtype=np.uint8)
    b, g, r = np.meshgrid(v, v, v, indexing="ij")
    return np.stack([b.ravel(), g.ravel(), r.ravel()], axis=1).reshape(4096, 4096, 3)


def _opencv_grey(image: np.ndarray, gains: tuple[float, float, float], s_max: int, v_min: int,
                 v_max: int) -> tuple[int, tuple[float, float, float]]:
    seen = cv2.transform(image, _diagonal(gains)) if gains != (1.0, 1.0, 1.0) else image
    mask = cv2.inRange(cv2.cvtColor(seen, cv2.COLOR_BGR2HSV), (0, 0, v_min), (255, s_max, v_max))
    count = cv2.countNonZero(mask)
    mean = cv2.mean(image, mask=mask)
    return count, (mean[0] * count, mean[1] * count, mean[2] * count)


@pytest.mark.parametrize("gains", [(1.0, 1.0, 1.0), (1.23, 0.91, 0.77), (0.6, 1.0, 1.6)])
@pytest.mark.parametrize("bounds", [(40, 16, 250), (0, 0, 255), (160, 16, 250), (90, 16, 255)])
def test_grey_sums_match_opencv_on_every_colour(every_colour: np.ndarray,
                                                 gains: tuple[float, float, float],
                                                 bounds: tuple[int, int, int]) -> None:
    s_max, v_min, v_max = bounds
    count, *sums = kernels.grey_sums(every_colour, np.array(gains, np.float32), *bounds)
    want_count, want_sums = _opencv_grey(every_colour, gains, s_max, v_min, v_max)
    assert count == want_count
    for got, want in zip(sums, want_sums, strict=True):
        assert got == pytest.approx(want, rel=1e-12)


def test_saturation_rank_is_the_histogram_percentile(every_colour: np.ndarray) -> None:
    rng = np.random.default_rng(5)
    for image in (every_colour[::64, ::64], rng.integers(0, 256, (36, 48, 3), np.uint8),
                  np.full((10, 10, 3), 128, np.uint8)):
        hist = cv2.calcHist([cv2.cvtColor(image, cv2.COLOR_BGR2HSV)], [1], None, [256],
                            [0, 256]).ravel()
        for share in (0.0, 0.1, 0.4, 0.9, 1.0):
            want = int(np.searchsorted(np.cumsum(hist), share * float(hist.sum())))
            assert kernels.saturation_rank(np.ascontiguousarray(image), share) == want


@pytest.mark.parametrize("shape", [(480, 640), (121, 163), (64, 96)])
@pytest.mark.parametrize("scale", [1, 2])
def test_balance_subsample_is_the_reduced_frame_sampled(shape: tuple[int, int],
                                                        scale: int) -> None:
    rng = np.random.default_rng(shape[0] + scale)
    image = rng.integers(0, 256, (*shape, 3), np.uint8)
    h, w = shape
    reduced = image if scale == 1 else cv2.resize(image[:h // scale * scale, :w // scale * scale],
                                                  (w // scale, h // scale),
                                                  interpolation=cv2.INTER_AREA)
    sh, sw = reduced.shape[:2]
    step = max(1, sw // 48)
    want = cv2.resize(reduced, (max(1, sw // step), max(1, sh // step)),
                      interpolation=cv2.INTER_NEAREST)
    assert np.array_equal(balance_subsample(image, scale), want)


def _opencv_balance(detector: Detector, tiny: np.ndarray) -> tuple[tuple[float, ...], float]:
    """The white balance as the chain of OpenCV calls the kernels replaced computed it."""
    gains: tuple[float, ...] = (1.0, 1.0, 1.0)
    grey = -1.0
    hsv = cv2.cvtColor(tiny, cv2.COLOR_BGR2HSV)
    hist = cv2.calcHist([hsv], [1], None, [256], [0, 256]).ravel()
    s40 = int(np.searchsorted(np.cumsum(hist), 0.4 * float(hist.sum())))
    s_max = min(160, max(60, s40 + 25))
    for attempt in range(2):
        greyish = cv2.inRange(hsv, (0, 0, 16), (255, s_max, 250))
        if attempt == 0 and cv2.countNonZero(greyish) < 0.05 * greyish.size:
            greyish = cv2.inRange(hsv, (0, 0, 16), (255, min(s_max, _CLIPPED_S_MAX), 255))
        if cv2.countNonZero(greyish) < 0.05 * greyish.size:
            break
        mean = cv2.mean(tiny, mask=greyish)
        grey = (mean[0] + mean[1] + mean[2]) / 3.0
        gains = detector._light_gains(tuple(grey / max(c, 1.0) for c in mean[:3]))
        if max(abs(g - 1.0) for g in gains) <= 0.02:
            break
        hsv = cv2.cvtColor(cv2.transform(tiny, _diagonal((gains[0], gains[1], gains[2]))),
                           cv2.COLOR_BGR2HSV)
        s_max = 40
    if grey < 0:
        mean = cv2.mean(tiny)
        grey = (mean[0] + mean[1] + mean[2]) / 3.0
    return gains, grey


@pytest.mark.parametrize("tint_limit", [None, 0.05])
def test_white_balance_gives_the_opencv_chain_s_gains(tint_limit: float | None) -> None:
    detector = Detector(DEFAULT_PALETTE, DetectorConfig(tint_limit=tint_limit))
    rng = np.random.default_rng(11)
    cases = []
    for cast in ((1.0, 1.0, 1.0), (0.7, 1.0, 1.3), (1.3, 0.95, 0.7), (1.0, 1.25, 1.0)):
        grey_room = rng.normal(120, 25, (36, 48, 1)) * np.array(cast) + rng.normal(0, 4, (36, 48, 3))
        cases.append(np.clip(grey_room, 0, 255).astype(np.uint8))
    overexposed = np.full((36, 48, 3), (255, 250, 215), np.uint8)  # clipped near-whites only
    saturated = np.zeros((36, 48, 3), np.uint8)
    saturated[..., 2] = 200  # nothing grey: gains 1, the scene's mean level
    cases += [overexposed, saturated, rng.integers(0, 256, (36, 48, 3), np.uint8)]
    for tiny in cases:
        got_gains, got_grey = detector.balance_sample(tiny)
        want_gains, want_grey = _opencv_balance(detector, tiny)
        assert got_gains == pytest.approx(want_gains, rel=1e-12, abs=1e-12)
        assert math.isclose(got_grey, want_grey, rel_tol=1e-12)
    # the cases do exercise the branches: a cast corrected, a clipped scene, nothing grey
    assert detector.balance_sample(cases[1])[0][2] < 0.95
    assert detector.balance_sample(overexposed)[0] != (1.0, 1.0, 1.0)
    assert detector.balance_sample(saturated)[0] == (1.0, 1.0, 1.0)


def test_warm_up_leaves_every_loop_compiled() -> None:
    kernels.warm_up()
    for loop in (kernels.block_means, kernels.saturation_rank, kernels.grey_sums):
        assert loop.signatures, loop
