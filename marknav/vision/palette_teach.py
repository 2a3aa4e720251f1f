"""Teaching a palette from pictures of the user's own marks (``marknav palette``).

Printed marks are rarely the pure hues a palette is first typed with, and the camera and the
room's light move them further. This module measures them instead, in four pure steps:

1. :func:`find_round_marks` — the saturated round objects of one frame, without a palette. The
   frame is white-balanced as the detector balances it (grey world,
   :mod:`~marknav.vision.detect.photometry`), so the hues measured here are the hues
   the detector will compare with the palette. Saturation is judged relative to the frame: the
   search starts just above the saturation of the frame's own grey part (its 40th percentile
   plus 25, within 60..160, the detector's grey criterion) and climbs a ladder of thresholds, so
   a pale mark on a white wall and a vivid one among pale posters are both cut out at some rung.
   A blob is round when it agrees with the ellipse fitted to its outline: intersection over
   union of the blob and the filled ellipse ≥ ``min_roundness`` (a disc 0.95–0.99, a square
   0.90, a bar or a blob of two touching marks far less). Blobs that are not round are also
   read per hue cluster (touching marks of different colours).
2. :func:`cluster_marks` — the marks' circular mean hues grouped into as many colours as the
   user names, by the grouping with the least squared hue spread (exact on the hue circle).
3. :func:`propose_palette` — each group named after the nearest canonical hue of the names
   given (one name per group), its hue range made of what its marks show (each mark's 2nd..98th
   percentile of pixel hue) widened into the free hues beside it by at most ``max_margin``,
   never past the middle of the gap to the next colour; where two colours' observed hues meet
   or overlap, a warning, and the boundary where the fewest pixels fall on the wrong side.
4. :func:`check_palette` — how a palette (a mission's, or the proposal) separates the marks
   found: per colour, the marks whose mean hue falls in its range, in another colour's range,
   in none; and how close each lies to an edge (hue units).

Hue is in OpenCV units (0..179, degrees / 2; a range may wrap: ``170..10``).
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from marknav.vision.palette import HUE_MAX, ColourRange, Palette

__all__ = [
    "CANONICAL_HUES",
    "ColourCheck",
    "ColourRequest",
    "FinderConfig",
    "Gap",
    "PaletteProposal",
    "ProposedColour",
    "RoundMark",
    "check_palette",
    "cluster_marks",
    "find_round_marks",
    "parse_colours",
    "propose_palette",
    "scene_hues",
    "yaml_block",
]

U8Array = npt.NDArray[np.uint8]
FloatArray = npt.NDArray[np.float64]
#: What OpenCV returns (masks, contours): arrays of whatever dtype the call gives.
Mat = npt.NDArray[Any]

#: Where each colour name sits on OpenCV's hue circle (0..179): the hue of the pure colour
#: (red 0°, yellow 60°, green 120°, cyan 180°, blue 240°, magenta 300°, halved), orange and the
#: in-between names at the hue printers and paints give them. Only used to *name* the groups of
#: marks found; the ranges come from the marks.
CANONICAL_HUES: dict[str, float] = {
    "red": 0.0,
    "orange": 12.0,
    "yellow": 28.0,
    "lime": 45.0,
    "green": 60.0,
    "teal": 80.0,
    "cyan": 90.0,
    "blue": 112.0,
    "violet": 135.0,
    "purple": 140.0,
    "magenta": 150.0,
    "pink": 165.0,
}

#: A non-round blob is read as at most this many hue clusters (touching marks of different
#: colours and the floor or wall they touch; more is a multicoloured object, not marks).
_MAX_HUE_PARTS = 6

_COLOUR_ITEM = re.compile(r"^([A-Za-z][A-Za-z0-9_-]*)(?:=(\d+(?:\.\d+)?))?(?::(left|right))?$")


@dataclass(frozen=True)
class ColourRequest:
    """One colour the user asks for: its name, the hue that names it (OpenCV units) and, if
    given, the side the robot passes it on."""

    name: str
    hue: float
    side: str | None = None


def parse_colours(text: str) -> list[ColourRequest]:
    """``"red,green:right,teal=85"`` → requests. Each item is ``NAME[=HUE][:SIDE]``; a name
    without ``=HUE`` must be one of :data:`CANONICAL_HUES`. ``ValueError`` says what is wrong."""
    items = [t.strip() for t in text.split(",") if t.strip()]
    if not items:
        raise ValueError("no colours given (e.g. red,green,blue)")
    out: list[ColourRequest] = []
    for item in items:
        m = _COLOUR_ITEM.match(item)
        if m is None:
            raise ValueError(f"{item!r}: expected NAME, NAME=HUE or NAME:SIDE (side left or "
                             "right), e.g. red:left or teal=85")
        name, hue_text, side = m.group(1), m.group(2), m.group(3)
        if hue_text is not None:
            hue = float(hue_text)
            if not 0.0 <= hue < HUE_MAX:
                raise ValueError(f"{item!r}: hue must be in 0..179 (OpenCV units)")
        elif name.lower() in CANONICAL_HUES:
            hue = CANONICAL_HUES[name.lower()]
        else:
            raise ValueError(f"{name!r} is not a colour name marknav knows the hue of "
                             f"({', '.join(CANONICAL_HUES)}); give its hue as {name}=HUE "
                             "(OpenCV units 0..179)")
        if any(r.name == name for r in out):
            raise ValueError(f"{name!r} is given twice")
        out.append(ColourRequest(name, hue, side))
    return out


# --------------------------------------------------------------------------------------------
# 1. Round saturated marks in one frame
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class FinderConfig:
    """How :func:`find_round_marks` decides what is a mark.

    Every field has the unit in its comment and the reason for its value.
    """

    #: Smallest semi-major axis (px): below ~5 px a blob's outline says nothing of its shape.
    min_radius_px: float = 5.0
    #: Blob ∩ fitted ellipse over blob ∪ ellipse (0..1). Discs (printed, tilted, JPEG-blurred)
    #: give 0.95–0.99; a square 0.90; two touching discs ≈ 0.8.
    min_roundness: float = 0.92
    #: Smallest minor/major axis ratio: a mark turned 65° from the camera still counts.
    min_axis_ratio: float = 0.4
    #: Saturation thresholds (0..255) between the frame's grey level and ``sat_top`` are
    #: tried this far apart: a mark's saturation is flat enough that a rung of 30 always cuts
    #: it whole from a background at least 30 paler.
    sat_step: int = 30
    #: The highest rung (0..255); above it only clipped pixels remain.
    sat_top: int = 220
    #: A mark's value (brightness, 0..255) must reach this share of the scene's grey level:
    #: darker saturated blobs are brown or black things and shadows (the detector's
    #: ``val_rel_min``).
    val_rel_min: float = 0.35
    #: ... and at least this absolute value (0..255) in a lit scene (the palette default).
    val_min: int = 50
    #: A non-round blob whose hue histogram has peaks at least this many hue units apart is
    #: read once per peak (each pixel going to the nearest peak): touching marks of different
    #: colours are ≥ 8 apart (the detector's ``split_hue_gap``); shading moves a mark's hue
    #: by less.
    hue_cluster_gap: float = 8.0
    #: The outer rim of a mark mixes it with its background; its hues are measured this share
    #: of the radius inside its outline (at least 1 px).
    rim_share: float = 0.2

    def __post_init__(self) -> None:
        if not self.min_radius_px > 0:
            raise ValueError("min_radius_px must be positive")
        for name in ("min_roundness", "min_axis_ratio", "val_rel_min", "rim_share"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"{name} must be in [0, 1]")
        if self.sat_step < 1 or not 0 < self.sat_top <= 255:
            raise ValueError("sat_step must be >= 1 and sat_top in 1..255")


@dataclass(frozen=True)
class RoundMark:
    """One saturated round object found in a frame (pixels; u right, v down).

    ``hue`` is the circular mean of its core pixels' hues (OpenCV units), ``hue_spread`` their
    circular standard deviation (hue units), ``hue_lo``/``hue_hi`` their 2nd and 98th percentile
    as offsets from ``hue`` (hue units, ``hue_lo`` ≤ 0 ≤ ``hue_hi``); ``saturation``/``value``
    medians (0..255) after the white balance; ``roundness`` the blob-ellipse IoU; ``source``
    the frame's name.
    """

    source: str
    x: float
    y: float
    radius: float
    axes: tuple[float, float]
    angle: float
    roundness: float
    hue: float
    hue_spread: float
    hue_lo: float
    hue_hi: float
    saturation: float
    value: float
    pixels: int
    hue_offsets: FloatArray = field(compare=False, repr=False)

    def to_dict(self) -> dict[str, object]:
        return {"source": self.source, "x": round(self.x, 1), "y": round(self.y, 1),
                "radius": round(self.radius, 1), "roundness": round(self.roundness, 3),
                "hue": round(self.hue, 2), "hue_spread": round(self.hue_spread, 2),
                "hue_range": [round(_wrap(self.hue + self.hue_lo), 1),
                              round(_wrap(self.hue + self.hue_hi), 1)],
                "saturation": round(self.saturation, 1), "value": round(self.value, 1)}


def hue_diff(a: float | FloatArray, b: float) -> float | FloatArray:
    """Signed circular difference a − b in (−90, 90] hue units."""
    d = (np.asarray(a, np.float64) - b + HUE_MAX / 2.0) % HUE_MAX - HUE_MAX / 2.0
    return float(d) if np.ndim(d) == 0 else d


def circular_mean(hues: FloatArray, weights: FloatArray | None = None) -> tuple[float, float]:
    """Circular mean (OpenCV units, [0, 180)) and circular standard deviation (hue units)."""
    ang = np.asarray(hues, np.float64) * (2.0 * math.pi / HUE_MAX)
    w = np.ones_like(ang) if weights is None else np.asarray(weights, np.float64)
    total = float(w.sum())
    if total <= 0:
        return 0.0, float("inf")
    s = float(np.dot(w, np.sin(ang))) / total
    c = float(np.dot(w, np.cos(ang))) / total
    r = min(1.0, math.hypot(s, c))
    mean = (math.degrees(math.atan2(s, c)) / 2.0) % HUE_MAX
    if mean >= HUE_MAX - 1e-9:
        mean = 0.0
    spread = math.sqrt(-2.0 * math.log(r)) * HUE_MAX / (2.0 * math.pi) if r > 0 else float("inf")
    return mean, spread


def _balanced_hsv(image: U8Array) -> tuple[U8Array, float]:
    """The frame in HSV through the detector's light-colour correction (grey world within
    bounds, :mod:`marknav.vision.detect.photometry`; no exposure gain: the floors here are
    relative to the frame already), and its grey level."""
    from marknav.vision.detect.photometry import PhotometryConfig, correction_gains, table_of

    h, w = image.shape[:2]
    small = cv2.resize(image, (max(1, w // 2), max(1, h // 2)), interpolation=cv2.INTER_AREA)
    corrected = cv2.LUT(np.ascontiguousarray(image),
                        table_of(correction_gains(small, PhotometryConfig(max_gain=1.0))))
    grey = float(np.mean(cv2.cvtColor(corrected, cv2.COLOR_BGR2GRAY)))
    return np.asarray(cv2.cvtColor(corrected, cv2.COLOR_BGR2HSV), np.uint8), grey


def _roundness(shape: tuple[int, int], contour: Mat) -> tuple[float, tuple[
        float, float, float, float, float]] | None:
    """(IoU of the blob and its fitted ellipse, (cx, cy, major, minor, angle)) or None."""
    if len(contour) < 5:
        return None
    (cx, cy), (d1, d2), angle = cv2.fitEllipse(contour)
    if not (math.isfinite(cx) and math.isfinite(cy) and d1 > 0 and d2 > 0):
        return None
    x, y, w, h = cv2.boundingRect(contour)
    pad = int(max(d1, d2)) + 2
    x0, y0 = max(0, x - pad), max(0, y - pad)
    x1, y1 = min(shape[1], x + w + pad), min(shape[0], y + h + pad)
    blob = np.zeros((y1 - y0, x1 - x0), np.uint8)
    cv2.drawContours(blob, [contour], -1, 255, cv2.FILLED, offset=(-x0, -y0))
    ell = np.zeros_like(blob)
    cv2.ellipse(ell, ((cx - x0, cy - y0), (d1, d2), angle), 255, cv2.FILLED)
    inter = int(np.count_nonzero(blob & ell))
    union = int(np.count_nonzero(blob | ell))
    if union == 0:
        return None
    major_angle = angle if d1 >= d2 else angle + 90.0  # the direction of the major axis
    return inter / union, (cx, cy, max(d1, d2) / 2.0, min(d1, d2) / 2.0, major_angle)


def _measure(source: str, hsv: U8Array, contour: Mat, iou: float,
             ell: tuple[float, float, float, float, float],
             keep: tuple[Mat, int, int] | None, cfg: FinderConfig) -> RoundMark | None:
    cx, cy, major, minor, angle = ell
    x, y, w, h = cv2.boundingRect(contour)
    region: Mat = np.zeros((h, w), np.uint8)
    cv2.drawContours(region, [contour], -1, 255, cv2.FILLED, offset=(-x, -y))
    inset = max(1, round(cfg.rim_share * minor))
    core = cv2.erode(region, cv2.getStructuringElement(cv2.MORPH_ELLIPSE,
                                                       (2 * inset + 1, 2 * inset + 1)))
    if keep is not None:  # a hue part of a blob: only its own pixels
        part, kx, ky = keep
        mine = np.zeros_like(region)
        sub = part[y - ky:y - ky + h, x - kx:x - kx + w]
        mine[:sub.shape[0], :sub.shape[1]] = sub
        region = cv2.bitwise_and(region, mine * 255)
        core = cv2.bitwise_and(core, region)
    if np.count_nonzero(core) < 12:
        core = region
    sel = core > 0
    if np.count_nonzero(sel) < 5:
        return None
    px = hsv[y:y + h, x:x + w][sel].astype(np.float64)
    mean, spread = circular_mean(px[:, 0])
    offsets = np.asarray(hue_diff(px[:, 0], mean), np.float64)
    lo, hi = np.percentile(offsets, [2.0, 98.0])
    return RoundMark(source=source, x=float(cx), y=float(cy), radius=float(major),
                     axes=(float(major), float(minor)), angle=float(angle),
                     roundness=float(iou), hue=mean,
                     hue_spread=spread, hue_lo=float(lo), hue_hi=float(hi),
                     saturation=float(np.median(px[:, 1])), value=float(np.median(px[:, 2])),
                     pixels=int(sel.sum()), hue_offsets=offsets)


def _hue_peaks(hues: FloatArray, gap: float, min_count: int) -> list[float]:
    """Peaks of a circular hue histogram (smoothed ±2), at least ``gap`` apart, each with
    ``min_count`` pixels within ``gap / 2``."""
    hist = np.bincount(np.asarray(hues, np.int64) % HUE_MAX, minlength=HUE_MAX).astype(float)
    k = np.ones(5)
    smooth = np.convolve(np.concatenate([hist[-2:], hist, hist[:2]]), k, "valid")
    half = max(1, int(gap // 2))
    near = np.convolve(np.concatenate([hist[-half:], hist, hist[:half]]),
                       np.ones(2 * half + 1), "valid")
    left, right = np.roll(smooth, 1), np.roll(smooth, -1)
    cand = np.flatnonzero((smooth > 0) & (smooth >= left) & (smooth >= right)
                          & (near >= min_count))
    peaks: list[float] = []
    for i in cand[np.argsort(-smooth[cand], kind="stable")].tolist():
        if all(abs(float(hue_diff(float(i), p))) >= gap for p in peaks):
            peaks.append(float(i))
    return peaks


def _floors(hsv: U8Array, grey: float, cfg: FinderConfig) -> tuple[U8Array, int]:
    """The pixels bright enough to be a mark (1) and the lowest saturation searched: just above
    the frame's own grey part (see the module docstring)."""
    exposure = min(1.0, grey / 100.0) if grey > 0 else 1.0
    v_floor = int(max(cfg.val_min * exposure, cfg.val_rel_min * grey))
    bright = (hsv[:, :, 2] >= v_floor).astype(np.uint8)
    step = max(1, hsv.shape[1] // 160)
    grey_sat = float(np.percentile(hsv[::step, ::step, 1], 40))
    return bright, int(min(160, max(60, grey_sat + 25)))


def scene_hues(image: U8Array, marks: Sequence[RoundMark],
               config: FinderConfig = FinderConfig()) -> FloatArray:
    """Share of the frame's pixels at each hue (180 bins) that are as saturated and bright as
    a mark could be but lie outside every mark found (floors, walls, posters): the hues a
    palette range should not reach into."""
    hsv, grey = _balanced_hsv(image)
    bright, s0 = _floors(hsv, grey, config)
    mask = ((hsv[:, :, 1] >= s0).astype(np.uint8) & bright) * 255
    for m in marks:  # the marks themselves, with their rim
        cv2.ellipse(mask, ((m.x, m.y), (2 * m.axes[0] + 6, 2 * m.axes[1] + 6), m.angle), 0,
                    cv2.FILLED)
    hist = cv2.calcHist([hsv], [0], mask, [HUE_MAX], [0, HUE_MAX]).ravel()
    return np.asarray(hist, np.float64) / float(mask.size)


def find_round_marks(image: U8Array, *, source: str = "",
                     config: FinderConfig = FinderConfig()) -> list[RoundMark]:
    """The saturated round objects of one BGR frame, largest first (see the module docstring)."""
    cfg = config
    hsv, grey = _balanced_hsv(image)
    sat = hsv[:, :, 1]
    bright, s0 = _floors(hsv, grey, cfg)
    rungs = list(range(s0, cfg.sat_top + 1, cfg.sat_step)) or [s0]
    min_area = math.pi * cfg.min_radius_px ** 2 * cfg.min_axis_ratio
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (3, 3))
    found: list[RoundMark] = []
    shape = (hsv.shape[0], hsv.shape[1])

    def consider(mask: Mat, keep: tuple[Mat, int, int] | None,
                 offset: tuple[int, int] = (0, 0)) -> None:
        contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE,
                                       offset=offset)
        for c in contours:
            if cv2.contourArea(c) < min_area:
                continue
            got = _roundness(shape, c)
            if got is None:
                continue
            iou, ell = got
            _cx, _cy, major, minor, _ = ell
            if iou < cfg.min_roundness or minor < cfg.min_axis_ratio * major:
                if keep is None:  # not one round object: maybe several of different hues
                    split(c)
                continue
            if major < cfg.min_radius_px:
                continue
            mark = _measure(source, hsv, c, iou, ell, keep, cfg)
            if mark is not None:
                found.append(mark)

    def split(contour: Mat) -> None:
        """A blob that is not round, read once per hue cluster (touching marks)."""
        x, y, w, h = cv2.boundingRect(contour)
        region = np.zeros((h, w), np.uint8)
        cv2.drawContours(region, [contour], -1, 1, cv2.FILLED, offset=(-x, -y))
        sel = region > 0
        hue_box = hsv[y:y + h, x:x + w, 0].astype(np.float64)
        peaks = _hue_peaks(hue_box[sel], cfg.hue_cluster_gap,
                           int(math.pi * cfg.min_radius_px ** 2))
        if len(peaks) < 2:
            return
        peaks = peaks[:_MAX_HUE_PARTS]
        # each pixel goes to the hue peak nearest it: a pale mark's hues are noisy (±6 units
        # at S ≈ 90), a window around its peak would cut it to pieces
        dist = np.stack([np.abs(np.asarray(hue_diff(hue_box, p))) for p in peaks])
        nearest = np.argmin(dist, axis=0)
        for i in range(len(peaks)):
            part = ((nearest == i) & sel).astype(np.uint8)
            part = cv2.morphologyEx(part, cv2.MORPH_OPEN, kernel)
            consider(part, (part, x, y), (x, y))

    for level in rungs:
        mask: Mat = cv2.morphologyEx((sat >= level).astype(np.uint8) & bright,
                                     cv2.MORPH_OPEN, kernel)
        consider(mask, None)
    return _one_per_object(found)


def _one_per_object(marks: list[RoundMark]) -> list[RoundMark]:
    """Marks found at several rungs (or also as a hue part) are one object: keep the roundest
    reading of each (centres closer than half the smaller radius)."""
    kept: list[RoundMark] = []
    for m in sorted(marks, key=lambda m: (-m.roundness, -m.pixels)):
        if all(math.hypot(m.x - k.x, m.y - k.y) >= 0.5 * min(m.radius, k.radius) for k in kept):
            kept.append(m)
    return sorted(kept, key=lambda m: -m.radius)


# --------------------------------------------------------------------------------------------
# 2. Grouping the marks' hues
# --------------------------------------------------------------------------------------------


def _kmeans_1d(x: FloatArray, k: int) -> tuple[float, list[int]]:
    """Exact 1-D k-means of sorted ``x`` (dynamic programming): (cost, start index of each
    group)."""
    n = len(x)
    c1 = np.concatenate([[0.0], np.cumsum(x)])
    c2 = np.concatenate([[0.0], np.cumsum(x * x)])

    def cost(i: int, j: int) -> float:  # x[i:j]
        m = j - i
        s = c1[j] - c1[i]
        return float(c2[j] - c2[i] - s * s / m)

    inf = float("inf")
    best = [[inf] * (n + 1) for _ in range(k + 1)]
    arg = [[0] * (n + 1) for _ in range(k + 1)]
    best[0][0] = 0.0
    for g in range(1, k + 1):
        for j in range(g, n + 1):
            for i in range(g - 1, j):
                if best[g - 1][i] == inf:
                    continue
                c = best[g - 1][i] + cost(i, j)
                if c < best[g][j]:
                    best[g][j], arg[g][j] = c, i
    starts = []
    j = n
    for g in range(k, 0, -1):
        i = arg[g][j]
        starts.append(i)
        j = i
    return best[k][n], starts[::-1]


def cluster_marks(hues: Sequence[float], k: int) -> list[int]:
    """Group index (0..k-1) of each hue, groups numbered by their circular order from the cut
    the grouping starts at; the grouping with the least within-group squared hue difference
    (exact: the circle is cut at each of the widest gaps, each cut solved exactly)."""
    n = len(hues)
    if k < 1 or n < k:
        raise ValueError(f"cannot make {k} groups of {n} marks")
    h = np.asarray(hues, np.float64) % HUE_MAX
    order = np.argsort(h, kind="stable")
    hs = h[order]
    gaps = np.diff(np.concatenate([hs, [hs[0] + HUE_MAX]]))  # gap after each sorted element
    cuts = np.argsort(-gaps, kind="stable")[:max(2 * k, 4)]
    best_cost, best_labels = float("inf"), [0] * n
    for cut in cuts.tolist():
        start = (cut + 1) % n
        idx = np.concatenate([order[start:], order[:start]])
        x = h[idx].copy()
        x[n - start:] += HUE_MAX if start else 0.0
        cost, starts = _kmeans_1d(x, k)
        if cost < best_cost - 1e-9:
            best_cost = cost
            labels = [0] * n
            bounds = [*starts, n]
            for g in range(k):
                for pos in range(bounds[g], bounds[g + 1]):
                    labels[int(idx[pos])] = g
            best_labels = labels
    return best_labels


# --------------------------------------------------------------------------------------------
# 3. The proposal
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ProposedColour:
    """One taught colour: its proposed range (inclusive, may wrap), what its marks showed
    (``mark_hues``: the lowest and highest mark mean hue; ``pixel_hues``: the lowest 2nd and
    highest 98th percentile of their pixels' hues) and the saturation/value floors."""

    name: str
    hue_lo: int
    hue_hi: int
    mean_hue: float
    mark_hues: tuple[float, float]
    pixel_hues: tuple[float, float]
    marks: int
    sat_min: int
    val_min: int
    side: str | None = None
    #: Hues where other saturated surfaces of the pictures stopped the range's margin.
    stopped_at: tuple[int, ...] = ()

    def range(self) -> ColourRange:
        return ColourRange(self.name, self.hue_lo, self.hue_hi, sat_min=self.sat_min,
                           val_min=self.val_min)


@dataclass(frozen=True)
class Gap:
    """Two colours next to each other on the hue circle (``below`` then ``above``, going up).

    ``boundary`` is the last hue of ``below``'s range when the ranges meet (``None`` when free
    hues are left between them). ``margin_below``/``margin_above``: hue units from the nearest
    mark mean hue of each colour to its range's edge on this side — how far a change of light
    may move a mark's hue before it leaves its colour (into the other one where they meet).
    ``pixel_overlap``: hue units that both colours' pixel hues (2nd..98th percentile) share
    (0 if none).
    """

    below: str
    above: str
    boundary: int | None
    margin_below: float
    margin_above: float
    pixel_overlap: float

    @property
    def margin(self) -> float:
        return min(self.margin_below, self.margin_above)


@dataclass(frozen=True)
class PaletteProposal:
    colours: tuple[ProposedColour, ...]
    gaps: tuple[Gap, ...]
    warnings: tuple[str, ...]
    labels: tuple[str, ...]  # the colour name given to each mark, in the order of the marks

    def palette(self) -> Palette:
        return tuple(c.range() for c in self.colours)


def _assign_names(means: list[float], requests: Sequence[ColourRequest]) -> list[int]:
    """Request index for each group: the one-to-one naming with the least squared hue distance
    between each group's mean and its name's hue."""
    k = len(means)
    best: tuple[float, tuple[int, ...]] = (float("inf"), tuple(range(k)))
    for perm in itertools.permutations(range(k)):
        cost = sum(float(hue_diff(means[g], requests[perm[g]].hue)) ** 2 for g in range(k))
        if cost < best[0]:
            best = (cost, perm)
    return list(best[1])


def _runs(hues: list[int]) -> str:
    """``[3, 4, 5, 9]`` → ``"3..5, 9"``."""
    parts: list[str] = []
    start = prev = hues[0]
    for h in [*hues[1:], None]:
        if h is not None and h == prev + 1:
            prev = h
            continue
        parts.append(f"{start}..{prev}" if prev != start else f"{start}")
        if h is not None:
            start = prev = h
    return ", ".join(parts)


def _wrap(h: float) -> float:
    """``h`` in [0, 180), with ``-0.0`` and rounding up to 180 mapped to 0."""
    out = round(h, 6) % HUE_MAX
    return 0.0 if out >= HUE_MAX or out == 0 else out


def propose_palette(marks: Sequence[RoundMark], requests: Sequence[ColourRequest], *,
                    clutter: FloatArray | None = None, clutter_share: float = 0.002,
                    max_margin: int = 12, min_margin: float = 3.0,
                    sat_share: float = 0.6, sat_default: int = 100,
                    val_default: int = 50) -> PaletteProposal:
    """Hue ranges for ``requests`` from ``marks`` (at least one mark per colour).

    Between two colours next to each other on the hue circle, the boundary lies halfway between
    their nearest marks' mean hues (the detector names a blob by its mean hue), so both get the
    same margin. Away from a neighbour, a range covers its marks' pixel hues and reaches
    ``max_margin`` (hue units) past them: room for light the photos did not see (after white
    balance, daylight against a warm lamp moves a printed colour by a few units); wider would
    only let clutter of other hues into the detector's search. ``clutter`` (from
    :func:`scene_hues`, averaged over the frames): a range stops before the first hue at which
    other saturated surfaces of the photos cover ``clutter_share`` of a frame (0.002: a disc
    of 14 px radius at 640×480, a small mark), and a colour whose own marks' hues are that
    common elsewhere in the photos gets a warning. Two colours whose margin is below
    ``min_margin`` (hue units) get a warning: a change of light can carry one into the other.
    ``sat_min`` is ``sat_share`` of the palest mark's median saturation (distance blur and glare
    lower it), never above ``sat_default`` (what the detector is tuned with), and ``val_min``
    likewise of the darkest mark's median value, never above ``val_default``.
    """
    k = len(requests)
    if k < 1:
        raise ValueError("no colours requested")
    if len(marks) < k:
        raise ValueError(f"found {len(marks)} round saturated mark{'s' if len(marks) != 1 else ''}"
                         f" but {k} colours were asked for: each colour needs at least one")
    groups = cluster_marks([m.hue for m in marks], k)
    members = [[m for m, g in zip(marks, groups, strict=True) if g == gi] for gi in range(k)]
    means = [circular_mean(np.array([m.hue for m in ms]))[0] for ms in members]
    names = _assign_names(means, requests)
    order = sorted(range(k), key=lambda g: means[g])
    # Per group, unwrapped around its mean: mark mean hues and pixel hues (2..98 %).
    mark_ext: dict[int, tuple[float, float]] = {}
    pix_ext: dict[int, tuple[float, float]] = {}
    for g in range(k):
        offs = [float(hue_diff(m.hue, means[g])) for m in members[g]]
        mark_ext[g] = (means[g] + min(offs), means[g] + max(offs))
        pix_ext[g] = (means[g] + min(o + m.hue_lo for o, m in zip(offs, members[g], strict=True)),
                      means[g] + max(o + m.hue_hi for o, m in zip(offs, members[g], strict=True)))
    busy = (np.zeros(HUE_MAX, bool) if clutter is None
            else np.asarray(clutter, np.float64) >= clutter_share)
    lo_edge: dict[int, int] = {}
    hi_edge: dict[int, int] = {}
    stopped: dict[int, list[int]] = {g: [] for g in range(k)}
    gaps: list[Gap] = []
    warnings: list[str] = []
    for g in range(k):
        lo, hi = math.floor(pix_ext[g][0]), math.ceil(pix_ext[g][1])
        # the hues the marks are read as (their mean hues, give or take min_margin)
        core = range(math.floor(mark_ext[g][0] - min_margin),
                     math.ceil(mark_ext[g][1] + min_margin) + 1)
        own = [h % HUE_MAX for h in core if busy[h % HUE_MAX]]
        if own:
            warnings.append(
                f"{requests[names[g]].name}: other saturated surfaces in the photos have its "
                f"marks' hues ({_runs(own)}); the detector may take them, or join them to "
                "its marks (a mark against a floor or wall of its own hue)")
        reach = 0
        while reach < max_margin and not busy[(hi + reach + 1) % HUE_MAX]:
            reach += 1
        hi_edge[g] = hi + reach
        if reach < max_margin:
            stopped[g].append((hi + reach + 1) % HUE_MAX)
        reach = 0
        while reach < max_margin and not busy[(lo - reach - 1) % HUE_MAX]:
            reach += 1
        lo_edge[g] = lo - reach
        if reach < max_margin:
            stopped[g].append((lo - reach - 1) % HUE_MAX)
    pairs = [(order[i], order[(i + 1) % k], HUE_MAX if i == k - 1 else 0)
             for i in range(k if k > 1 else 0)]  # the last pair: round the circle
    boundaries: list[int | None] = []
    for a, b, shift in pairs:
        boundary: int = math.floor((mark_ext[a][1] + mark_ext[b][0] + shift) / 2.0)
        if hi_edge[a] >= boundary or lo_edge[b] + shift <= boundary + 1:  # the ranges meet
            hi_edge[a] = min(hi_edge[a], boundary)
            lo_edge[b] = max(lo_edge[b] + shift, boundary + 1) - shift
            boundaries.append(boundary)
        else:
            boundaries.append(None)
    for (a, b, shift), met in zip(pairs, boundaries, strict=True):
        a_hi, b_lo = mark_ext[a][1], mark_ext[b][0] + shift
        margin_a = hi_edge[a] + 0.5 - a_hi
        margin_b = b_lo - (lo_edge[b] + shift - 0.5)
        overlap = max(0.0, pix_ext[a][1] - (pix_ext[b][0] + shift))
        name_a, name_b = requests[names[a]].name, requests[names[b]].name
        gaps.append(Gap(name_a, name_b, None if met is None else met % HUE_MAX,
                        round(margin_a, 2), round(margin_b, 2), round(overlap, 1)))
        if met is not None and min(margin_a, margin_b) < min_margin:
            how = "overlap" if overlap > 0 else "are close"
            warnings.append(
                f"{name_a} and {name_b} {how}: their marks' mean hues are only "
                f"{b_lo - a_hi:.1f} hue units apart ({name_a} up to {_wrap(a_hi):.1f}, "
                f"{name_b} from {_wrap(b_lo):.1f})"
                + (f" and their pixels' hues share {overlap:.0f} units" if overlap > 0 else "")
                + f"; split at {met % HUE_MAX}|{(met + 1) % HUE_MAX}, a margin of "
                f"{min(margin_a, margin_b):.1f} hue units: a change of light will carry one into "
                "the other (choose marks of more different colours)")
    colours = []
    for g in order:
        req = requests[names[g]]
        lo, hi = lo_edge[g], hi_edge[g]
        if hi - lo + 1 >= HUE_MAX:  # a lone colour never takes the whole circle
            excess = hi - lo + 2 - HUE_MAX
            lo, hi = lo + excess // 2, hi - (excess - excess // 2)
        sat = min(m.saturation for m in members[g])
        val = min(m.value for m in members[g])
        colours.append(ProposedColour(
            name=req.name, hue_lo=lo % HUE_MAX, hue_hi=hi % HUE_MAX, mean_hue=_wrap(means[g]),
            mark_hues=(_wrap(mark_ext[g][0]), _wrap(mark_ext[g][1])),
            pixel_hues=(_wrap(pix_ext[g][0]), _wrap(pix_ext[g][1])), marks=len(members[g]),
            sat_min=int(max(1, min(sat_default, sat_share * sat))),
            val_min=int(max(1, min(val_default, sat_share * val))), side=req.side,
            stopped_at=tuple(stopped[g])))
    colours.sort(key=lambda c: [r.name for r in requests].index(c.name))
    labels = tuple(requests[names[g]].name for g in groups)
    return PaletteProposal(tuple(colours), tuple(gaps), tuple(warnings), labels)


def yaml_block(proposal: PaletteProposal) -> str:
    """The ``marks.colours`` block to paste (a colour without a side given says so)."""
    lines = ["marks:", "  colours:                  # hue in OpenCV units 0..179, taught from "
             "photos"]
    width = max(len(c.name) for c in proposal.colours)
    for c in proposal.colours:
        side = f", side: {c.side}" if c.side else ""
        line = (f"    {c.name + ':':<{width + 1}} {{hue: [{c.hue_lo}, {c.hue_hi}]{side}, "
                f"sat_min: {c.sat_min}, val_min: {c.val_min}}}")
        if not c.side:
            line += "  # add side: left or right"
        lines.append(line)
    return "\n".join(lines)


# --------------------------------------------------------------------------------------------
# 4. How a palette separates the marks
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ColourCheck:
    """One colour of a palette against the marks found: ``marks`` whose mean hue is nearest
    this colour (the group it names), of which ``inside`` fall in its range, ``in_other`` in
    another colour's range (``other_names``) and ``in_none`` in no range; ``min_margin`` is the
    smallest distance (hue units) from an inside mark's hue to its range's edge."""

    name: str
    marks: int
    inside: int
    in_other: int
    in_none: int
    other_names: tuple[str, ...]
    min_margin: float | None


def _nearest_colour(palette: Palette, hue: float) -> int:
    """Index of the range holding ``hue`` (the one whose centre is nearest if several), else
    of the nearest range."""
    holding = [i for i, c in enumerate(palette) if c.contains(hue)]
    if holding:
        return min(holding, key=lambda i: abs(float(hue_diff(hue, palette[i].centre_hue))))
    return min(range(len(palette)), key=lambda i: palette[i].distance(hue))


def check_palette(marks: Sequence[RoundMark], palette: Palette) -> tuple[list[ColourCheck],
                                                                         list[str]]:
    """Per colour of ``palette``: how the marks that belong to it (by grouping the marks into
    as many hue groups as the palette has colours, each group given to the colour nearest its
    mean) fall on its range. Also the colour each mark was given, in the order of ``marks``."""
    k = len(palette)
    if not marks:
        return [ColourCheck(c.name, 0, 0, 0, 0, (), None) for c in palette], []
    groups = cluster_marks([m.hue for m in marks], min(k, len(marks)))
    kk = max(groups) + 1
    means = [circular_mean(np.array([m.hue for m, g in zip(marks, groups, strict=True)
                                     if g == gi]))[0] for gi in range(kk)]
    requests = [ColourRequest(c.name, c.centre_hue) for c in palette]
    if kk == k:
        owner = [palette.index(palette[i]) for i in _assign_names(means, requests)]
    else:
        owner = [_nearest_colour(palette, mu) for mu in means]
    belongs = [owner[g] for g in groups]
    out = []
    for i, c in enumerate(palette):
        mine = [m for m, b in zip(marks, belongs, strict=True) if b == i]
        inside = [m for m in mine if c.contains(m.hue)]
        others: list[str] = []
        in_none = 0
        for m in mine:
            if c.contains(m.hue):
                continue
            held = [o.name for o in palette if o.name != c.name and o.contains(m.hue)]
            if held:
                others.extend(held)
            else:
                in_none += 1
        margin = min((_inside_margin(c, m.hue) for m in inside), default=None)
        out.append(ColourCheck(c.name, len(mine), len(inside), len(mine) - len(inside) - in_none,
                               in_none, tuple(sorted(set(others))), margin))
    return out, [palette[b].name for b in belongs]


def _inside_margin(c: ColourRange, hue: float) -> float:
    """Distance (hue units) from ``hue``, inside ``c``, to the nearer edge of ``c``."""
    to_lo = (hue - c.hue_lo) % HUE_MAX
    to_hi = (c.hue_hi - hue) % HUE_MAX
    return float(min(to_lo, to_hi))
