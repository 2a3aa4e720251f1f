"""Compiled loops (numba) where a stage's cost was the calls, not the pixels or points.

Per-frame and per-blob steps on a few thousand pixels or a few hundred contour points cost
microseconds of arithmetic and tens of microseconds of NumPy and OpenCV call overhead. These
loops compute the same numbers in one call each.

The white balance reads a ≈ 48×36 subsample of every frame. As a chain of OpenCV and NumPy calls
(block means, BGR→HSV, a saturation histogram, two masks, two masked means, a colour transform
and a second conversion) it cost ≈ 0.1 ms a frame, almost all of it per-call overhead on ≈ 2,000
pixels. These loops compute the same numbers in three calls:

- :func:`block_means` — the subsample's pixels, each the rounded mean of its ``scale``×``scale``
  block (as ``cv2.resize`` with ``INTER_AREA`` at an integer factor rounds it);
- :func:`saturation_rank` — the saturation below which a given share of the pixels lie;
- :func:`grey_sums` — count and B, G, R sums of the pixels that look grey (saturation and value
  bounds), read after per-channel gains.

Saturation and value are OpenCV's 8-bit ``COLOR_BGR2HSV`` ones exactly: ``V = max(B, G, R)``,
``S = ((V − min)·⌊255·2¹²/V⌉ + 2¹¹) >> 12`` (its division table); a gain is applied as
``cv2.transform`` with a diagonal ``float32`` matrix applies it (the product in ``float32``,
rounded half to even, saturated). ``tests/vision/test_kernels.py`` checks both against OpenCV
on every 8-bit colour.

The coarse gate and the search (:mod:`.gate`): :func:`coarse_seeds` — the quarter-resolution
sample, its white balance, HSV and the search thresholds in one pass; :func:`search_box` — the
half-resolution image, its HSV and the search mask of one gated rectangle in one pass (the hue
as OpenCV's ``hdiv_table`` gives it; both checked against OpenCV, on every 8-bit colour too).

The arc path and the whole-mark measurement:

- :func:`circle_fit` — the algebraic (Kåsa) least-squares circle through contour points and the
  angle the points span around it (the same formulas as before; the sums in point order, so the
  last bits may differ from the matrix product's);
- :func:`ellipse_rms` — how far points lie from an ellipse or circle (root mean square);
- :func:`radius_range` — how far inside and outside an ellipse a contour's points reach;
- :func:`true_runs` — the maximal runs of a cyclic boolean array;
- :func:`quadrants_differ` — whether the background's chroma differs between the quadrants
  around a centre (exact integer sums, as the integral images gave them).

Compiled on first use and cached beside this file (``cache=True``); :func:`warm_up` does it at
set-up.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from marknav.core.compiled import compiled as _compiled

__all__ = ["block_means", "circle_fit", "coarse_seeds", "ellipse_rms", "grey_sums",
           "quadrants_differ", "radius_range", "saturation_rank", "search_box", "true_runs",
           "warm_up"]


_HSV_SHIFT = 12
#: OpenCV's ``sdiv_table``: round(255·2¹² / v), 0 for v = 0.
_SDIV = np.zeros(256, np.int64)
_SDIV[1:] = np.round((255 << _HSV_SHIFT) / np.arange(1, 256, dtype=np.float64)).astype(np.int64)
_HALF = 1 << (_HSV_SHIFT - 1)
#: OpenCV's ``hdiv_table`` for hues 0..179: round(180·2¹² / (6·d)), 0 for d = 0.
_HDIV = np.zeros(256, np.int64)
_HDIV[1:] = np.round((180 << _HSV_SHIFT) / (6.0 * np.arange(1, 256, dtype=np.float64))
                     ).astype(np.int64)


@_compiled
def _saturation_of(v: int, diff: int) -> int:
    """OpenCV's 8-bit saturation of a colour with value ``v`` = max and ``diff`` = max − min."""
    return (diff * _SDIV[v] + _HALF) >> _HSV_SHIFT


@_compiled
def _saturation(b: int, g: int, r: int) -> tuple[int, int]:
    v = max(b, g, r)
    return _saturation_of(v, v - min(b, g, r)), v


@_compiled
def _gain_table(gains: npt.NDArray[np.float32]) -> npt.NDArray[np.int64]:
    """Each channel's 256 values scaled by its gain (B, G, R; ``float32``) as ``cv2.transform``
    with the gains' diagonal matrix makes them: the ``float32`` product, rounded half to even,
    saturated."""
    scaled = np.empty((3, 256), np.int64)
    for c in range(3):
        for value in range(256):
            scaled[c, value] = min(255, int(np.rint(np.float32(value) * gains[c])))
    return scaled


@_compiled
def _hue(b: int, g: int, r: int, v: int, diff: int) -> int:
    """OpenCV's 8-bit hue (0..179) of a colour with value ``v`` = max and ``diff`` = max − min."""
    if v == r:
        hue = g - b
    elif v == g:
        hue = b - r + 2 * diff
    else:
        hue = r - g + 4 * diff
    hue = (hue * _HDIV[diff] + _HALF) >> _HSV_SHIFT
    return hue + 180 if hue < 0 else hue


@_compiled
def _mean4(top: npt.NDArray[np.uint8], bottom: npt.NDArray[np.uint8], i: int, c: int) -> int:
    """Channel ``c``'s rounded mean (halves up) of the 2×2 block at column ``i`` of two rows."""
    return (np.int64(top[i, c]) + top[i + 1, c] + bottom[i, c] + bottom[i + 1, c] + 2) >> 2


@_compiled
def block_means(image: npt.NDArray[np.uint8], ys: npt.NDArray[np.intp],
                xs: npt.NDArray[np.intp], scale: int) -> npt.NDArray[np.uint8]:
    """Pixel (i, j) of the result: the mean of ``image``'s ``scale``×``scale`` block whose
    top-left pixel is (``ys[i]``, ``xs[j]``), rounded to nearest (halves up)."""
    out = np.empty((len(ys), len(xs), 3), np.uint8)
    if scale == 2:  # the detector's search scale: the four pixels spelt out
        for i in range(len(ys)):
            top = image[ys[i]]
            bottom = image[ys[i] + 1]
            for j in range(len(xs)):
                for c in range(3):
                    out[i, j, c] = _mean4(top, bottom, xs[j], c)
        return out
    n = scale * scale
    for i in range(len(ys)):
        for j in range(len(xs)):
            for c in range(3):
                total = 0
                for dy in range(scale):
                    for dx in range(scale):
                        total += image[ys[i] + dy, xs[j] + dx, c]
                out[i, j, c] = (total + n // 2) // n
    return out


@_compiled
def saturation_rank(bgr: npt.NDArray[np.uint8], share: float) -> int:
    """The least saturation ``s`` (0..255) with at least ``share`` of the pixels at or below
    it; 256 if none (as ``np.searchsorted`` over the cumulative histogram)."""
    hist = np.zeros(256, np.int64)
    h, w = bgr.shape[0], bgr.shape[1]
    for y in range(h):
        for x in range(w):
            s, _ = _saturation(int(bgr[y, x, 0]), int(bgr[y, x, 1]), int(bgr[y, x, 2]))
            hist[s] += 1
    target = share * float(h * w)
    total = 0
    for s in range(256):
        total += hist[s]
        if total >= target:
            return s
    return 256


@_compiled
def grey_sums(bgr: npt.NDArray[np.uint8], gains: npt.NDArray[np.float32], s_max: int,
              v_min: int, v_max: int) -> tuple[int, float, float, float]:
    """How many pixels look grey once scaled by ``gains`` (B, G, R; ``float32``) —
    saturation ≤ ``s_max``, ``v_min`` ≤ value ≤ ``v_max`` — and the sums of their B, G, R
    as they are in ``bgr`` (unscaled)."""
    # Each channel's 256 scaled values, as cv2.transform makes them, looked up per pixel.
    scaled = _gain_table(gains)
    count = 0
    sb = 0
    sg = 0
    sr = 0
    for y in range(bgr.shape[0]):
        for x in range(bgr.shape[1]):
            b, g, r = int(bgr[y, x, 0]), int(bgr[y, x, 1]), int(bgr[y, x, 2])
            s, v = _saturation(scaled[0, b], scaled[1, g], scaled[2, r])
            if s <= s_max and v_min <= v <= v_max:
                count += 1
                sb += b
                sg += g
                sr += r
    return count, float(sb), float(sg), float(sr)


@_compiled
def circle_fit(pts: npt.NDArray[np.float64],
               want_span: bool) -> tuple[bool, float, float, float, float]:
    """(ok, cx, cy, r, span): the algebraic least-squares circle through ``pts`` (n × 2), in
    closed form about the points' mean, and with ``want_span`` the angle (radians) the points
    cover around it — 2π minus the widest gap between their directions (else 0). Not ok for
    fewer than 3 points, collinear points or a non-finite result."""
    n = pts.shape[0]
    if n < 3:
        return False, 0.0, 0.0, 0.0, 0.0
    mx = 0.0
    my = 0.0
    for i in range(n):
        mx += pts[i, 0]
        my += pts[i, 1]
    mx /= n
    my /= n
    suu = suv = suw = svv = svw = 0.0
    for i in range(n):
        u = pts[i, 0] - mx
        v = pts[i, 1] - my
        w = u * u + v * v
        suu += u * u
        suv += u * v
        suw += u * w
        svv += v * v
        svw += v * w
    rhs_u, rhs_v = 0.5 * suw, 0.5 * svw
    det = suu * svv - suv * suv
    if abs(det) < 1e-9 * max(suu * svv, 1e-12):
        return False, 0.0, 0.0, 0.0, 0.0
    cx = (rhs_u * svv - rhs_v * suv) / det
    cy = (rhs_v * suu - rhs_u * suv) / det
    r = math.sqrt(cx * cx + cy * cy + (suu + svv) / n)
    if not (r > 0 and math.isfinite(cx) and math.isfinite(cy) and math.isfinite(r)):
        return False, 0.0, 0.0, 0.0, 0.0
    cx += mx
    cy += my
    span = 0.0
    if want_span:
        ang = np.empty(n)
        for i in range(n):
            ang[i] = math.atan2(pts[i, 1] - cy, pts[i, 0] - cx)
        ang.sort()
        gap = ang[0] + 2.0 * math.pi - ang[n - 1]
        for i in range(1, n):
            gap = max(gap, ang[i] - ang[i - 1])
        span = 2.0 * math.pi - gap
    return True, cx, cy, r, span


@_compiled
def ellipse_rms(pts: npt.NDArray[np.float64], cx: float, cy: float, a: float, b: float,
                theta: float) -> float:
    """Root mean square of the points' signed distances from the ellipse (centre, semi-axes
    ``a`` along ``theta`` and ``b``), each measured along its ray from the centre as
    :meth:`.geometry._Ellipse.residuals` measures it (a point at the centre: minus the minor
    semi-axis); inf for no point."""
    n = pts.shape[0]
    if n == 0:
        return math.inf
    c, s = math.cos(theta), math.sin(theta)
    total = 0.0
    for i in range(n):
        dx = pts[i, 0] - cx
        dy = pts[i, 1] - cy
        if a == b:
            res = math.hypot(dx, dy) - a
        else:
            q0 = dx * (c / a) + dy * (s / a)
            q1 = dx * (-s / b) + dy * (c / b)
            rho = math.sqrt(q0 * q0 + q1 * q1)
            res = -min(a, b) if rho == 0.0 else math.sqrt(dx * dx + dy * dy) * (1.0 - 1.0 / rho)
        total += res * res
    return math.sqrt(total / n)


@_compiled
def radius_range(pts: npt.NDArray[np.int32], cx: float, cy: float, a: float, b: float,
                 theta: float) -> tuple[float, float]:
    """The least and the greatest squared normalised radius ``(u/a)² + (v/b)²`` of the points
    (n × 2, integer pixels) about the ellipse (centre, semi-axes ``a`` along ``theta``, ``b``):
    1 on it, below 1 inside."""
    c, s = math.cos(theta), math.sin(theta)
    m00, m01, m10, m11 = c / a, -s / b, s / a, c / b
    lo = math.inf
    hi = -math.inf
    for i in range(pts.shape[0]):
        dx = pts[i, 0] - cx
        dy = pts[i, 1] - cy
        u = dx * m00 + dy * m10
        v = dx * m01 + dy * m11
        rho2 = u * u + v * v
        lo = min(lo, rho2)
        hi = max(hi, rho2)
    return lo, hi


@_compiled
def true_runs(keep: npt.NDArray[np.bool_]) -> tuple[npt.NDArray[np.intp],
                                                     npt.NDArray[np.intp]]:
    """The maximal runs of True in the cyclic array ``keep``: ``(order, bounds)``, each run
    being ``order[b:e]`` for a row (b, e) of ``bounds``. ``order`` lists the indices from the
    first False one on (so that no run wraps past it), all of them when every one is True."""
    n = len(keep)
    start = 0
    while start < n and keep[start]:
        start += 1
    if start == n:
        start = 0
    order = np.empty(n, np.intp)
    for i in range(n):
        order[i] = (start + i) % n
    bounds = np.empty((n // 2 + 1, 2), np.intp)
    k = 0
    i = 0
    while i < n:
        if keep[order[i]]:
            b = i
            while i < n and keep[order[i]]:
                i += 1
            bounds[k, 0] = b
            bounds[k, 1] = i
            k += 1
        else:
            i += 1
    return order, bounds[:k]


@_compiled
def quadrants_differ(roi: npt.NDArray[np.uint8], back: npt.NDArray[np.uint8], cx: int, cy: int,
                     spread: float) -> bool:
    """Whether two of the four quadrants about (``cx``, ``cy``) — rows ``[0, cy)`` / ``[cy, h)``
    by columns ``[0, cx)`` / ``[cx, w)`` — have background colours (the ``roi`` pixels where
    ``back`` is set, quadrants of at least 4 such pixels) whose chroma (grey removed) lies
    ``spread`` or more apart."""
    h, w = back.shape
    if roi.shape[0] != h or roi.shape[1] != w:
        raise ValueError("quadrants_differ: roi and back differ in size")
    counts = np.zeros(4, np.int64)
    sums = np.zeros((4, 3), np.int64)
    for y in range(h):
        row = 0 if y < cy else 2
        for x in range(w):
            value = back[y, x]
            if value == 0:
                continue
            q = row if x < cx else row + 1
            counts[q] += value
            for c in range(3):
                sums[q, c] += roi[y, x, c]
    chroma = np.empty((4, 3))
    kept = 0
    for q in range(4):
        n = counts[q] // 255
        if n < 4:
            continue
        inv = 1.0 / n
        b, g, r = float(sums[q, 0]) * inv, float(sums[q, 1]) * inv, float(sums[q, 2]) * inv
        grey = (b + g + r) / 3.0
        chroma[kept, 0], chroma[kept, 1], chroma[kept, 2] = b - grey, g - grey, r - grey
        kept += 1
    limit = spread * spread
    for i in range(kept):
        for j in range(i + 1, kept):
            d0 = chroma[i, 0] - chroma[j, 0]
            d1 = chroma[i, 1] - chroma[j, 1]
            d2 = chroma[i, 2] - chroma[j, 2]
            if d0 * d0 + d1 * d1 + d2 * d2 >= limit:
                return True
    return False


@_compiled
def coarse_seeds(image: npt.NDArray[np.uint8], gains: npt.NDArray[np.float32], sat_min: int,
                 v_floor: int, gate: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint8]:
    """The coarse gate's seeds of a frame whose sides are multiples of 4 (``gate.COARSE_STEP``
    is 4): per 4×4 block the rounded mean of its central 2×2 pixels (``cv2.resize`` to a
    quarter with ``INTER_LINEAR``), scaled by ``gains`` (B, G, R, ``float32``; as
    ``cv2.transform`` with their diagonal matrix), 255 where OpenCV's 8-bit HSV of it has
    S ≥ ``sat_min``, V ≥ ``v_floor`` and ``gate[H] != 0``, else 0. One pass instead of a resize
    and five calls on the sample."""
    scaled = _gain_table(gains)
    rows, cols = image.shape[0] // 4, image.shape[1] // 4
    out = np.zeros((rows, cols), np.uint8)
    for y in range(rows):
        top = image[4 * y + 1]
        bottom = image[4 * y + 2]
        for x in range(cols):
            i = 4 * x + 1
            b = scaled[0, _mean4(top, bottom, i, 0)]
            g = scaled[1, _mean4(top, bottom, i, 1)]
            r = scaled[2, _mean4(top, bottom, i, 2)]
            v = max(b, g, r)
            if v < v_floor:
                continue
            diff = v - min(b, g, r)
            if _saturation_of(v, diff) < sat_min:
                continue
            hue = _hue(b, g, r, v, diff)
            if gate[hue]:
                out[y, x] = 255
    return out


@_compiled
def search_box(image: npt.NDArray[np.uint8], x0: int, y0: int, x1: int, y1: int,
               gains: npt.NDArray[np.float32], sat_min: int, v_floor: int,
               gate: npt.NDArray[np.uint8], small: npt.NDArray[np.uint8],
               hsv: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint8]:
    """The half-resolution search products of one rectangle (search px ``x0``..``x1``,
    ``y0``..``y1``) in one pass: ``small`` there gets each 2×2 block's rounded mean
    (``cv2.resize`` by half with ``INTER_AREA``) scaled by ``gains`` (as ``cv2.transform``
    with their diagonal matrix), ``hsv`` its OpenCV 8-bit HSV; returns the rectangle's mask
    before the opening: 255 where S ≥ ``sat_min``, V ≥ ``v_floor`` and ``gate[H] != 0``."""
    scaled = _gain_table(gains)
    mask = np.zeros((y1 - y0, x1 - x0), np.uint8)
    for y in range(y0, y1):
        top = image[2 * y]
        bottom = image[2 * y + 1]
        for x in range(x0, x1):
            i = 2 * x
            b = scaled[0, _mean4(top, bottom, i, 0)]
            g = scaled[1, _mean4(top, bottom, i, 1)]
            r = scaled[2, _mean4(top, bottom, i, 2)]
            small[y, x, 0] = b
            small[y, x, 1] = g
            small[y, x, 2] = r
            v = max(b, g, r)
            diff = v - min(b, g, r)
            s = _saturation_of(v, diff)
            hue = _hue(b, g, r, v, diff)
            hsv[y, x, 0] = hue
            hsv[y, x, 1] = s
            hsv[y, x, 2] = v
            if s >= sat_min and v >= v_floor and gate[hue]:
                mask[y - y0, x - x0] = 255
    return mask


_warm = False


def warm_up() -> None:
    """Compile the loops (or load them from the cache: ≈ 0.2 s the first time in a process) now,
    at set-up, rather than in the first frame's detection. Cheap after the first call.

    A loop is compiled per argument layout: contiguous arrays and views (a region of a frame)
    are both made here, as the detector passes them. (A read-only frame, e.g. one wrapping a
    camera's byte buffer, compiles its own variants at its first detection.)"""
    global _warm
    if _warm:
        return
    frame = np.zeros((6, 6, 3), np.uint8)
    origins = np.zeros(1, np.intp)
    for image in (frame, frame[1:5, 1:5]):  # contiguous, and a region of a frame
        block_means(image, origins, origins, 2)
        saturation_rank(image, 0.5)
        grey_sums(image, np.ones(3, np.float32), 255, 0, 255)
        quadrants_differ(image, np.zeros(image.shape[:2], np.uint8), 1, 1, 1.0)
        coarse_seeds(image, np.ones(3, np.float32), 1, 1, np.zeros(256, np.uint8))
        search_box(image, 0, 0, 1, 1, np.ones(3, np.float32), 1, 1, np.zeros(256, np.uint8),
                   np.zeros((3, 3, 3), np.uint8), np.zeros((3, 3, 3), np.uint8))
    points = np.array([[0.0, 1.0], [1.0, 0.0], [0.0, -1.0], [-1.0, 0.0]])
    circle_fit(points, True)
    ellipse_rms(points, 0.0, 0.0, 2.0, 1.0, 0.0)
    true_runs(np.ones(3, np.bool_))
    radius_range(np.zeros((1, 2), np.int32), 0.0, 0.0, 1.0, 1.0, 0.0)
    _warm = True
