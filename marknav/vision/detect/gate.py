"""Stage 0, the coarse gate: where in the frame a mark can be at all.

Most of a room is not a mark's colour. A quarter-resolution sample of the frame (each pixel the
mean of a 2×2 block of every 4×4: ``INTER_LINEAR`` at a quarter) is white-balanced and
classified with the search mask's own thresholds — in one compiled pass
(:func:`.kernels.coarse_seeds`) when the frame's sides are multiples of 4, else with OpenCV
(the same seeds; ≈ 0.07 against 0.11 ms at 640×480); a mark of radius ≥ 4 px always holds
a sample that lies wholly inside it (its inscribed square is ≥ 5 px wide), so every mark seeds
at least one pixel. The seeds, grown by the reach the later stages read around a blob
(``_PAD`` search px: the background band of the whole-mark measurement, the samples outside an
arc), give rectangles; the half-resolution search products (white-balanced image, HSV, mask)
are computed only there — one compiled pass per rectangle
(:func:`.kernels.search_box`), then OpenCV's opening — and the rest of the search arrays stays
zero (no colour: no blob). Frames whose candidate area is large (a wall or a sky in a mark's
colour) are searched whole, with OpenCV, as before.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from marknav.vision.detect.geometry import Mat, U8Array
from marknav.vision.detect.kernels import coarse_seeds, search_box

__all__ = ["COARSE_STEP", "SearchBuffers", "SearchProducts", "coarse_sample", "search_products"]

#: Full-resolution px per coarse px (:func:`.kernels.coarse_seeds` is written for 4).
COARSE_STEP = 4
#: Search px grown around every coarse seed (covers ``whole._BACK`` and the arc path's reads
#: outside a blob, plus the search mask's blur and opening).
_PAD = 8
#: Share of the search image above which the whole frame is searched (rectangles cost more
#: than they save).
_MAX_SHARE = 0.45
#: The hue gate's table when every hue passes, and the gains of no white balance.
_ALL_HUES = np.full(256, 255, np.uint8)
_UNIT = np.ones(3, np.float32)


@dataclass
class SearchProducts:
    small: Mat  # search resolution, white-balanced (zero outside the searched rectangles)
    hsv: Mat
    mask: Mat
    #: Searched rectangles (x0, y0, x1, y1) at search resolution; None: the whole frame.
    boxes: list[tuple[int, int, int, int]] | None


class SearchBuffers:
    """The gated search arrays, kept from frame to frame (a detector is used by one thread):
    only the rectangles written last time are cleared, not the whole arrays."""

    def __init__(self) -> None:
        self.shape = (0, 0)
        self.small = self.hsv = self.mask = np.zeros((0, 0), np.uint8)
        self.written: list[tuple[int, int, int, int]] = []

    def take(self, sw: int, sh: int) -> tuple[Mat, Mat, Mat]:
        if self.shape != (sh, sw):
            self.shape = (sh, sw)
            self.small = np.zeros((sh, sw, 3), np.uint8)
            self.hsv = np.zeros((sh, sw, 3), np.uint8)
            self.mask = np.zeros((sh, sw), np.uint8)
        else:
            for x0, y0, x1, y1 in self.written:
                self.small[y0:y1, x0:x1] = 0
                self.hsv[y0:y1, x0:x1] = 0
                self.mask[y0:y1, x0:x1] = 0
        self.written = []
        return self.small, self.hsv, self.mask


def coarse_sample(image: U8Array) -> Mat:
    """The quarter-resolution sample the gate and the white balance read."""
    h, w = image.shape[:2]
    return cv2.resize(image, (max(1, w // COARSE_STEP), max(1, h // COARSE_STEP)),
                      interpolation=cv2.INTER_LINEAR)


def _classify(bgr: Mat, balance: npt.NDArray[np.float32] | None, sat_min: int, v_floor: int,
              gate_lut: Mat | None, kernel: Mat | None) -> tuple[Mat, Mat, Mat]:
    """White-balanced image, HSV and the search mask of one (sub)image."""
    if balance is not None:
        bgr = cv2.transform(bgr, balance)
    hsv = cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV)
    mask = cv2.inRange(hsv, (0, sat_min, v_floor), (255, 255, 255))
    if gate_lut is not None:
        # Only hues of the palette: a saturated floor, wall or board of another hue (wood
        # beside a red mark, teal beside green) is background, not part of a mark's blob.
        cv2.bitwise_and(mask, cv2.LUT(hsv[:, :, 0], gate_lut), dst=mask)
    if kernel is not None:
        mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, kernel)
    return bgr, hsv, mask


def search_products(image: U8Array, small_size: tuple[int, int], scale: int,
                    gated: bool, whole: Mat | None, balance: npt.NDArray[np.float32] | None,
                    sat_min: int, v_floor: int, gate_lut: Mat | None,
                    kernel: Mat | None, buffers: SearchBuffers,
                    band: tuple[float, float] | None = None) -> SearchProducts:
    """The half-resolution search image, HSV and mask, computed where the coarse gate
    (``gated``; needs ``scale`` 2) finds a seed, or over the whole frame (``whole``: the
    search-resolution image when already made). ``scale``: full px per search px (1 or 2).
    Gated products live in ``buffers`` until the next call. ``band`` (search rows, the horizon
    prior's): only seeded regions reaching into it are searched. ``balance`` is a diagonal
    matrix (the white balance's gains) and ``gate_lut`` holds 0 or 255 per hue, as the
    detector makes them: the compiled passes read only the diagonal and test ``!= 0``."""
    sw, sh = small_size
    if gated and scale != 2:
        raise ValueError(f"the coarse gate needs the half-resolution search, not scale {scale}")
    boxes = _boxes(_seeds(image, balance, sat_min, v_floor, gate_lut), scale, sw, sh, band) \
        if gated else None
    if boxes is None:
        small: Mat = whole if whole is not None else image if scale == 1 else \
            cv2.resize(image[:sh * scale, :sw * scale], (sw, sh), interpolation=cv2.INTER_AREA)
        small, hsv, mask = _classify(small, balance, sat_min, v_floor, gate_lut, kernel)
        return SearchProducts(small, hsv, mask, None)
    small, hsv, mask = buffers.take(sw, sh)
    buffers.written = boxes
    gains = _gains(balance)
    for x0, y0, x1, y1 in boxes:
        # Written straight into the buffers' rectangles (per-pixel operations: overlapping
        # rectangles write the same values on their common pixels).
        m: Mat = search_box(image, x0, y0, x1, y1, gains, sat_min, v_floor,
                            _ALL_HUES if gate_lut is None else gate_lut, small, hsv)
        if kernel is not None:
            m = cv2.morphologyEx(m, cv2.MORPH_OPEN, kernel)
        # Overlapping rectangles agree on their common pixels except near a rectangle's edge,
        # where the opening saw zeros: keep the union.
        cv2.bitwise_or(mask[y0:y1, x0:x1], m, dst=mask[y0:y1, x0:x1])
    return SearchProducts(small, hsv, mask, boxes)


def _gains(balance: npt.NDArray[np.float32] | None) -> npt.NDArray[np.float32]:
    """The diagonal of the white balance's matrix (B, G, R gains)."""
    return _UNIT if balance is None else np.ascontiguousarray(np.diagonal(balance), np.float32)


def _seeds(image: U8Array, balance: npt.NDArray[np.float32] | None, sat_min: int, v_floor: int,
           gate_lut: Mat | None) -> Mat:
    """The coarse gate's seed mask (quarter resolution) of ``image``."""
    h, w = image.shape[:2]
    if h % COARSE_STEP == 0 and w % COARSE_STEP == 0:
        return coarse_seeds(image, _gains(balance), sat_min, v_floor,
                            _ALL_HUES if gate_lut is None else gate_lut)
    return _classify(coarse_sample(image), balance, sat_min, v_floor, gate_lut, None)[2]


def _boxes(seeds: Mat, scale: int, sw: int, sh: int, band: tuple[float, float] | None,
           ) -> list[tuple[int, int, int, int]] | None:
    """Search-resolution rectangles around the coarse seeds, or None to search everything."""
    per = COARSE_STEP // scale  # search px per coarse px
    grow = -(-_PAD // per)  # coarse px
    k = 2 * grow + 1
    grown = cv2.dilate(seeds, cv2.getStructuringElement(cv2.MORPH_RECT, (k, k)))
    if band is None and cv2.countNonZero(grown) * per * per > _MAX_SHARE * sw * sh:
        return None
    outlines, _ = cv2.findContours(grown, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    boxes: list[tuple[int, int, int, int]] = []
    ch, cw = seeds.shape
    for outline in outlines:
        x, y, w, h = cv2.boundingRect(outline)
        x0, y0 = max(0, x * per - 1), max(0, y * per - 1)
        # The last coarse column/row stands for what is left of the frame.
        x1 = sw if x + w >= cw else min(sw, (x + w) * per + 1)
        y1 = sh if y + h >= ch else min(sh, (y + h) * per + 1)
        if band is not None and (y0 > band[1] + _PAD or y1 < band[0] - _PAD):
            continue  # no blob here reaches the band where mark centres lie
        boxes.append((x0, y0, x1, y1))
    return boxes
