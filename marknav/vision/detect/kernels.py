"""Compiled per-pixel loops (numba) where a stage's cost was the calls, not the pixels.

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
on every 8-bit colour. Compiled on first use and cached beside this file (``cache=True``).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numba import njit

__all__ = ["block_means", "grey_sums", "saturation_rank", "warm_up"]

_HSV_SHIFT = 12
#: OpenCV's ``sdiv_table``: round(255·2¹² / v), 0 for v = 0.
_SDIV = np.zeros(256, np.int64)
_SDIV[1:] = np.round((255 << _HSV_SHIFT) / np.arange(1, 256, dtype=np.float64)).astype(np.int64)
_HALF = 1 << (_HSV_SHIFT - 1)


@njit(cache=True, nogil=True)
def _saturation(b: int, g: int, r: int) -> tuple[int, int]:
    v = max(b, g, r)
    low = min(b, g, r)
    return ((v - low) * _SDIV[v] + _HALF) >> _HSV_SHIFT, v


@njit(cache=True, nogil=True)
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
                x = xs[j]
                for c in range(3):
                    acc = (np.int32(top[x, c]) + np.int32(top[x + 1, c])
                           + np.int32(bottom[x, c]) + np.int32(bottom[x + 1, c]))
                    out[i, j, c] = (acc + 2) >> 2
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


@njit(cache=True, nogil=True)
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


@njit(cache=True, nogil=True)
def grey_sums(bgr: npt.NDArray[np.uint8], gains: npt.NDArray[np.float32], s_max: int,
              v_min: int, v_max: int) -> tuple[int, float, float, float]:
    """How many pixels look grey once scaled by ``gains`` (B, G, R; ``float32``) —
    saturation ≤ ``s_max``, ``v_min`` ≤ value ≤ ``v_max`` — and the sums of their B, G, R
    as they are in ``bgr`` (unscaled)."""
    # Each channel's 256 scaled values, as cv2.transform makes them, looked up per pixel.
    scaled = np.empty((3, 256), np.int64)
    for c in range(3):
        for value in range(256):
            scaled[c, value] = min(255, int(np.rint(np.float32(value) * gains[c])))
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


_warm = False


def warm_up() -> None:
    """Compile the loops (or load them from the cache: ≈ 0.1 s the first time in a process) now,
    at set-up, rather than in the first frame's detection. Cheap after the first call."""
    global _warm
    if _warm:
        return
    tiny = np.zeros((2, 2, 3), np.uint8)
    block_means(np.zeros((4, 4, 3), np.uint8), np.zeros(1, np.intp), np.zeros(1, np.intp), 2)
    saturation_rank(tiny, 0.5)
    grey_sums(tiny, np.ones(3, np.float32), 255, 0, 255)
    _warm = True
