"""Stage 1, colour: palette lookup tables, white balance, value floor, a blob's hues, and the
coverage (α) transform.

- **White balance**: grey world over the frame's low-saturation pixels only, gains clamped to
  ``gain_limits``; it removes colour casts.
- **Value floor**: the palette's value floor scaled to the scene's exposure and at least
  ``val_rel_min`` of its grey level: a colour much darker than its surroundings is brown or
  black, not orange or red.
- **A blob's colours**: its hue histogram, the palette colour of its circular mean hue (red
  wraps 170..10), and the colours it holds in separate hue clusters (touching marks).
- **Coverage**: each pixel projected on the mark-minus-background colour difference with its
  grey component removed gives the share ``α`` of the pixel the mark covers (linear in
  coverage, blind to shading and to the light's level).
"""

from __future__ import annotations

import functools
import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from marknav.vision.detect.base import _DetectorBase, _Frame
from marknav.vision.detect.geometry import Contour, FloatArray, Mat, U8Array
from marknav.vision.detect.kernels import block_means, grey_sums, saturation_rank
from marknav.vision.palette import HUE_MAX, ColourRange

log = logging.getLogger("marknav.vision.detect")

_NO_COLOUR = 255
#: Steps per hue unit of the table that names a mean hue's colour.
_FINE = 4
#: Mark-minus-background colour difference (grey component removed) below which a window has
#: no mark to measure (BGR units).
_MIN_CONTRAST = 12.0
#: Saturation up to which a clipped pixel counts as a near-white in an overexposed frame (a cool
#: cast clipped to (255, 250, 200) is S ≈ 55; an orange surface's clipped highlights S 100-160).
_CLIPPED_S_MAX = 90
#: No gains: the pixels' saturation read as they are.
_UNIT_GAINS = np.ones(3, np.float32)
_HUE_ANGLES = np.arange(HUE_MAX) * (2.0 * math.pi / HUE_MAX)
_HUE_SIN = np.sin(_HUE_ANGLES)
_HUE_COS = np.cos(_HUE_ANGLES)


def _hsv(bgr: Sequence[float]) -> tuple[float, float, float]:
    """OpenCV's 8-bit HSV (hue 0..180, saturation and value 0..255) of one BGR colour."""
    b, g, r = bgr[0], bgr[1], bgr[2]
    v = max(b, g, r)
    span = v - min(b, g, r)
    if v <= 0 or span <= 0:
        return 0.0, 0.0, v
    if v == r:
        h = 60.0 * (g - b) / span
    elif v == g:
        h = 120.0 + 60.0 * (b - r) / span
    else:
        h = 240.0 + 60.0 * (r - g) / span
    return (h % 360.0) / 2.0, 255.0 * span / v, v


def _circular_mean_hue(hist: FloatArray) -> float | None:
    """Circular mean (OpenCV hue units, [0, 180)) of a 180-bin hue histogram."""
    total = float(hist.sum())
    if total <= 0:
        return None
    s = float(np.dot(hist, _HUE_SIN))
    c = float(np.dot(hist, _HUE_COS))
    if math.hypot(s, c) < 1e-6 * total:
        return None
    hue = math.degrees(math.atan2(s, c)) / 2.0
    hue %= HUE_MAX
    if hue >= HUE_MAX - 1e-9:  # ``x % 180`` of a tiny negative number rounds to 180.0
        hue = 0.0
    return hue


@functools.lru_cache(maxsize=8)
def _subsample_origins(h: int, w: int, scale: int) -> tuple[npt.NDArray[np.intp],
                                                            npt.NDArray[np.intp]]:
    """Rows and columns (full resolution) of the top-left pixels of the blocks
    :func:`balance_subsample` reads."""
    sh, sw = (h // scale, w // scale) if scale > 1 else (h, w)
    step = max(1, sw // 48)
    th, tw = max(1, sh // step), max(1, sw // step)
    # cv2.INTER_NEAREST: source index floor(dst · src / dst_size).
    ys = (np.arange(th) * (sh / th)).astype(np.intp) * scale
    xs = (np.arange(tw) * (sw / tw)).astype(np.intp) * scale
    return ys, xs


def balance_subsample(image: U8Array | Mat, scale: int) -> Mat:
    """The subsample :meth:`_ColourStage.white_balance` reads of ``image`` box-reduced by
    ``scale`` (1 or 2), taken from ``image`` itself: the same pixels (nearest neighbour of the
    reduced image, each the mean of its ``scale``×``scale`` block, rounded as ``INTER_AREA``
    rounds it) without reducing the frame."""
    h, w = image.shape[:2]
    if h < scale or w < scale:
        raise ValueError(f"a {w}×{h} image has no {scale}×{scale} block")
    ys, xs = _subsample_origins(h, w, scale)
    out: Mat = block_means(image, ys, xs, scale)
    return out


def _diagonal(gains: tuple[float, float, float]) -> npt.NDArray[np.float32]:
    out = np.zeros((3, 3), np.float32)
    out[0, 0], out[1, 1], out[2, 2] = gains
    return out


@dataclass
class _BlobColours:
    """What a blob's hues say (search resolution)."""

    region: Mat  # the blob's mask pixels in its bounding box
    origin: tuple[int, int]
    counts: FloatArray  # pixels per palette colour
    colour: int | None  # palette colour of the circular mean hue
    purity: float  # share of the blob's pixels in that colour
    present: list[int]  # colours holding a real share of the blob, most first
    split: bool  # two or more of them in separate hue clusters


class _ColourStage(_DetectorBase):
    """Colour: hue tables, white balance, a blob's colours, coverage."""

    @staticmethod
    def _build_hue_lut(palette: Sequence[ColourRange], margin: float) -> Mat:
        """Hue (0..179) → index of the palette colour it belongs to, or 255 for none."""
        lut = np.full(HUE_MAX, _NO_COLOUR, np.uint8)
        for h in range(HUE_MAX):
            best, best_d = _NO_COLOUR, math.inf
            for k, colour in enumerate(palette):
                d = colour.distance(h)
                if d > margin:
                    continue
                if d == 0.0:  # inside: prefer the range whose centre is nearest
                    dc = abs((h - colour.centre_hue + 90.0) % HUE_MAX - 90.0)
                    d = -1.0 / (1.0 + dc)
                if d < best_d:
                    best, best_d = k, d
            lut[h] = best
        return lut

    def _colour_of_hue(self, hue: float) -> int | None:
        """The palette colour whose range holds ``hue`` or lies within ``hue_margin`` of it
        (nearest wins); a table at 1/4 hue step."""
        k = int(self._fine_lut[int(hue * _FINE) % (HUE_MAX * _FINE)])
        return None if k == _NO_COLOUR else k

    @staticmethod
    def _build_fine_lut(palette: Sequence[ColourRange], margin: float) -> Mat:
        lut = np.full(HUE_MAX * _FINE, _NO_COLOUR, np.uint8)
        for i in range(HUE_MAX * _FINE):
            hue = (i + 0.5) / _FINE
            best, best_d = _NO_COLOUR, math.inf
            for k, colour in enumerate(palette):
                d = colour.distance(hue)
                if d <= margin and d < best_d:
                    best, best_d = k, d
            lut[i] = best
        return lut

    def white_balance(self, image: U8Array | Mat) -> tuple[tuple[float, float, float], float]:
        """Grey-world gains (B, G, R) from the low-saturation pixels, and the scene's grey level.

        Measured on a ≈ 48-pixel-wide subsample. Only pixels that already look grey count: the
        less saturated part of the frame (saturation up to 25 above its 40th percentile, within
        60..160, so a strong cast that lifts grey to S ≈ 100 still counts as grey while marks
        at S ≈ 255 do not), neither black nor clipped (unless nearly all greys are clipped, as in
        an overexposed frame: then the clipped near-whites count, S ≤ 90; a bright orange
        surface clipped in red only keeps its own hue, not the light's). A second pass keeps the
        pixels that are grey (``S < 40``) after the first gains. Coloured marks and clutter
        therefore cannot pull the gains, however large they are in the frame. With fewer than
        5 % grey pixels there is nothing to balance against: gains 1. Gains are clamped to
        ``config.gain_limits``.
        """
        h, w = image.shape[:2]
        step = max(1, w // 48)
        tiny = cv2.resize(image, (max(1, w // step), max(1, h // step)),
                          interpolation=cv2.INTER_NEAREST)
        return self.balance_sample(tiny)

    def balance_sample(self, tiny: U8Array | Mat) -> tuple[tuple[float, float, float], float]:
        """:meth:`white_balance` of its ≈ 48-pixel-wide subsample (the per-pixel loops in
        :mod:`.kernels`: saturation and value as OpenCV's BGR→HSV gives them)."""
        gains = (1.0, 1.0, 1.0)
        grey = -1.0
        s_max = min(160, max(60, saturation_rank(tiny, 0.4) + 25))
        enough = 0.05 * (tiny.shape[0] * tiny.shape[1])  # (as 0.05 * mask.size rounds it)
        seen_with = _UNIT_GAINS  # the gains the pixels' saturation is read after
        for attempt in range(2):
            count, sb, sg, sr = grey_sums(tiny, seen_with, s_max, 16, 250)
            if attempt == 0 and count < enough:
                # An overexposed scene: its greys are clipped. Clipping flattens a cast but keeps
                # its direction, so the clipped near-whites still say which way to correct.
                # Only near-whites: a bright surface clipped in one channel (an orange
                # photograph's highlights) keeps its own hue, not the light's.
                count, sb, sg, sr = grey_sums(tiny, seen_with, min(s_max, _CLIPPED_S_MAX), 16,
                                              255)
            if count < enough:
                break
            inv = 1.0 / count  # as cv2.mean scales its sums
            mean = (sb * inv, sg * inv, sr * inv)
            grey = (mean[0] + mean[1] + mean[2]) / 3.0
            b, g, r = self._light_gains(tuple(grey / max(c, 1.0) for c in mean))
            gains = (b, g, r)
            if max(abs(b - 1.0), abs(g - 1.0), abs(r - 1.0)) <= 0.02:
                break
            seen_with = np.array(gains, np.float32)
            s_max = 40
        if grey < 0:  # no grey to measure: the scene's mean level
            m = cv2.mean(tiny)
            grey = (m[0] + m[1] + m[2]) / 3.0
        return gains, grey

    def _light_gains(self, gains: Sequence[float]) -> tuple[float, float, float]:
        """Grey-world ``gains`` (B, G, R) held to what a room's light can do
        (``config.tint_limit``), then clamped to ``gain_limits``.

        Room lights differ mostly along the blue–amber axis (daylight, shade, incandescent: the
        black-body locus). A strong green or magenta excess in a room's greys is the room's own
        colour (a painted wall, a carpet), not the light's. In log gains the correction is split
        into its blue–amber part ``(ln B − ln R)/2``, kept, and its green–magenta part
        ``ln G − (ln B + ln R)/2``, held to ±``tint_limit``; their mean is kept. ``None`` (the
        bare detector's default): plain grey world — photographs from unknown cameras carry
        green tints of their own (a sensor's raw green excess can need −0.25).
        """
        lo, hi = self.config.gain_limits
        limit = self.config.tint_limit
        if limit is not None:
            lb, lg, lr = (math.log(max(1e-3, float(c))) for c in gains[:3])
            mean = (lb + lg + lr) / 3.0
            u = (lb - lr) / 2.0
            v = min(limit, max(-limit, lg - (lb + lr) / 2.0))
            gains = tuple(math.exp(x) for x in (mean + u - v / 3.0, mean + 2.0 * v / 3.0,
                                                mean - u - v / 3.0))
        b, g, r = (min(hi, max(lo, float(c))) for c in gains[:3])
        return b, g, r

    def _value_floor(self, grey: float) -> int:
        cfg = self.config
        return int(max(self._val_min * self._exposure(grey), cfg.val_rel_min * grey))

    def _exposure(self, grey: float) -> float:
        """How far a scene of grey level ``grey`` falls short of ``val_ref_grey`` (1 at or
        above it): the floors that hold for a lit scene scale down with it."""
        ref = self.config.val_ref_grey
        return min(1.0, grey / ref) if ref > 0 else 1.0

    def _colours(self, frame: _Frame, contour: Contour,
                 box: tuple[int, int, int, int]) -> _BlobColours:
        """The blob's hue histogram, the palette colour of its circular mean hue, and the
        colours it holds in separate hue clusters (touching marks of different colours)."""
        cfg = self.config
        bx, by, bw, bh = box
        region = np.zeros((bh, bw), np.uint8)
        cv2.drawContours(region, [contour], -1, 255, cv2.FILLED, offset=(-bx, -by))
        cv2.bitwise_and(region, frame.mask[by:by + bh, bx:bx + bw], dst=region)
        hist = np.asarray(cv2.calcHist([frame.hsv[by:by + bh, bx:bx + bw]], [0], region,
                                       [HUE_MAX], [0, HUE_MAX]), np.float64).ravel()
        total = float(hist.sum())
        counts = self._membership @ hist
        mean_hue = _circular_mean_hue(hist)
        colour = None if mean_hue is None else self._colour_of_hue(mean_hue)
        if colour is None:
            log.debug("blob at (%d, %d): hue %s in no palette range", bx * frame.sx,
                      by * frame.sy, mean_hue)
        min_count = 0.5 * math.pi * (cfg.min_partial_radius / frame.sx) ** 2
        present = sorted((k for k in range(len(self.palette)) if counts[k] >= min_count),
                         key=lambda k: -counts[k])
        split = len(present) >= 2 and self._distinct_hues(hist, present)
        purity = float(counts[colour]) / total if colour is not None and total > 0 else 0.0
        return _BlobColours(region, (bx, by), counts, colour, purity, present, split)

    def _meets_floors(self, frame: _Frame, colours: _BlobColours) -> bool:
        """The blob's mean saturation and value reach its colour's own floors (when the
        palette's floors differ; the mask used the lowest)."""
        if self._uniform_floors or colours.colour is None:
            return True
        spec = self.palette[colours.colour]
        x0, y0 = colours.origin
        h, w = colours.region.shape
        mean = cv2.mean(frame.hsv[y0:y0 + h, x0:x0 + w], mask=colours.region)
        return mean[1] >= spec.sat_min and mean[2] >= spec.val_min

    def _distinct_hues(self, hist: FloatArray, order: list[int]) -> bool:
        """Whether the blob's colours are separate hue clusters (touching marks of different
        colours), not one mark whose shading straddles a palette boundary."""
        means = []
        for k in order:
            mean = _circular_mean_hue(hist * self._membership[k])
            if mean is not None:
                means.append(mean)
        for i, a in enumerate(means):
            for b in means[i + 1:]:
                if abs((a - b + 90.0) % HUE_MAX - 90.0) >= self.config.split_hue_gap:
                    return True
        return False

    @staticmethod
    def _alpha_transform(mark_bgr: Sequence[float],
                         back_bgr: Sequence[float]) -> npt.NDArray[np.float32] | None:
        """The 1×4 matrix mapping BGR to 255·α, α = the pixel's coverage by the mark.

        α is the projection of (pixel − background) on (mark − background), both with their
        grey component removed: linear in coverage (so α = 0.5 is the edge, whatever the blur),
        and unmoved by shading, shadows and the light's level. ``None`` when the mark's colour
        hardly differs from the background's.
        """
        d0, d1, d2 = (mark_bgr[0] - back_bgr[0], mark_bgr[1] - back_bgr[1],
                      mark_bgr[2] - back_bgr[2])
        grey = (d0 + d1 + d2) / 3.0
        d0, d1, d2 = d0 - grey, d1 - grey, d2 - grey
        n2 = d0 * d0 + d1 * d1 + d2 * d2
        if n2 < _MIN_CONTRAST ** 2:
            return None
        k = 255.0 / n2
        w0, w1, w2 = k * d0, k * d1, k * d2
        offset = -(w0 * back_bgr[0] + w1 * back_bgr[1] + w2 * back_bgr[2])
        return np.array([[w0, w1, w2, offset]], np.float32)


def _window_sum(hist: npt.NDArray[np.float64], half: int) -> npt.NDArray[np.float64]:
    """Sum of a circular histogram over ±``half`` bins around each bin."""
    padded = np.concatenate([hist[-half - 1:], hist, hist[:half]])
    cs = np.cumsum(padded)
    out: npt.NDArray[np.float64] = cs[2 * half + 1:] - cs[:len(hist)]
    return out


def _hue_peaks(hist: npt.NDArray[np.float64], min_count: float, gap: float) -> list[float]:
    """Hues (OpenCV units) of the separate clusters of a circular hue histogram: local maxima of
    the histogram smoothed over ±2 hue, at least ``gap`` apart, each holding ``min_count``
    pixels within ``gap / 2`` of it, largest first."""
    n = len(hist)
    smooth = _window_sum(hist, 2)
    near = _window_sum(hist, max(1, int(gap // 2)))
    left = np.concatenate([smooth[-1:], smooth[:-1]])
    right = np.concatenate([smooth[1:], smooth[:1]])
    is_peak = (smooth > 0) & (smooth >= left) & (smooth >= right) & (near >= min_count)
    candidates = np.flatnonzero(is_peak)
    if len(candidates) < 2:
        return []
    peaks: list[float] = []
    for i in candidates[np.argsort(-smooth[candidates], kind="stable")].tolist():
        if all(abs((i - p + n / 2) % n - n / 2) >= gap for p in peaks):
            peaks.append(float(i))
    return peaks
