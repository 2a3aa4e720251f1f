"""The white balance's compiled loops (marknav/vision/detect/kernels.py) give OpenCV's numbers:
saturation and value on every 8-bit colour, gains as cv2.transform applies them, block means as
INTER_AREA rounds them, and the same gains as the chain of OpenCV calls they replaced."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import cv2
import numba
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


@pytest.mark.slow
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


def test_balance_subsample_needs_a_whole_block() -> None:
    with pytest.raises(ValueError, match="no 2×2 block"):
        balance_subsample(np.zeros((252, 1, 3), np.uint8), 2)


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
        grey_room = (rng.normal(120, 25, (36, 48, 1)) * np.array(cast)
                     + rng.normal(0, 4, (36, 48, 3)))
        cases.append(np.clip(grey_room, 0, 255).astype(np.uint8))
    overexposed = np.full((36, 48, 3), (255, 250, 215), np.uint8)  # clipped near-whites only
    saturated = np.zeros((36, 48, 3), np.uint8)
    saturated[..., 2] = 200  # nothing grey: gains 1, the scene's mean level
    cases += [overexposed, saturated, rng.integers(0, 256, (36, 48, 3), np.uint8)]
    # Subsample sizes whose 5 % threshold is a whole number of pixels (3×20: 3.0), where the
    # threshold's rounding decides the branch: grey counts put on and around it.
    for shape in ((3, 20), (6, 10), (4, 5), (5, 12)):
        for greys in (-1, 0, 1):
            n = shape[0] * shape[1]
            tiny = np.zeros((*shape, 3), np.uint8)
            tiny[...] = (20, 40, 220)  # saturated: not grey
            flat = tiny.reshape(-1, 3)
            k = max(0, round(0.05 * n) + greys)
            flat[:k] = rng.integers(90, 160, (k, 1)) + rng.integers(-6, 7, (k, 3))
            cases.append(tiny)
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
    for name in kernels.__all__:
        if name != "warm_up":
            assert getattr(kernels, name).signatures, name


# --- the arc path's and the whole-mark measurement's loops ------------------------------------


def _numpy_circle(pts: np.ndarray) -> tuple[float, float, float]:
    """The Kåsa circle through the normal equations, solved by NumPy."""
    x, y = pts[:, 0], pts[:, 1]
    a = np.column_stack([x, y, np.ones(len(pts))])
    (d, e, f), *_ = np.linalg.lstsq(a, x * x + y * y, rcond=None)
    cx, cy = d / 2.0, e / 2.0
    return cx, cy, math.sqrt(f + cx * cx + cy * cy)


def _arc(rng: np.random.Generator, n: int, span_deg: float) -> np.ndarray:
    phi = np.radians(rng.uniform(0, 360) + np.linspace(0, span_deg, n))
    cx, cy, r = rng.uniform(-50, 50), rng.uniform(-50, 50), rng.uniform(5, 80)
    return np.column_stack([cx + r * np.cos(phi), cy + r * np.sin(phi)]) + \
        rng.normal(0, 0.3, (n, 2))


def _gram_circle(pts: np.ndarray) -> tuple[float, float, float] | None:
    """The Kåsa fit as the arc path made it before it was compiled: one Gram matrix product."""
    n = len(pts)
    mean = pts.sum(axis=0) / n
    cols = np.empty((n, 3), np.float64)
    np.subtract(pts, mean, out=cols[:, :2])
    u, v = cols[:, 0], cols[:, 1]
    cols[:, 2] = u * u + v * v
    (suu, suv, suw), (_, svv, svw), _ = (cols.T @ cols).tolist()
    det = suu * svv - suv * suv
    if abs(det) < 1e-9 * max(suu * svv, 1e-12):
        return None
    cx = (0.5 * suw * svv - 0.5 * svw * suv) / det
    cy = (0.5 * svw * suu - 0.5 * suw * suv) / det
    r = math.sqrt(cx * cx + cy * cy + (suu + svv) / n)
    return cx + float(mean[0]), cy + float(mean[1]), r


def test_circle_fit_is_the_gram_matrix_fit() -> None:
    rng = np.random.default_rng(13)
    for _ in range(300):
        pts = _arc(rng, int(rng.integers(3, 300)), float(rng.uniform(20, 360)))
        ok, cx, cy, r, _ = kernels.circle_fit(pts, False)
        want = _gram_circle(pts)
        assert ok == (want is not None)
        if want is not None:
            assert (cx, cy, r) == pytest.approx(want, rel=1e-9, abs=1e-9)


def test_circle_fit_is_the_least_squares_circle_and_its_span() -> None:
    rng = np.random.default_rng(3)
    for span in (40.0, 120.0, 230.0, 359.0):
        pts = _arc(rng, 80, span)
        ok, cx, cy, r, got_span = kernels.circle_fit(pts, True)
        assert ok
        assert (cx, cy, r) == pytest.approx(_numpy_circle(pts), rel=1e-9, abs=1e-9)
        # the widest gap between the points' directions, seen from the fitted centre
        ang = np.sort(np.arctan2(pts[:, 1] - cy, pts[:, 0] - cx))
        gap = max(float(np.diff(ang).max()), float(ang[0] + 2 * math.pi - ang[-1]))
        assert got_span == pytest.approx(2 * math.pi - gap, abs=1e-12)
        assert abs(math.degrees(got_span) - span) < 10.0  # (noisy points, a fitted centre)
    assert not kernels.circle_fit(np.array([[0.0, 0.0], [1.0, 1.0]]), True)[0]
    line = np.column_stack([np.arange(10.0), 2.0 * np.arange(10.0)])
    assert not kernels.circle_fit(line, False)[0]  # collinear: no circle


def test_ellipse_rms_is_the_residuals_rms() -> None:
    from marknav.vision.detect.geometry import _Ellipse, _rms

    rng = np.random.default_rng(4)
    for a, b in ((20.0, 20.0), (30.0, 18.0), (9.0, 14.0)):
        e = _Ellipse(rng.uniform(-9, 9), rng.uniform(-9, 9), a, b, rng.uniform(0, math.pi))
        pts = rng.normal(0, 25, (200, 2))
        pts[0] = (e.cx, e.cy)  # the centre itself: minus the minor semi-axis
        got = kernels.ellipse_rms(pts, e.cx, e.cy, e.a, e.b, e.theta)
        assert got == pytest.approx(_rms(e.residuals(pts)), rel=1e-12)
    assert kernels.ellipse_rms(np.zeros((0, 2)), 0.0, 0.0, 1.0, 1.0, 0.0) == math.inf


def _numpy_runs(keep: np.ndarray) -> list[list[int]]:
    n = len(keep)
    if n == 0 or not keep.any():
        return []
    if keep.all():
        return [list(range(n))]
    start = int(np.argmin(keep))
    order = [(start + i) % n for i in range(n)]
    runs: list[list[int]] = []
    current: list[int] = []
    for i in order:
        if keep[i]:
            current.append(i)
        elif current:
            runs.append(current)
            current = []
    if current:
        runs.append(current)
    return runs


def test_runs_are_the_cyclic_true_stretches() -> None:
    from marknav.vision.detect.geometry import _runs

    rng = np.random.default_rng(6)
    cases = [np.zeros(0, bool), np.zeros(5, bool), np.ones(7, bool),
             np.array([True, True, False, True, True]),  # wraps round: one run 3, 4, 0, 1
             np.array([False, True, False, True])]
    cases += [rng.random(n) < p for n in (1, 2, 17, 300) for p in (0.2, 0.5, 0.9)]
    for keep in cases:
        assert [r.tolist() for r in _runs(keep)] == _numpy_runs(keep), keep
    assert [r.tolist() for r in _runs(cases[3])] == [[3, 4, 0, 1]]


def _integral_quadrants_differ(roi: np.ndarray, back: np.ndarray, cx: int, cy: int,
                               spread: float) -> bool:
    """The test as the whole-mark stage made it before it was compiled: two integral images."""
    h, w = roi.shape[:2]
    count = cv2.integral(back, sdepth=cv2.CV_32S)
    total = cv2.integral(cv2.bitwise_and(roi, roi, mask=back), sdepth=cv2.CV_32S)
    chromas = []
    for y0, y1, x0, x1 in ((0, cy, 0, cx), (0, cy, cx, w), (cy, h, 0, cx), (cy, h, cx, w)):
        n = int(count[y1, x1] - count[y0, x1] - count[y1, x0] + count[y0, x0]) // 255
        if n < 4:
            continue
        sums = total[y1, x1] - total[y0, x1] - total[y1, x0] + total[y0, x0]
        inv = 1.0 / n
        b, g, r = float(sums[0]) * inv, float(sums[1]) * inv, float(sums[2]) * inv
        grey = (b + g + r) / 3.0
        chromas.append((b - grey, g - grey, r - grey))
    return any((a[0] - c[0]) ** 2 + (a[1] - c[1]) ** 2 + (a[2] - c[2]) ** 2 >= spread ** 2
               for i, a in enumerate(chromas) for c in chromas[i + 1:])


def test_quadrants_differ_is_the_integral_image_test() -> None:
    rng = np.random.default_rng(12)
    agree = {True: 0, False: 0}
    for _ in range(400):
        h, w = int(rng.integers(3, 40)), int(rng.integers(3, 40))
        roi = np.clip(rng.normal(120, 30, (h, w, 1)) + rng.normal(0, 12, (h, w, 3)) +
                      (rng.normal(0, 25, 3) if rng.random() < 0.5 else 0), 0, 255)
        roi = roi.astype(np.uint8)
        roi[: h // 2, : w // 2] = np.clip(roi[: h // 2, : w // 2] * rng.uniform(0.5, 1.5, 3),
                                          0, 255)
        back = np.where(rng.random((h, w)) < 0.7, 255, 0).astype(np.uint8)
        cx, cy = int(rng.integers(1, w)), int(rng.integers(1, h))
        want = _integral_quadrants_differ(roi, back, cx, cy, 15.0)
        assert kernels.quadrants_differ(roi, back, cx, cy, 15.0) == want
        agree[want] += 1
    assert min(agree.values()) > 40  # both answers were exercised
    with pytest.raises(ValueError, match="differ in size"):
        kernels.quadrants_differ(np.zeros((4, 4, 3), np.uint8), np.zeros((4, 5), np.uint8),
                                 1, 1, 15.0)


@pytest.mark.parametrize("view", [False, True])
def test_quadrants_differ_reads_the_background_of_each_quadrant(view: bool) -> None:
    roi = np.full((40, 40, 3), 120, np.uint8)
    back = np.full((40, 40), 255, np.uint8)
    back[10:30, 10:30] = 0  # the mark's domain
    if view:  # a region of a larger frame, as the detector passes it
        frame = np.zeros((60, 70, 3), np.uint8)
        frame[5:45, 7:47] = roi
        roi = frame[5:45, 7:47]
    assert not kernels.quadrants_differ(roi, back, 20, 20, 15.0)  # grey all round
    roi[20:, :20] = (40, 90, 160)  # a wood floor in the lower-left quadrant
    assert kernels.quadrants_differ(roi, back, 20, 20, 15.0)
    assert not kernels.quadrants_differ(roi, back, 20, 20, 200.0)  # under the spread asked
    back[20:, :20] = 0  # ... but none of its pixels is background
    assert not kernels.quadrants_differ(roi, back, 20, 20, 15.0)


def test_detection_compiles_nothing_after_warm_up() -> None:
    """Every layout the detector passes is compiled at set-up: a frame's detection does not
    stop to compile (≈ 0.1-0.3 s)."""
    from marknav.sim.synthetic.scene import bench_frames

    kernels.warm_up()
    loops = [getattr(kernels, name) for name in kernels.__all__ if name != "warm_up"]
    before = [len(loop.signatures) for loop in loops]
    detector = Detector(DEFAULT_PALETTE)
    for scene in bench_frames(6, 7):
        detector.detect(scene.image)
        detector.detect(np.ascontiguousarray(scene.image[:, 1:]))  # odd width: other views
    assert [len(loop.signatures) for loop in loops] == before


def test_radius_range_spans_the_points_normalised_radii() -> None:
    rng = np.random.default_rng(8)
    pts = rng.integers(-40, 40, (150, 2)).astype(np.int32)
    cx, cy, a, b, theta = 1.5, -2.25, 30.0, 17.0, 0.6
    c, s = math.cos(theta), math.sin(theta)
    d = pts - np.array([cx, cy])
    u = (d[:, 0] * c + d[:, 1] * s) / a
    v = (-d[:, 0] * s + d[:, 1] * c) / b
    lo, hi = kernels.radius_range(pts, cx, cy, a, b, theta)
    assert (lo, hi) == pytest.approx((float((u * u + v * v).min()), float((u * u + v * v).max())),
                                     rel=1e-12)
    ring = np.array([[round(20 * math.cos(t)), round(20 * math.sin(t))]
                     for t in np.linspace(0, 2 * math.pi, 90)], np.int32)
    lo, hi = kernels.radius_range(ring, 0.0, 0.0, 20.0, 20.0, 0.0)  # a digital circle: ≈ 1
    assert 0.9 < lo <= 1.0 <= hi < 1.1


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(numba.core.config, "CACHE_LOCATOR_CLASSES"),
                    reason="this numba cannot be told which cache locators to try")
def test_an_installation_without_a_writable_cache_still_detects(tmp_path: Path) -> None:
    """Where numba can cache nowhere (a read-only install; simulated by allowing only the
    IPython locator), the loops are compiled in the process instead of failing at import."""
    frame = tmp_path / "frame.png"
    from marknav.sim.synthetic.scene import bench_frames

    scene = bench_frames(1, 3)[0]
    cv2.imwrite(str(frame), scene.image)
    script = (
        "import sys, cv2\n"
        "from marknav.vision.detect import kernels\n"
        "from marknav.vision.detect.detector import Detector\n"
        "assert type(kernels.grey_sums._cache).__name__ == 'NullCache'\n"
        "marks = Detector().detect(cv2.imread(sys.argv[1]))\n"
        "print(len(marks))\n"
    )
    env = {**os.environ, "NUMBA_CACHE_LOCATOR_CLASSES": "IPythonCacheLocator"}
    done = subprocess.run([sys.executable, "-c", script, str(frame)], env=env,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert int(done.stdout.strip()) == len(Detector(DEFAULT_PALETTE).detect(scene.image)) > 0


# --- the coarse gate's seeds --------------------------------------------------------------------


def _opencv_seeds(image: np.ndarray, gains: tuple[float, float, float], sat_min: int,
                  v_floor: int, gate: np.ndarray) -> np.ndarray:
    """The gate's seeds as OpenCV calls made them before the compiled pass."""
    h, w = image.shape[:2]
    sample = cv2.resize(image, (w // 4, h // 4), interpolation=cv2.INTER_LINEAR)
    if gains != (1.0, 1.0, 1.0):
        sample = cv2.transform(sample, _diagonal(gains))
    hsv = cv2.cvtColor(sample, cv2.COLOR_BGR2HSV)
    seeds = cv2.inRange(hsv, (0, sat_min, v_floor), (255, 255, 255))
    return cv2.bitwise_and(seeds, cv2.LUT(np.ascontiguousarray(hsv[:, :, 0]), gate))


@pytest.mark.slow
@pytest.mark.parametrize("gains", [(1.0, 1.0, 1.0), (1.23, 0.91, 0.77), (0.6, 1.0, 1.6)])
def test_coarse_seeds_match_opencv_on_every_colour(every_colour: np.ndarray,
                                                   gains: tuple[float, float, float]) -> None:
    """Every colour as a uniform 4×4 block (so the sample is the colour itself); the gate lets
    every other hue through, so that a hue off by one would show."""
    gate = np.where(np.arange(256) % 2 == 0, 255, 0).astype(np.uint8)
    for rows in range(0, 4096, 512):
        slab = np.repeat(np.repeat(every_colour[rows:rows + 512], 4, axis=0), 4, axis=1)
        got = kernels.coarse_seeds(slab, np.array(gains, np.float32), 60, 40, gate)
        assert np.array_equal(got, _opencv_seeds(slab, gains, 60, 40, gate)), rows


@pytest.mark.slow
def test_coarse_seeds_match_opencv_on_random_frames() -> None:
    """The block means' rounding, frame sizes, thresholds and gates."""
    rng = np.random.default_rng(21)
    for _ in range(60):
        h, w = 4 * int(rng.integers(1, 130)), 4 * int(rng.integers(1, 170))
        image = rng.integers(0, 256, (h + 5, w + 7, 3), np.uint8)
        if rng.random() < 0.5:  # smooth patches, as in photographs
            image = cv2.GaussianBlur(image, (0, 0), float(rng.uniform(0.5, 4.0)))
        # a frame, a region of a larger one, or a read-only frame (a camera's buffer)
        image = image[:h, :w].copy() if rng.random() < 0.4 else image[2:2 + h, 3:3 + w]
        if rng.random() < 0.3:
            image.setflags(write=False)
        b, g, r = (float(x) for x in rng.uniform(0.6, 1.6, 3))
        gains = (b, g, r) if rng.random() < 0.7 else (1.0, 1.0, 1.0)
        gate = np.where(rng.random(256) < 0.4, 255, 0).astype(np.uint8)
        sat_min, v_floor = int(rng.integers(0, 256)), int(rng.integers(0, 256))
        got = kernels.coarse_seeds(image, np.array(gains, np.float32), sat_min, v_floor, gate)
        want = _opencv_seeds(image, gains, sat_min, v_floor, gate)
        assert np.array_equal(got, want), (h, w, gains, sat_min, v_floor)


def _opencv_box(image: np.ndarray, box: tuple[int, int, int, int],
                gains: tuple[float, float, float], sat_min: int, v_floor: int,
                gate: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A gated rectangle's search products as OpenCV calls made them before the compiled pass."""
    x0, y0, x1, y1 = box
    small = cv2.resize(image[2 * y0:2 * y1, 2 * x0:2 * x1], (x1 - x0, y1 - y0),
                       interpolation=cv2.INTER_AREA)
    if gains != (1.0, 1.0, 1.0):
        small = cv2.transform(small, _diagonal(gains))
    hsv = cv2.cvtColor(small, cv2.COLOR_BGR2HSV)
    mask = cv2.inRange(hsv, (0, sat_min, v_floor), (255, 255, 255))
    return small, hsv, cv2.bitwise_and(mask, cv2.LUT(np.ascontiguousarray(hsv[:, :, 0]), gate))


@pytest.mark.slow
@pytest.mark.parametrize("gains", [(1.0, 1.0, 1.0), (1.23, 0.91, 0.77), (0.6, 1.0, 1.6)])
def test_search_box_matches_opencv_on_every_colour(every_colour: np.ndarray,
                                                   gains: tuple[float, float, float]) -> None:
    gate = np.where(np.arange(256) % 3 == 0, 255, 0).astype(np.uint8)
    for rows in range(0, 4096, 1024):
        slab = np.repeat(np.repeat(every_colour[rows:rows + 1024], 2, axis=0), 2, axis=1)
        small = np.zeros((1024, 4096, 3), np.uint8)
        hsv = np.zeros_like(small)
        mask = kernels.search_box(slab, 0, 0, 4096, 1024, np.array(gains, np.float32), 60, 40,
                                  gate, small, hsv)
        want = _opencv_box(slab, (0, 0, 4096, 1024), gains, 60, 40, gate)
        for got, ref in zip((small, hsv, mask), want, strict=True):
            assert np.array_equal(got, ref), rows


def test_search_box_writes_its_rectangle_only_and_matches_opencv() -> None:
    rng = np.random.default_rng(22)
    for _ in range(60):
        sh, sw = int(rng.integers(4, 250)), int(rng.integers(4, 330))
        image = rng.integers(0, 256, (2 * sh + 3, 2 * sw + 5, 3), np.uint8)
        if rng.random() < 0.5:
            image = cv2.GaussianBlur(image, (0, 0), float(rng.uniform(0.5, 4.0)))
        image = image[:2 * sh + int(rng.integers(0, 2)), :2 * sw + int(rng.integers(0, 2))]
        if rng.random() < 0.3:
            image = image.copy()
            image.setflags(write=False)
        x0, y0 = int(rng.integers(0, sw)), int(rng.integers(0, sh))  # the last column too
        x1, y1 = int(rng.integers(x0 + 1, sw + 1)), int(rng.integers(y0 + 1, sh + 1))
        b, g, r = (float(x) for x in rng.uniform(0.6, 1.6, 3))
        gains = (b, g, r) if rng.random() < 0.7 else (1.0, 1.0, 1.0)
        gate = np.where(rng.random(256) < 0.4, 255, 0).astype(np.uint8)
        sat_min, v_floor = int(rng.integers(0, 256)), int(rng.integers(0, 256))
        small = np.zeros((sh, sw, 3), np.uint8)
        hsv = np.zeros_like(small)
        mask = kernels.search_box(image, x0, y0, x1, y1, np.array(gains, np.float32), sat_min,
                                  v_floor, gate, small, hsv)
        want = _opencv_box(image, (x0, y0, x1, y1), gains, sat_min, v_floor, gate)
        assert np.array_equal(small[y0:y1, x0:x1], want[0])
        assert np.array_equal(hsv[y0:y1, x0:x1], want[1])
        assert np.array_equal(mask, want[2])
        small[y0:y1, x0:x1] = 0
        hsv[y0:y1, x0:x1] = 0
        assert not small.any() and not hsv.any()  # nothing outside the rectangle
