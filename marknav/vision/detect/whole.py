"""Stage 2, the fast path: an isolated whole mark (inside the image, convex).

The ellipse with the contour's area and second moments must follow every contour point (radial
deviation, axis ratio), and the convex hull must have no straight cut (an occluder's edge). The
mark is then measured in a small window (at full resolution; marks of ``fine_radius`` and more
in the half-resolution image, whose box-averaged pixels keep coverage linear): the ``α >= 0.5``
pixels (the mid-level of chroma) give area, centroid and shape by image moments (the pixel count
is an unbiased area), so the radius is not biased by blur or by where a contour runs through the
edge pixels; their mismatch with the fitted ellipse must be small (``max_outline_error``). The
colour is the palette colour of the mark's mean (white-balanced) hue.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from marknav.vision.detect.base import _Frame
from marknav.vision.detect.colour import _MIN_CONTRAST, _ColourStage, _hsv
from marknav.vision.detect.geometry import (
    Contour,
    Mat,
    _draw,
    _Ellipse,
    _moments_ellipse,
    _paste,
)
from marknav.vision.detect.kernels import quadrants_differ, radius_range
from marknav.vision.detect.model import Mark

log = logging.getLogger("marknav.vision.detect")

#: Bands around a coarse ellipse in the full-resolution window (px beyond its outline): the
#: mark is counted inside ``_DOMAIN``; the window reaches ``_BACK`` beyond the outline and its
#: pixels outside the domain are the background.
_DOMAIN = 4.0
_BACK = 8.0
#: Sectors around a whole mark whose backgrounds are told apart when they differ.
_SECTORS = 8
#: Chroma difference (BGR units, grey removed) between two sectors' backgrounds from which
#: they are told apart (a textured floor or a cast stays below it; a board of a near colour,
#: a wood floor under a grey wall do not).
_SECTOR_SPREAD = 30.0
#: The quadrants' chroma spread from which the sectors are looked at (below ``_SECTOR_SPREAD``:
#: a quadrant averages two sectors).
_QUADRANT_SPREAD = 15.0
#: One row per sector (sums per sector through one product).
_ONE_HOT = np.eye(_SECTORS)


@dataclass
class _Measured:
    """A whole mark measured in one image (that image's pixels)."""

    ellipse: _Ellipse
    error: float  # pixel/ellipse mismatch per pixel of outline
    mark_bgr: tuple[float, float, float]  # mean colour inside the mark


class _WholeMarks(_ColourStage):
    """The fast path: whole marks measured by their coverage's moments."""

    def _whole_fit(self, contour: Contour, *, tolerance_px: float) -> _Ellipse | None:
        """The ellipse with a closed contour's area and second moments, if the contour is one:
        every contour point within ``max(tolerance_px, 9 % of the major axis)`` of it (radially),
        axis ratio at least ``min_axis_ratio``. ``tolerance_px`` is one pixel of the contour's
        own resolution."""
        e = _moments_ellipse(cv2.moments(contour))
        if e is None or e.minor < self.config.min_axis_ratio * 0.9 * e.major:
            return None
        # Normalised radius of every contour point: (u/a)² + (v/b)².
        lo, hi = radius_range(contour.reshape(-1, 2), e.cx, e.cy, e.a, e.b, e.theta)
        limit = max(tolerance_px, 0.09 * e.major) / math.sqrt(e.a * e.b)
        if math.sqrt(hi) > 1.0 + limit or math.sqrt(lo) < 1.0 - limit:
            return None
        return e

    @staticmethod
    def _to_full(frame: _Frame, e: _Ellipse) -> _Ellipse:
        """A search-resolution ellipse in full-resolution pixels (pixel centres at integers)."""
        return _Ellipse((e.cx + 0.5) * frame.sx - 0.5, (e.cy + 0.5) * frame.sy - 0.5,
                        e.a * frame.sx, e.b * frame.sy, e.theta)

    def _measure_whole(self, frame: _Frame, coarse: _Ellipse, colour: int | None,
                       purity: float, exclude: tuple[Mat, int, int] | None = None,
                       bridge_px: float = 0.0) -> Mark | None:
        """A whole mark measured near its coarse ellipse (full-resolution pixels): the pixels
        with α >= 0.5 inside the coarse outline grown by ``_DOMAIN`` px give area, centroid and
        shape (image moments); the pixel/ellipse mismatch checks the shape. ``exclude`` (a mask
        and its origin in the image) holds pixels of touching marks of other colours.

        Marks larger than ``config.fine_radius`` are measured in the search image: its pixels
        are box averages, which carry each pixel's coverage linearly, so the α = 0.5 count is as
        unbiased there and costs a quarter.

        With ``colour`` None, the colour is the palette colour of the mark's mean hue (white
        balanced), and the purity says how squarely that hue lies in the colour's range.
        """
        cfg = self.config
        limit = cfg.max_outline_error
        if exclude is None and frame.sx > 1 and coarse.major >= cfg.fine_radius:
            limit = cfg.max_search_outline_error
            sx, sy = frame.sx, frame.sy
            local = _Ellipse((coarse.cx + 0.5) / sx - 0.5, (coarse.cy + 0.5) / sy - 0.5,
                             coarse.a / sx, coarse.b / sy, coarse.theta)
            measured = self._measure_in(frame.small, local, None, sx, bridge_px)
            if measured is None:
                return None
            e = measured.ellipse
            fitted = _Ellipse((e.cx + 0.5) * sx - 0.5, (e.cy + 0.5) * sy - 0.5, e.a * sx,
                              e.b * sy, e.theta)
            balanced = measured.mark_bgr  # the search image is white-balanced
        else:
            measured = self._measure_in(frame.image, coarse, exclude, 1.0, bridge_px)
            if measured is None:
                return None
            fitted = measured.ellipse
            b, g, r = measured.mark_bgr
            gb, gg, gr = self.last_gains
            # Saturated as the balanced search image is: a channel clipped at 255 stays 255
            # (a bright yellow mark, R and G clipped, times a red gain of 1.2 read orange).
            balanced = (min(255.0, b * gb), min(255.0, g * gg), min(255.0, r * gr))
        error = measured.error
        if error > limit:
            log.debug("whole mark at (%.1f, %.1f) r=%.1f: outline error %.2f px",
                      fitted.cx, fitted.cy, fitted.major, error)
            return None
        moved = math.hypot(fitted.cx - coarse.cx, fitted.cy - coarse.cy)
        if moved > 0.25 * coarse.major + 1.5 or \
                abs(fitted.major - coarse.major) > 0.25 * coarse.major + 1.5:
            log.debug("whole mark at (%.1f, %.1f) r=%.1f moved to (%.1f, %.1f) r=%.1f",
                      coarse.cx, coarse.cy, coarse.major, fitted.cx, fitted.cy, fitted.major)
            return None
        if colour is None:
            hue, sat, val = _hsv(balanced)
            colour = self._colour_of_hue(hue)
            if colour is None:
                log.debug("whole mark at (%.1f, %.1f): mean hue %.1f in no palette range",
                          fitted.cx, fitted.cy, hue)
                return None
            spec = self.palette[colour]
            if not self._uniform_floors and (sat < spec.sat_min or val < spec.val_min):
                return None
            purity = 1.0 - 0.5 * spec.distance(hue) / max(cfg.hue_margin, 1e-9)
        quality = max(0.0, 1.0 - 0.5 * error / limit)
        return self._mark(fitted, colour, purity * quality)

    def _measure_in(self, image: Mat, coarse: _Ellipse,
                    exclude: tuple[Mat, int, int] | None,
                    scale: float = 1.0, bridge_px: float = 0.0) -> _Measured | None:
        """The α >= 0.5 pixels near ``coarse``, in ``image``'s own pixels (``scale`` full
        pixels each): their ellipse, its outline error and the mark's mean colour."""
        h, w = image.shape[:2]
        domain_px = _DOMAIN / scale + 0.5
        reach = coarse.major + _BACK / scale + 1.0
        x0 = max(0, math.floor(coarse.cx - reach))
        y0 = max(0, math.floor(coarse.cy - reach))
        x1 = min(w, math.ceil(coarse.cx + reach) + 1)
        y1 = min(h, math.ceil(coarse.cy + reach) + 1)
        if x1 - x0 < 3 or y1 - y0 < 3:
            return None
        roi = image[y0:y1, x0:x1]
        shape = (y1 - y0, x1 - x0)
        local = _Ellipse(coarse.cx - x0, coarse.cy - y0, coarse.a, coarse.b, coarse.theta)
        inner = _draw(shape, local.scaled(-max(1.0, 0.3 * local.minor)))
        domain = _draw(shape, local.scaled(domain_px))
        # The background: the window outside the domain (its corners reach ≈ _BACK px out).
        back = cv2.bitwise_not(domain)
        if exclude is not None:
            excluded = _paste(exclude, x0, y0, shape)
            cv2.subtract(back, excluded, dst=back)
            cv2.subtract(domain, excluded, dst=domain)
        if cv2.countNonZero(back) < 8:
            return None
        mark_bgr = cv2.mean(roi, mask=inner)
        transform = self._alpha_transform(mark_bgr, cv2.mean(roi, mask=back))
        if transform is None:
            return None
        binary = cv2.threshold(cv2.transform(roi, transform), 127, 255, cv2.THRESH_BINARY)[1]
        self._sector_alpha(roi, local, back, mark_bgr, binary, (domain, inner))
        cv2.bitwise_and(binary, domain, dst=binary)
        cv2.bitwise_or(binary, inner, dst=binary)
        if bridge_px > 0:
            # Thin occluders across the mark (poles, wires, seams) up to ``bridge_px`` wide:
            # a closing restores the disc (it leaves a convex outline as it is).
            k = 2 * math.ceil((bridge_px / scale + 2.0) / 2.0) + 1
            kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))
            cv2.morphologyEx(binary, cv2.MORPH_CLOSE, kernel, dst=binary)
            cv2.bitwise_and(binary, domain, dst=binary)
        fitted = _moments_ellipse(cv2.moments(binary, binaryImage=True))
        if fitted is None:
            return None
        mismatch = cv2.countNonZero(cv2.bitwise_xor(binary, _draw(shape, fitted)))
        error = mismatch / max(fitted.perimeter(), 1.0)
        out = _Ellipse(fitted.cx + x0, fitted.cy + y0, fitted.a, fitted.b, fitted.theta)
        return _Measured(out, error, (mark_bgr[0], mark_bgr[1], mark_bgr[2]))

    def _sector_alpha(self, roi: Mat, local: _Ellipse, back: Mat,
                      mark_bgr: Sequence[float], binary: Mat,
                      band: tuple[Mat, Mat]) -> None:
        """Where the background differs around the mark (a floor below it and a wall above, a
        board of a near colour beside it), ``binary`` is redone against the backgrounds
        actually there: the mean colours of ``_SECTORS`` sectors around the centre are the
        candidates, and each pixel takes its coverage against the candidate of its own sector
        or the two beside it that explains it best as a mix of the mark's colour and that
        background (the least distance, grey removed, from the line through the two). Against
        the mean background a near-colour board counts as half mark; against only its own
        sector's mean, a sector holding both the board and the wall beside it still reads the
        board's pixels there as mark (composite frame 32: a small blue mark beside a violet
        board was lost). Neighbours only: backgrounds from across the mark would explain some
        clutter's pixels too (a blue patch between a jersey's red stripes became a mark).
        ``band`` (domain, inner): only the pixels inside the domain and outside the inner
        ellipse are redone, the others the caller decides alone."""
        if not _quadrants_differ(roi, local, back):
            return
        ys, xs = np.nonzero(back)
        if len(ys) < 8:
            return
        step = max(1, len(ys) // 384)  # a few hundred samples tell the sectors' colours
        ys, xs = ys[::step], xs[::step]
        sectors = _sector_of(xs - local.cx, ys - local.cy)
        counts = np.bincount(sectors, minlength=_SECTORS).astype(np.float64)
        sums = _ONE_HOT[sectors].T @ roi[ys, xs].astype(np.float64)  # (sector, channel)
        known = counts >= 3
        if int(known.sum()) < 2:
            return
        means = sums[known] / counts[known, None]
        chroma = means - means.mean(axis=1, keepdims=True)
        diff = chroma[:, None, :] - chroma[None, :, :]
        if float(np.max(np.einsum("ijk,ijk->ij", diff, diff))) < _SECTOR_SPREAD ** 2:
            return
        # Per candidate background b (grey removed: chroma c_b) and the mark's direction
        # d = c_m - c_b: the coverage α = <c_p - c_b, d>/|d|², linear in the pixel, and the
        # squared distance from the line, |c_p - c_b|² - α²|d|², which up to the pixel's own
        # |c_p|² (the same for every candidate) is |c_b|² - 2<p, c_b> - α²|d|².
        d = np.asarray(mark_bgr[:3], np.float64)[None, :] - means
        d -= d.mean(axis=1, keepdims=True)
        n2 = np.einsum("ij,ij->i", d, d)
        contrast = n2 >= _MIN_CONTRAST ** 2
        if not contrast.any():
            return
        d, n2, c_b = d[contrast], n2[contrast], chroma[contrast]
        wts = d / n2[:, None]  # α = p·w + offset
        offset = -np.einsum("ij,ij->i", wts, means[contrast])
        w = roi.shape[1]
        domain, inner = band
        where = np.flatnonzero((domain > inner).ravel())  # in the domain, not in the inner
        if len(where) == 0:
            return
        pixels = roi.reshape(-1, 3)[where].astype(np.float32)
        linear = pixels @ np.concatenate([wts, c_b]).T.astype(np.float32)  # (pixels, 2k)
        k = len(n2)
        alpha = linear[:, :k] + offset.astype(np.float32)
        dist = (np.einsum("ij,ij->i", c_b, c_b).astype(np.float32) - 2.0 * linear[:, k:]
                - alpha * alpha * n2.astype(np.float32))
        # Only the backgrounds of the pixel's own sector and its two neighbours compete.
        rows = np.flatnonzero(known)[contrast]
        sector = _sector_of(where % w - local.cx, where // w - local.cy)
        apart = np.abs((sector[:, None] - rows[None, :] + _SECTORS // 2) % _SECTORS
                       - _SECTORS // 2)
        dist[apart > 1] = np.inf
        best = np.argmin(dist, axis=1)
        usable = np.isfinite(dist[np.arange(len(best)), best])
        chosen = alpha[np.arange(len(best)), best]
        np.put(binary, where[usable], np.where(chosen[usable] >= 127.5 / 255.0, 255, 0))


def _quadrants_differ(roi: Mat, local: _Ellipse, back: Mat) -> bool:
    """Whether the background's colour may differ around the mark: the chroma of its four
    quadrants (about the centre) spreads by more than ``_QUADRANT_SPREAD``
    (:func:`.kernels.quadrants_differ`), so that the sector split is only paid for where it
    may matter."""
    h, w = roi.shape[:2]
    cx, cy = min(max(1, round(local.cx)), w - 1), min(max(1, round(local.cy)), h - 1)
    return bool(quadrants_differ(roi, back, cx, cy, _QUADRANT_SPREAD))


def _sector_of(dx: npt.NDArray[np.floating[Any]], dy: npt.NDArray[np.floating[Any]],
               ) -> npt.NDArray[np.intp]:
    """Index (0.._SECTORS-1) of the angular sector of each offset from a centre."""
    ang = np.arctan2(dy, dx)
    out: npt.NDArray[np.intp] = (np.floor((ang + math.pi) * (_SECTORS / (2.0 * math.pi)))
                                 .astype(np.intp) % _SECTORS)
    return out
