"""The pipeline: search mask at half resolution, cheap rejection, then per blob the fast path
(:mod:`.whole`) or the arc path (:mod:`.arcs`), then suppression (:mod:`.suppress`).

1. **Search at half resolution** (``DetectorConfig.downscale``): the frame is box-reduced
   (``INTER_AREA``) and white-balanced (:mod:`.colour`); one HSV mask ``S >= sat_min,
   V >= v_floor``, a 3×3 opening and external contours give the blobs.
2. **Cheap rejection** with a handful of OpenCV calls: blobs too small, too thin (stripes),
   rectangle-like (area / minimum bounding rectangle > ``max_extent``), small triangles (<
   ``min_small_extent`` of it).
3. Whole marks take the fast path, the rest the arc path; duplicates are suppressed.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Sequence

import cv2
import numpy as np

from marknav.vision.detect.arcs import _ArcMarks
from marknav.vision.detect.base import _Frame
from marknav.vision.detect.colour import _NO_COLOUR, _diagonal, _hue_peaks, balance_subsample
from marknav.vision.detect.faint import chroma_contrast
from marknav.vision.detect.gate import SearchBuffers, search_products
from marknav.vision.detect.geometry import (
    Contour,
    Mat,
    U8Array,
    _flat_stretch,
    _from_rotated_rect,
    _longest_edge,
)
from marknav.vision.detect.glow import is_glow
from marknav.vision.detect.kernels import warm_up
from marknav.vision.detect.model import DetectorConfig, Mark
from marknav.vision.detect.suppress import _suppress_duplicates
from marknav.vision.palette import DEFAULT_PALETTE, HUE_MAX, Palette

__all__ = ["Detector", "detect_marks"]

log = logging.getLogger("marknav.vision.detect")

#: The share of ``min_chroma_contrast`` a mark cut out of a floor of its own hue by saturation
#: must reach (the cut has measured a saturation gap; the colour difference is small).
_SATURATION_CUT_SHARE = 2.0 / 3.0


class Detector(_ArcMarks):
    """Finds palette-coloured circular/elliptical marks in BGR frames.

    Reuse one detector for a stream of frames (it builds its lookup tables once). Not
    thread-safe: use one detector per thread.
    """

    def __init__(self, palette: Palette = DEFAULT_PALETTE,
                 config: DetectorConfig | None = None) -> None:
        if not palette:
            raise ValueError("the palette is empty")
        if len(palette) >= _NO_COLOUR:
            raise ValueError(f"at most {_NO_COLOUR - 1} colours, got {len(palette)}")
        self.palette: Palette = tuple(palette)
        self.config = config if config is not None else DetectorConfig()
        #: The config as given; ``config`` is it scaled for the last frame's width.
        self._base_config = self.config
        self._width = -1
        self._sat_min = min(c.sat_min for c in self.palette)
        self._val_min = min(c.val_min for c in self.palette)
        self._uniform_floors = all(
            c.sat_min == self._sat_min and c.val_min == self._val_min for c in self.palette
        )
        hue_lut = self._build_hue_lut(self.palette, self.config.hue_margin)
        self._hue_lut = np.full(256, _NO_COLOUR, np.uint8)
        self._hue_lut[:HUE_MAX] = hue_lut
        self._fine_lut = self._build_fine_lut(self.palette, self.config.hue_margin)
        self._gate_lut = np.where(self._hue_lut == _NO_COLOUR, 0, 255).astype(np.uint8)
        self._membership = np.zeros((len(self.palette), HUE_MAX), np.float64)
        for k in range(len(self.palette)):
            self._membership[k, hue_lut == k] = 1.0
        size = self.config.open_size
        self._kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (size, size))
        self._kernel3 = cv2.getStructuringElement(cv2.MORPH_RECT, (3, 3))
        self.last_gains: tuple[float, float, float] = (1.0, 1.0, 1.0)
        self.last_grey_level: float = 0.0
        #: Blob readings the last frame did not get (``DetectorConfig.max_readings``; at
        #: least: a blob left unread is not split into the parts it would have given), and
        #: the frames so far that were cut short so.
        self.last_skipped = 0
        self.crowded_frames = 0
        #: Blob readings the last frame got.
        self.last_readings = 0
        self._readings_left = 0
        self._buffers = SearchBuffers()
        warm_up()  # the detector's compiled loops, loaded before the first frame

    def detect(self, image: U8Array) -> list[Mark]:
        """All marks in a BGR ``uint8`` image (H×W×3), largest first."""
        if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim != 3 \
                or image.shape[2] != 3:
            raise ValueError("detect() needs a BGR uint8 image of shape (H, W, 3)")
        h, w = image.shape[:2]
        if w != self._width:
            self._width = w
            self.config = self._base_config.for_width(w)
        cfg = self.config
        scale = cfg.downscale if min(h, w) >= 64 * cfg.downscale else 1
        sw, sh = (w // scale, h // scale) if scale > 1 else (w, h)
        # The coarse gate (:mod:`.gate`) needs marks of at least 4 px radius and the
        # half-resolution search it narrows down.
        gated = cfg.coarse_gate and scale > 1 and cfg.min_radius >= 4.0
        whole = None
        if not gated and scale > 1:
            # Whole search pixels only (an odd last row/column is left out), so that each is
            # the mean of its 2×2 block, as in the coarse gate's rectangles.
            whole = cv2.resize(image[:sh * scale, :sw * scale], (sw, sh),
                               interpolation=cv2.INTER_AREA)
        if cfg.white_balance:
            gains, grey = (self.white_balance(whole) if whole is not None else
                           self.balance_sample(balance_subsample(image, scale)))
        else:
            gains, grey = (1.0, 1.0, 1.0), float(np.mean(cv2.mean(image)[:3]))
        self.last_gains, self.last_grey_level = gains, grey
        balance = _diagonal(gains) if max(abs(g - 1.0) for g in gains) > 0.02 else None
        v_floor = self._value_floor(grey)
        products = search_products(image, (sw, sh), scale, gated, whole, balance, self._sat_min,
                                   v_floor, self._gate_lut if cfg.hue_gate else None,
                                   self._kernel if cfg.open_size > 1 else None,
                                   self._buffers, self._horizon_band(h, scale))
        small, hsv, mask = products.small, products.hsv, products.mask
        self.last_skipped, self.last_readings, self._readings_left = 0, 0, cfg.max_readings
        if products.boxes is not None and not products.boxes:
            return []  # no seed anywhere (the gate's rectangles): an empty mask, no blob
        contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
        frame = _Frame(image, w, h, small, hsv, mask, float(scale), float(scale), balance,
                       v_floor)
        min_area = 0.4 * math.pi * (cfg.min_radius / scale) ** 2
        band = self._horizon_band(h, scale)
        marks: list[Mark] = []
        # Marks cut out by saturation stand apart from a floor of their own hue by a saturation
        # gap the cut has measured (>= split_saturation_gap); their colour difference to it is
        # small (a green disc on a green carpet: chroma 36-41 at floor S 170-180): the faint test
        # holds them to two thirds of its floor (small clutter the cut finds measures 17-24).
        by_saturation: list[Mark] = []  # (held, so that their ids stay theirs)
        candidates: list[tuple[int, Contour, float]] = []
        for i, contour in enumerate(contours):
            if len(contour) < 6:
                continue
            area = cv2.contourArea(contour)
            if area < min_area:
                continue
            if band is not None:
                _, y, _, bh = cv2.boundingRect(contour)
                if y > band[1] or y + bh < band[0]:
                    continue
            candidates.append((i, contour, area))
        # Read largest first (a crowded frame's readings go to the nearest marks), reported in
        # the contours' order.
        by_blob: dict[int, list[Mark]] = {}
        for i, contour, area in sorted(candidates, key=lambda c: -c[2]):
            if self._readings_left <= 0:
                self.last_skipped += 1
                continue
            found = self._blob(frame, contour, area)
            if not found:
                # Read again per hue, and cut by saturation (a mark on a floor of its own hue
                # inside a blob whose other colours the hue split found); duplicates go below.
                if cfg.split_colours:
                    found = self._split_hues(frame, contour, area, min_area)
                if cfg.split_saturation_gap > 0:
                    cut = self._split_saturation(frame, contour, area, min_area)
                    by_saturation.extend(cut)
                    found = found + cut
            by_blob[i] = found
        marks.extend(m for i in sorted(by_blob) for m in by_blob[i])
        if cfg.bridge_px > 0 and len(contours) >= 2:
            # Any blobs may be pieces of a mark cut by a thin occluder (a piece can give a
            # partial mark of the wrong size on its own: the joined whole then outscores it).
            marks.extend(self._bridged(frame, contours, min_area))
        if band is not None:
            lo, hi = (band[0] + 0.5) * scale - 0.5, (band[1] + 0.5) * scale - 0.5
            marks = [m for m in marks if lo <= m.y <= hi]
        marks = _suppress_duplicates(marks)
        if cfg.reject_glows:
            marks = [m for m in marks if not is_glow(image, m)]
        if cfg.min_chroma_contrast > 0 and marks:
            cut_ids = {id(m) for m in by_saturation}
            marks = [m for m in marks
                     if not self._faint(image, m, _SATURATION_CUT_SHARE if id(m) in cut_ids
                                        else 1.0)]
        marks.sort(key=lambda m: (-m.radius, m.x, m.y))
        self.last_readings = cfg.max_readings - self._readings_left
        if self.last_skipped:
            self.crowded_frames += 1
            (log.warning if self.crowded_frames == 1 else log.debug)(
                "a crowded frame: %d blob readings left unread after the first %d "
                "(DetectorConfig.max_readings; %d such frames so far)",
                self.last_skipped, cfg.max_readings, self.crowded_frames)
        return marks

    def _reading(self) -> bool:
        """Whether the frame's budget (``max_readings``) allows one more blob reading (spent
        if so; counted in ``last_skipped`` if not)."""
        if self._readings_left > 0:
            self._readings_left -= 1
            return True
        self.last_skipped += 1
        return False

    def _faint(self, image: U8Array, mark: Mark, share: float = 1.0) -> bool:
        """Whether ``mark``'s colour hardly stands out from its surroundings (:mod:`.faint`):
        below ``share`` of ``min_chroma_contrast``, scaled down in scenes darker than
        ``val_ref_grey``."""
        cfg = self.config
        contrast = chroma_contrast(image, mark, self.last_gains)
        if contrast is None:
            return False
        return contrast < share * cfg.min_chroma_contrast * self._exposure(self.last_grey_level)

    def _horizon_band(self, height: int, scale: int) -> tuple[float, float] | None:
        """Rows (search resolution) where mark centres may lie, or None without the prior."""
        cfg = self.config
        if cfg.horizon_row is None:
            return None
        row = (cfg.horizon_row + 0.5) / scale - 0.5
        tol = cfg.horizon_tolerance_px / scale
        return (row - tol, row + tol)

    def _bridged(self, frame: _Frame, contours: Sequence[Contour],
                 min_area: float) -> list[Mark]:
        """Whole marks cut into pieces by thin occluders: the search mask closed across gaps
        of up to ``bridge_px`` (full-resolution px); where that joins blobs, each palette
        colour's pixels there are closed on their own, and a closed shape made of two or more
        pieces is tried as one whole mark, its measurement closed across the occluder."""
        cfg = self.config
        sh, sw = frame.mask.shape
        # The opening and the blur widen the gap by about a search pixel on each side.
        k = 2 * math.ceil((cfg.bridge_px / frame.sx + 2.0) / 2.0) + 1
        kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))
        # The closing only changes pixels within k of the mask's own: it is computed on the
        # mask's bounding box grown by k + 1 (the same pixels and outlines as on the whole mask).
        bx, by, bw, bh = cv2.boundingRect(frame.mask)
        cx0, cy0 = max(0, bx - k - 1), max(0, by - k - 1)
        cx1, cy1 = min(sw, bx + bw + k + 1), min(sh, by + bh + k + 1)
        closed = cv2.morphologyEx(frame.mask[cy0:cy1, cx0:cx1], cv2.MORPH_CLOSE, kernel)
        joined, _ = cv2.findContours(closed, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE,
                                     offset=(cx0, cy0))
        if len(joined) >= len(contours):
            return []  # nothing joined
        firsts = [tuple(float(v) for v in c[0, 0]) for c in contours]
        marks: list[Mark] = []
        for outline in joined:
            if len(outline) < 6 or cv2.contourArea(outline) < 2 * min_area:
                continue
            inside = [c for c, p in zip(contours, firsts, strict=True)
                      if cv2.pointPolygonTest(outline, p, False) >= 0]
            if len(inside) < 2:
                continue
            if self._readings_left <= 0:
                self.last_skipped += 1  # a joined shape left unread (and the rest with it)
                break
            whole = self._bridged_one(frame, outline, min_area) or \
                self._without_bars(frame, inside, kernel, min_area)
            if whole:
                marks.extend(whole)
                continue
            x0, y0, bw, bh = cv2.boundingRect(outline)
            if bw * bh > 0.3 * sw * sh:
                # A large region (a floor, a wall, the sky): only the joined pieces are read
                # colour by colour, not everything in its box (a blue mark cut by a pole and
                # joined to a wood floor of another palette colour), and only marks large
                # against the occluder count (≥ 3 × bridge_px): a shirt's small blue patches
                # across its red stripes are no mark.
                pieces = [p for p in inside if cv2.contourArea(p) >= 0.25 * min_area]
                if len(pieces) < 2:
                    continue
                box = self._grown(cv2.boundingRect(np.concatenate(pieces)), k, sw, sh)
                region = np.zeros((box[3] - box[1], box[2] - box[0]), np.uint8)
                cv2.drawContours(region, pieces, -1, 255, cv2.FILLED, offset=(-box[0], -box[1]))
                cv2.bitwise_and(region, frame.mask[box[1]:box[3], box[0]:box[2]], dst=region)
                found = self._colour_by_colour(frame, region, box, kernel, min_area)
                marks.extend(m for m in found if m.radius >= 3.0 * cfg.bridge_px)
            else:
                box = self._grown((x0, y0, bw, bh), k, sw, sh)
                region = frame.mask[box[1]:box[3], box[0]:box[2]]
                marks.extend(self._colour_by_colour(frame, region, box, kernel, min_area))
        return marks

    @staticmethod
    def _grown(rect: Sequence[int], k: int, sw: int, sh: int) -> tuple[int, int, int, int]:
        """(x0, y0, x1, y1): a bounding rectangle grown by ``k`` (search px) inside the image."""
        x0, y0, bw, bh = rect
        x0, y0 = max(0, x0 - k), max(0, y0 - k)
        return x0, y0, min(sw, x0 + bw + 2 * k), min(sh, y0 + bh + 2 * k)

    def _colour_by_colour(self, frame: _Frame, region: Mat, box: tuple[int, int, int, int],
                          kernel: Mat, min_area: float) -> list[Mark]:
        """Each palette colour's pixels of ``region`` (the search mask's pixels to read, in
        ``box``) closed on their own; each closed shape made of two or more pieces is tried as
        one whole mark."""
        x0, y0, x1, y1 = box
        labels = cv2.LUT(np.ascontiguousarray(frame.hsv[y0:y1, x0:x1, 0]), self._hue_lut)
        marks: list[Mark] = []
        for colour in range(len(self.palette)):
            own = cv2.bitwise_and(cv2.inRange(labels, colour, colour), region)
            if cv2.countNonZero(own) < 2 * min_area:
                continue
            n, _ = cv2.connectedComponents(own)
            if n < 3:  # background and at least two pieces
                continue
            marks.extend(self._closed_marks(frame, own, (x0, y0), kernel, min_area))
        return marks

    def _closed_marks(self, frame: _Frame, pieces: Mat, origin: tuple[int, int], kernel: Mat,
                      min_area: float, exclude: tuple[Mat, int, int] | None = None,
                      ) -> list[Mark]:
        """``pieces`` (a search-resolution mask placed at ``origin``) closed across gaps with
        ``kernel``; each closed shape tried as one whole mark (:meth:`_bridged_one`)."""
        shut = cv2.morphologyEx(pieces, cv2.MORPH_CLOSE, kernel)
        shapes, _ = cv2.findContours(shut, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE,
                                     offset=origin)
        marks: list[Mark] = []
        for shape in shapes:
            marks.extend(self._bridged_one(frame, shape, min_area, exclude))
        return marks

    def _bar_like(self, contour: Contour, area: float, scale: float) -> tuple[float, float]:
        """The contour's minimum bounding rectangle's sides, or (-1, -1) when it is no mark's
        piece (the cheap clutter rejection): slivers and stripes (a mark's visible part, even cut
        by the image edge down to ``min_arc`` of its outline, is at least a quarter as wide as
        long) and rectangles (they fill their minimum bounding rectangle)."""
        cfg = self.config
        _, (rw, rh), _ = cv2.minAreaRect(contour)
        if (min(rw, rh) + 1.0) * scale < 1.2 * cfg.min_radius or \
                min(rw, rh) < 0.3 * max(rw, rh):
            return -1.0, -1.0
        if area > cfg.max_extent * rw * rh and min(rw, rh) * scale >= 24.0:
            return -1.0, -1.0
        return rw, rh

    def _without_bars(self, frame: _Frame, pieces: Sequence[Contour],
                      kernel: Mat, min_area: float) -> list[Mark]:
        """Whole marks from ``pieces`` (search-mask blobs that one closing joined) once the
        pieces that are no mark's (:meth:`_bar_like`: stripes, bars, rectangles) are left out:
        a mark cut in pieces by a pole (or a pole and a wire), with bars of its colour within
        the closing's reach, is joined without the bars."""
        bars = [self._bar_like(p, cv2.contourArea(p), frame.sx)[0] < 0 for p in pieces]
        kept = [p for p, bar in zip(pieces, bars, strict=True) if not bar]
        if len(kept) < 2 or len(kept) == len(pieces):
            return []
        sh, sw = frame.mask.shape
        x0, y0, x1, y1 = self._grown(cv2.boundingRect(np.concatenate(pieces)), kernel.shape[0],
                                     sw, sh)
        joined = np.zeros((y1 - y0, x1 - x0), np.uint8)
        cv2.drawContours(joined, kept, -1, 255, cv2.FILLED, offset=(-x0, -y0))
        # The bars' pixels (a search pixel around them, at full resolution) are no part of the
        # mark's measurement either.
        dropped: Mat = np.zeros_like(joined)
        cv2.drawContours(dropped, [p for p, bar in zip(pieces, bars, strict=True) if bar], -1,
                         255, cv2.FILLED, offset=(-x0, -y0))
        dropped = cv2.dilate(dropped, self._kernel3)
        scale = round(frame.sx)
        full = cv2.resize(dropped, (dropped.shape[1] * scale, dropped.shape[0] * scale),
                          interpolation=cv2.INTER_NEAREST)
        return self._closed_marks(frame, joined, (x0, y0), kernel, min_area,
                                  (full, x0 * scale, y0 * scale))

    def _bridged_one(self, frame: _Frame, shape: Contour, min_area: float,
                     exclude: tuple[Mat, int, int] | None = None) -> list[Mark]:
        """A closed shape of pieces read as one whole mark (``exclude``: full-resolution pixels
        that are no part of it, and their origin)."""
        cfg = self.config
        sh, sw = frame.mask.shape
        if len(shape) < 6 or cv2.contourArea(shape) < min_area or not self._reading():
            return []
        bx, by, bw, bh = cv2.boundingRect(shape)
        if bx <= 0 or by <= 0 or bx + bw >= sw or by + bh >= sh:
            return []
        # A tilted occluder leaves a notch where it leaves the outline: a looser coarse fit
        # (the measurement, closed across the occluder, checks the outline again).
        coarse = self._whole_fit(shape, tolerance_px=2.5)
        if coarse is None:
            return []
        mark = self._measure_whole(frame, self._to_full(frame, coarse), None, 1.0, exclude,
                                   bridge_px=cfg.bridge_px)
        return [] if mark is None else [mark]

    def _split_hues(self, frame: _Frame, contour: Contour, area: float,
                    min_area: float) -> list[Mark]:
        """A blob that gave no mark, read once more per hue cluster: a mark touching a large
        region of another palette colour (a red disc against blue sky, a blue one against
        green foliage) or of a near hue inside the same colour's range (a violet board behind a
        blue mark) is its own cluster's part of the blob, cut out by its own outline."""
        cfg = self.config
        bx, by, bw, bh = cv2.boundingRect(contour)
        if area < math.pi * (cfg.min_partial_radius / frame.sx) ** 2 or \
                (min(bw, bh) + 1) * frame.sx < 2.0 * cfg.min_partial_radius:
            return []  # too small or thin to hold a mark and something else
        region = np.zeros((bh, bw), np.uint8)
        cv2.drawContours(region, [contour], -1, 255, cv2.FILLED, offset=(-bx, -by))
        cv2.bitwise_and(region, frame.mask[by:by + bh, bx:bx + bw], dst=region)
        hue = np.ascontiguousarray(frame.hsv[by:by + bh, bx:bx + bw, 0])
        hist = np.asarray(cv2.calcHist([hue], [0], region, [HUE_MAX], [0, HUE_MAX]),
                          np.float64).ravel()
        peaks = _hue_peaks(hist, min_area, cfg.split_hue_gap)
        if len(peaks) < 2:
            return []
        # Each hue goes to its nearest peak (circular distance).
        hues = np.arange(HUE_MAX, dtype=np.float64)
        dist = np.abs((hues[:, None] - np.asarray(peaks, np.float64)[None, :] + 90.0)
                      % HUE_MAX - 90.0)
        lut = np.full(256, _NO_COLOUR, np.uint8)
        lut[:HUE_MAX] = np.argmin(dist, axis=1).astype(np.uint8)
        clusters = cv2.LUT(hue, lut)
        marks: list[Mark] = []
        for k in range(len(peaks)):
            # The other clusters' palette hues are another object for this part's readings (a
            # board of a near colour behind the mark is not the mark going on past its outline);
            # hues of no palette colour stay what they are, background.
            keep = np.where((lut == k) | (self._hue_lut == _NO_COLOUR), 255, 0).astype(np.uint8)
            part_frame = dataclasses.replace(frame, hue_keep=keep)
            own = cv2.bitwise_and(cv2.inRange(clusters, k, k), region)
            own = cv2.morphologyEx(own, cv2.MORPH_OPEN, self._kernel3)
            parts, _ = cv2.findContours(own, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE,
                                        offset=(bx, by))
            found: list[Mark] = []
            for part in parts:
                part_area = cv2.contourArea(part)
                if len(part) < 6 or part_area < min_area or part_area > 0.97 * area:
                    continue
                found.extend(self._blob(part_frame, part, part_area))
            if cfg.bridge_px > 0 and len(parts) >= 2:
                # The cluster's pieces may be one mark cut by a thin occluder (a mark against
                # a region of another palette colour, a pole across it).
                found.extend(self._joined(frame, own, (bx, by), len(parts), min_area))
            marks.extend(found)
        return marks

    def _split_saturation(self, frame: _Frame, contour: Contour, area: float,
                          min_area: float) -> list[Mark]:
        """A blob that gave no mark, cut once at the saturation that best separates it (Otsu):
        a mark touching a paler region of its own hue (a green disc on a green carpet, a red
        one before a terracotta board) is the more saturated part, cut out by its outline."""
        cfg = self.config
        bx, by, bw, bh = cv2.boundingRect(contour)
        if area < math.pi * (cfg.min_partial_radius / frame.sx) ** 2 or \
                (min(bw, bh) + 1) * frame.sx < 2.0 * cfg.min_partial_radius:
            return []
        region = np.zeros((bh, bw), np.uint8)
        cv2.drawContours(region, [contour], -1, 255, cv2.FILLED, offset=(-bx, -by))
        cv2.bitwise_and(region, frame.mask[by:by + bh, bx:bx + bw], dst=region)
        sat = np.ascontiguousarray(frame.hsv[by:by + bh, bx:bx + bw, 1])
        inside = sat[region > 0]
        if inside.size < 2 * min_area:
            return []
        level, _ = cv2.threshold(inside.reshape(1, -1), 0, 255,
                                 cv2.THRESH_BINARY | cv2.THRESH_OTSU)
        high, low = inside[inside > level], inside[inside <= level]
        # The paler region must be a good part of the blob (a floor, a board), not a mark's
        # own shading or rim.
        if high.size < min_area or low.size < 0.25 * inside.size or \
                float(high.mean()) - float(low.mean()) < cfg.split_saturation_gap:
            return []
        own: Mat = cv2.morphologyEx(
            np.where((sat > level) & (region > 0), 255, 0).astype(np.uint8), cv2.MORPH_OPEN,
            self._kernel3)
        parts, _ = cv2.findContours(own, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE,
                                    offset=(bx, by))
        # The parts are measured against a mask without the paler region, which is their
        # background now, not part of them.
        mask = frame.mask.copy()
        window = mask[by:by + bh, bx:bx + bw]
        window[(region > 0) & (own == 0)] = 0
        cut = dataclasses.replace(frame, mask=mask)
        marks: list[Mark] = []
        for part in parts:
            part_area = cv2.contourArea(part)
            if len(part) < 6 or part_area < min_area or part_area > 0.97 * area:
                continue
            marks.extend(self._blob(cut, part, part_area))
        return marks

    def _joined(self, frame: _Frame, own: Mat, origin: tuple[int, int], pieces: int,
                min_area: float) -> list[Mark]:
        """Whole marks among the shapes of a mask (search resolution, at ``origin``) closed
        across gaps of up to ``bridge_px``, where the closing joined some of its ``pieces``."""
        k = 2 * math.ceil((self.config.bridge_px / frame.sx + 2.0) / 2.0) + 1
        kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))
        shut = cv2.morphologyEx(own, cv2.MORPH_CLOSE, kernel)
        shapes, _ = cv2.findContours(shut, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE,
                                     offset=origin)
        if len(shapes) >= pieces:
            return []  # nothing joined
        marks: list[Mark] = []
        for shape in shapes:
            marks.extend(self._bridged_one(frame, shape, min_area))
        return marks

    def _blob(self, frame: _Frame, contour: Contour, area: float) -> list[Mark]:
        if not self._reading():
            return []
        cfg = self.config
        s = frame.sx
        bx, by, bw, bh = cv2.boundingRect(contour)
        box = (bx, by, bw, bh)
        sh, sw = frame.mask.shape
        border = bx <= 0 or by <= 0 or bx + bw >= sw or by + bh >= sh
        rw, rh = self._bar_like(contour, area, s)
        if rw < 0:
            return []
        hull = cv2.convexHull(contour)
        hull_area = cv2.contourArea(hull)
        convex = area >= cfg.min_solidity * hull_area
        if convex and not border:
            coarse = self._whole_fit(contour, tolerance_px=1.0)
            if coarse is not None and \
                    _longest_edge(cv2.approxPolyDP(hull, 0.75, True)) > _flat_stretch(coarse):
                coarse = None  # a straight cut: an occluder's edge
            if coarse is not None:
                mark = self._measure_whole(frame, self._to_full(frame, coarse), None, 1.0)
                if mark is not None:
                    return [mark]
        # Not a clean whole mark: cut by the image edge, partly hidden, touching, or clutter.
        # Polygons (few vertices) and shapes far from their fitted ellipse's area stay out of
        # the slow path.
        step = max(1, len(contour) // 64)  # the least-squares fit needs no more points
        e = _from_rotated_rect(cv2.fitEllipseDirect(
            np.ascontiguousarray(contour[::step]).astype(np.float32)))
        ell_area = math.pi * e.a * e.b
        if not ell_area > 0 or abs(area - ell_area) > 0.2 * ell_area:
            return []
        r_est = math.sqrt(hull_area / math.pi)
        if r_est * s >= 16.0 and len(cv2.approxPolyDP(hull, 0.1 * r_est, True)) < 6:
            return []
        # Small triangles: blur rounds them past the polygon test, but they fill little of
        # their bounding rectangle (≈ 0.5-0.6; a disc 0.79, a disc cut by a chord >= 0.67).
        if r_est * s < 20.0 and area < cfg.min_small_extent * rw * rh:
            return []
        colours = self._colours(frame, contour, box)
        split = colours.split
        if not split and (colours.colour is None or not self._meets_floors(frame, colours)):
            return []
        if not border:
            # Inside the image: a partly hidden mark (convex) or touching marks (concave).
            # Either is at least as round as two touching discs, and a partly hidden one must
            # be large enough to tell from a bar's rounded end.
            if e.minor < 0.9 * cfg.min_axis_ratio * e.major:
                return []
            if convex and r_est * s < cfg.min_partial_radius:
                return []
        if not self._has_arc(frame, contour, r_est):
            return []
        # Both readings below look at the same full-resolution window.
        win = self._window(frame, colours.region, box, pad=4)
        marks: list[Mark] | None = None
        if split:
            # Touching marks of different colours: each colour on its own, the others hiding
            # it (each colour's part is that colour by construction: purity 1). When that
            # accounts for every colour present, with two marks at least, the blob is
            # explained: the one-mark reading below is not needed.
            present = colours.present
            marks = self._window_marks(frame, colours.region, box, present,
                                       purity=dict.fromkeys(present, 1.0), try_whole=True,
                                       win=win)
            if len(marks) >= max(2, len(present)):
                return marks
        single: list[Mark] = []
        if colours.colour is not None:
            # One mark's reading: every palette-coloured pixel of the blob is the mark (its
            # shading may straddle a palette boundary). A convex blob inside the image already
            # failed as a whole mark.
            single = self._window_marks(frame, colours.region, box, [colours.colour],
                                        purity={colours.colour: colours.purity},
                                        try_whole=border or not convex, merged=True, win=win)
        if marks is None:
            return single
        # The per-colour reading stands when it finds more marks, or as many and at least two
        # (one mark whose shading straddles two palette colours is one mark).
        if len(marks) > len(single) or len(marks) == len(single) >= 2:
            return marks
        return single


def detect_marks(image: U8Array, palette: Palette = DEFAULT_PALETTE) -> list[Mark]:
    """Convenience: the marks in one BGR image with a fresh :class:`Detector`."""
    return Detector(palette).detect(image)
