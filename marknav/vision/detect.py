"""Coloured circular marks in one BGR frame (paper §3: HSV colour space, circles and ellipses).

The paper (§3.2) classifies marks in HSV because hue and saturation move little when the light
changes, finds circles with the Hough transform (§3.3) and checks each object against the ellipse
fitted to its contour. This module keeps that idea and orders it for speed: every pixel of the
frame goes through a few OpenCV calls at half resolution; Python work is per blob, O(1) calls for
a whole mark, and only blobs that may be partial marks reach the slower arc path.

1. **Search at half resolution** (``DetectorConfig.downscale``): the frame is box-reduced
   (``INTER_AREA``); a **white balance** (grey world over the frame's low-saturation pixels
   only, gains clamped to ``gain_limits``) removes colour casts; one HSV mask
   ``S >= sat_min, V >= v_floor``, a 3×3 opening and external contours give the blobs.
   ``v_floor`` is the palette's value floor scaled to the scene's exposure and at least
   ``val_rel_min`` of its grey level: a colour much darker than its surroundings is brown or
   black, not orange or red.
2. **Cheap rejection** with a handful of OpenCV calls: blobs too small, too thin (stripes),
   rectangle-like (area / minimum bounding rectangle > ``max_extent``), small triangles (<
   ``min_small_extent`` of it).
3. **Fast path** (an isolated whole mark: inside the image, convex): the ellipse with the
   contour's area and second moments must follow every contour point (radial deviation, axis
   ratio), and the convex hull must have no straight cut (an occluder's edge). The mark is then
   measured in a small window (at full resolution; marks of ``fine_radius`` and more in the
   half-resolution image, whose box-averaged pixels keep coverage linear): each pixel is
   projected on the mark-minus-background colour difference with its grey component removed,
   which gives the pixel's coverage ``α`` by the mark (linear in coverage, blind to shading and
   to the light's level). The ``α >= 0.5`` pixels (the mid-level of chroma) give area,
   centroid and shape by image moments (the pixel count is an unbiased area), so
   the radius is not biased by blur or by where a contour runs through the edge pixels; their
   mismatch with the fitted ellipse must be small (``max_outline_error``). The colour is the
   palette colour of the mark's mean (white-balanced) hue; red wraps 170..10.
4. **Slow path** (cut by the image edge, partly hidden, touching another mark — or clutter):
   polygons (few hull vertices), shapes far from their fitted ellipse's area and shapes with no
   plausible arc at half resolution are dropped first. The colour comes from the blob's hue
   histogram; a blob that holds two palette colours in separate hue clusters is also read per
   colour (touching marks of different colours), and the reading that explains it with more
   marks wins. In a full-resolution window the ``α >= 0.5`` mask of the colour (pixels of the
   other palette colours excluded) is traced; its parts are tried as whole marks, else contour
   points on the image border and in concave stretches are dropped and the remaining arcs
   fitted with circles (or an ellipse when they go round enough of it), arcs of one circle
   merged — what the Hough transform gives the paper (a partial circle still yields its centre
   and radius), without an accumulator. The edge points are moved to the ``α = 0.5`` crossing
   along the normals (one vectorised bilinear sampling) and refitted; a candidate must be
   supported by enough of its outline, filled by its colour (marks of other colours in front
   do not count against it) and not continue past its outline.

Output: :class:`Mark` objects sorted by radius, largest (nearest) first. ``radius`` is the
semi-major axis (eqs. 2-4 of the paper relate it to range).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import cv2
import numpy as np
import numpy.typing as npt

from marknav.vision.palette import DEFAULT_PALETTE, HUE_MAX, ColourRange, Palette

log = logging.getLogger(__name__)

__all__ = ["Detector", "DetectorConfig", "Mark", "detect_marks"]

Shape = Literal["circle", "ellipse"]
FloatArray = npt.NDArray[np.float64]
U8Array = npt.NDArray[np.uint8]
#: What OpenCV returns (images, masks, contours): its stubs type the element loosely.
Mat = npt.NDArray[Any]
Contour = Mat

_NO_COLOUR = 255
#: Steps per hue unit of the table that names a mean hue's colour.
_FINE = 4
#: Mark-minus-background colour difference (grey component removed) below which a window has
#: no mark to measure (BGR units).
_MIN_CONTRAST = 12.0
#: Bands around a coarse ellipse in the full-resolution window (px beyond its outline): the
#: mark is counted inside ``_DOMAIN``; the window reaches ``_BACK`` beyond the outline and its
#: pixels outside the domain are the background.
_DOMAIN = 4.0
_BACK = 8.0
#: Samples along an edge normal for the sub-pixel crossing (px from the contour point).
_RAY_T = np.array([-1.5, -0.75, 0.0, 0.75, 1.5, 2.25], np.float64)


@dataclass(frozen=True)
class Mark:
    """One detected mark, in pixels (u right, v down; pixel centres at integer coordinates).

    ``radius`` is the semi-major axis; ``axes`` is (semi-major, semi-minor); ``angle_deg`` is the
    direction of the major axis, degrees in [0, 180) from +u towards +v (0 for circles).
    ``score`` in [0, 1] grows with the share of the outline seen, the fit quality and the colour
    purity.
    """

    colour: str
    x: float
    y: float
    radius: float
    axes: tuple[float, float]
    angle_deg: float
    shape: Shape
    score: float

    def to_dict(self) -> dict[str, object]:
        """The JSON form: ``{colour, x, y, radius, axes, angle, shape, score}`` (angle: deg)."""
        return {
            "colour": self.colour,
            "x": round(self.x, 2),
            "y": round(self.y, 2),
            "radius": round(self.radius, 2),
            "axes": [round(self.axes[0], 2), round(self.axes[1], 2)],
            "angle": round(self.angle_deg, 1),
            "shape": self.shape,
            "score": round(self.score, 3),
        }


@dataclass(frozen=True)
class DetectorConfig:
    """Tuning of :class:`Detector`. The defaults suit 320×240 to 1280×720 frames.

    The saturation/value floors come from the palette (:class:`ColourRange`); the mask uses the
    lowest floors of the palette and each colour's own floors are checked on its blobs.
    """

    #: Grey-world white balance before classification (fixes warm/cool casts).
    white_balance: bool = True
    #: Lowest and highest white-balance gain per channel.
    gain_limits: tuple[float, float] = (0.6, 1.6)
    #: The palette's value floors hold for scenes whose grey level is at least this (0..255);
    #: in darker scenes (an under-exposed camera, dim light) they scale down with it.
    val_ref_grey: float = 100.0
    #: A blob's value floor is also at least this fraction of the scene's grey level.
    val_rel_min: float = 0.35
    #: Blob search at 1/downscale resolution (1 or 2); marks are measured at full resolution,
    #: whole ones of ``fine_radius`` or more in the search image.
    downscale: int = 2
    #: Side of the square opening applied to the search mask (odd, 1 = none).
    open_size: int = 3
    #: Smallest and largest semi-major axis reported (px); ``None`` = no upper limit.
    min_radius: float = 5.0
    max_radius: float | None = None
    #: Smallest radius of a mark seen only in part (cut by the image edge, partly hidden,
    #: touching another): a smaller arc cannot be told from the rounded end of a bar.
    min_partial_radius: float = 8.0
    #: Whole marks of at least this radius (px) are measured in the search image.
    fine_radius: float = 24.0
    #: Smallest minor/major ratio accepted (a mark seen at a steep angle).
    min_axis_ratio: float = 0.4
    #: ``circle`` when minor/major is at least this, else ``ellipse``.
    circle_ratio: float = 0.9
    #: Hue (OpenCV units) a blob's mean hue may lie outside a palette range and still get its name.
    hue_margin: float = 2.0
    #: A blob holding two palette colours whose mean hues differ by at least this (OpenCV hue
    #: units), each over at least half a ``min_partial_radius`` disc, is also read per colour:
    #: touching marks. Closer hues are one mark's shading.
    split_hue_gap: float = 8.0
    #: Blobs whose area exceeds this share of their minimum bounding rectangle are rectangles.
    max_extent: float = 0.9
    #: Blobs smaller than 20 px (equivalent radius) filling less than this share of their
    #: minimum bounding rectangle are triangles or splinters.
    min_small_extent: float = 0.62
    #: Blob area / convex hull area at or above which a blob counts as convex (fast path).
    min_solidity: float = 0.93
    #: Largest mismatch between a whole mark's pixels and its fitted ellipse, in pixels per pixel
    #: of outline (0.25-0.55 for clean discs of any size; a square gives ≈ 0.05 × its side, a
    #: disc with a fifth of its outline hidden ≈ 0.02 × its radius). Larger: the arc path.
    max_outline_error: float = 0.65
    #: Share of the visible outline (inside the image) that must be seen as the mark's edge
    #: (0.1 more for marks smaller than 2.5 × ``min_partial_radius``).
    min_support: float = 0.4
    #: Share of the whole outline that must be seen (a sliver at the image edge is not a mark).
    min_arc: float = 0.3
    #: Share of a partial mark's visible area that must have its colour.
    min_fill: float = 0.7
    #: Largest share of the visible outline across which the mark's colour goes on: more is the
    #: end of a stripe or a corner of a larger shape, not a mark.
    max_continued: float = 0.15
    #: Marks scoring lower than this are dropped.
    min_score: float = 0.05

    def __post_init__(self) -> None:
        if self.open_size < 1 or self.open_size % 2 == 0:
            raise ValueError(f"open_size must be odd and >= 1, got {self.open_size}")
        if self.downscale not in (1, 2):
            raise ValueError(f"downscale must be 1 or 2, got {self.downscale}")
        if self.min_radius <= 0:
            raise ValueError(f"min_radius must be > 0, got {self.min_radius}")
        if self.max_radius is not None and self.max_radius < self.min_radius:
            raise ValueError("max_radius must be >= min_radius")
        if self.min_partial_radius < self.min_radius:
            raise ValueError("min_partial_radius must be >= min_radius")
        lo, hi = self.gain_limits
        if not 0 < lo <= 1 <= hi:
            raise ValueError(f"gain_limits must satisfy 0 < low <= 1 <= high, got {lo, hi}")
        for name in ("min_axis_ratio", "circle_ratio", "min_support", "max_continued",
                     "min_arc", "min_fill", "val_rel_min", "min_score", "max_extent",
                     "min_small_extent", "min_solidity"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {value}")


@dataclass(slots=True)
class _Ellipse:
    """Centre, semi-axes ``a`` along ``theta`` (radians, image axes) and ``b`` across it."""

    cx: float
    cy: float
    a: float
    b: float
    theta: float

    @property
    def major(self) -> float:
        return max(self.a, self.b)

    @property
    def minor(self) -> float:
        return min(self.a, self.b)

    def rho(self, pts: FloatArray) -> FloatArray:
        """Normalised radius of each point: 1 on the ellipse, < 1 inside."""
        dx = pts[:, 0] - self.cx
        dy = pts[:, 1] - self.cy
        c, s = math.cos(self.theta), math.sin(self.theta)
        u = (dx * c + dy * s) / self.a
        v = (-dx * s + dy * c) / self.b
        out: FloatArray = np.sqrt(u * u + v * v)
        return out

    def residuals(self, pts: FloatArray) -> FloatArray:
        """Signed distance (px, + outside) of each point from the ellipse, along its ray from the
        centre (exact for circles, close for the mildly eccentric ellipses of marks)."""
        if self.a == self.b:
            out_c: FloatArray = np.hypot(pts[:, 0] - self.cx, pts[:, 1] - self.cy) - self.a
            return out_c
        rho = self.rho(pts)
        dist = np.hypot(pts[:, 0] - self.cx, pts[:, 1] - self.cy)
        with np.errstate(divide="ignore", invalid="ignore"):
            res = dist * (1.0 - 1.0 / rho)
        out: FloatArray = np.nan_to_num(res, nan=-self.minor)
        return out

    def perimeter(self) -> float:
        a, b = self.a, self.b
        return math.pi * (3 * (a + b) - math.sqrt(max((3 * a + b) * (a + 3 * b), 0.0)))

    def scaled(self, da: float) -> _Ellipse:
        """The ellipse with both semi-axes grown by ``da`` px (shrunk when negative, >= 0.5)."""
        return _Ellipse(self.cx, self.cy, max(0.5, self.a + da), max(0.5, self.b + da),
                        self.theta)


def _from_rotated_rect(rect: tuple[Sequence[float], Sequence[float], float]) -> _Ellipse:
    (cx, cy), (w, h), angle = rect
    return _Ellipse(float(cx), float(cy), float(w) / 2.0, float(h) / 2.0, math.radians(angle))


def _fit_circle(pts: FloatArray, iterations: int = 0) -> _Ellipse | None:
    """Least-squares circle: the algebraic (Kåsa) fit in closed form, then ``iterations``
    Gauss-Newton steps on the geometric distances (the algebraic fit shrinks short arcs)."""
    n = len(pts)
    if n < 3:
        return None
    mean = pts.mean(axis=0)
    u = pts[:, 0] - mean[0]
    v = pts[:, 1] - mean[1]
    uu, vv = u * u, v * v
    suu, svv, suv = float(uu.sum()), float(vv.sum()), float((u * v).sum())
    rhs_u = 0.5 * float((u * (uu + vv)).sum())
    rhs_v = 0.5 * float((v * (uu + vv)).sum())
    det = suu * svv - suv * suv
    if abs(det) < 1e-9 * max(suu * svv, 1e-12):
        return None
    cx = (rhs_u * svv - rhs_v * suv) / det
    cy = (rhs_v * suu - rhs_u * suv) / det
    r = math.sqrt(cx * cx + cy * cy + (suu + svv) / n)
    for _ in range(iterations):
        dx = u - cx
        dy = v - cy
        dist = np.sqrt(dx * dx + dy * dy)
        if float(dist.min()) < 1e-9:
            break
        jac = np.column_stack([dx / dist, dy / dist, np.ones(n)])
        try:
            step = np.linalg.solve(jac.T @ jac, jac.T @ (dist - r))
        except np.linalg.LinAlgError:
            break
        cx, cy, r = cx + float(step[0]), cy + float(step[1]), r + float(step[2])
        if float(np.abs(step).max()) < 1e-3:
            break
    if not (r > 0 and math.isfinite(cx) and math.isfinite(cy) and math.isfinite(r)):
        return None
    return _Ellipse(cx + float(mean[0]), cy + float(mean[1]), r, r, 0.0)


def _fit_ellipse(pts: FloatArray) -> _Ellipse | None:
    if len(pts) < 6:
        return None
    try:
        e = _from_rotated_rect(cv2.fitEllipseDirect(pts.astype(np.float32)))
    except cv2.error:
        return None
    if not (e.a > 0 and e.b > 0 and math.isfinite(e.cx) and math.isfinite(e.cy)):
        return None
    return e


def _rms(values: FloatArray) -> float:
    return float(np.sqrt(np.mean(values * values))) if len(values) else math.inf


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


_COS_36 = np.cos(np.arange(36) * (2.0 * math.pi / 36))
_SIN_36 = np.sin(np.arange(36) * (2.0 * math.pi / 36))
_HUE_ANGLES = np.arange(HUE_MAX) * (2.0 * math.pi / HUE_MAX)
_HUE_SIN = np.sin(_HUE_ANGLES)
_HUE_COS = np.cos(_HUE_ANGLES)


def _runs(keep: npt.NDArray[np.bool_]) -> list[npt.NDArray[np.intp]]:
    """Index arrays of the maximal runs of True in a cyclic boolean array."""
    n = len(keep)
    if n == 0 or not keep.any():
        return []
    if keep.all():
        return [np.arange(n)]
    start = int(np.argmin(keep))  # a False element: runs cannot wrap past it
    rolled = np.concatenate((keep[start:], keep[:start]))
    idx = np.concatenate((np.arange(start, n), np.arange(start)))
    edges = np.diff(np.concatenate([[0], rolled.astype(np.int8), [0]]))
    begins = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1)
    return [idx[b:e] for b, e in zip(begins, ends, strict=True)]


@dataclass
class _Frame:
    """One frame's shared data: the full image, the half-resolution search products, and the
    white-balance matrix (applied to full-resolution windows when their hues are needed)."""

    image: Mat
    width: int
    height: int
    small: Mat  # search resolution, white-balanced
    hsv: Mat  # search resolution, white-balanced
    mask: Mat  # search resolution
    sx: float  # full-resolution px per search px
    sy: float
    balance: npt.NDArray[np.float32] | None  # 3×3 white-balance matrix, None when identity
    v_floor: int


@dataclass
class _Measured:
    """A whole mark measured in one image (that image's pixels)."""

    ellipse: _Ellipse
    error: float  # pixel/ellipse mismatch per pixel of outline
    mark_bgr: tuple[float, float, float]  # mean colour inside the mark


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


@dataclass
class _Window:
    """A full-resolution window of the frame with its per-pixel palette labels."""

    x0: int
    y0: int
    bgr: Mat
    labels: Mat  # palette index per pixel, _NO_COLOUR for none
    blob: Mat  # the blob's pixels, dilated (255)


class Detector:
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
        self._sat_min = min(c.sat_min for c in self.palette)
        self._val_min = min(c.val_min for c in self.palette)
        self._uniform_floors = all(
            c.sat_min == self._sat_min and c.val_min == self._val_min for c in self.palette
        )
        hue_lut = self._build_hue_lut(self.palette, self.config.hue_margin)
        self._hue_lut = np.full(256, _NO_COLOUR, np.uint8)
        self._hue_lut[:HUE_MAX] = hue_lut
        self._fine_lut = self._build_fine_lut(self.palette, self.config.hue_margin)
        self._membership = np.zeros((len(self.palette), HUE_MAX), np.float64)
        for k in range(len(self.palette)):
            self._membership[k, hue_lut == k] = 1.0
        size = self.config.open_size
        self._kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (size, size))
        self._kernel3 = cv2.getStructuringElement(cv2.MORPH_RECT, (3, 3))
        self.last_gains: tuple[float, float, float] = (1.0, 1.0, 1.0)
        self.last_grey_level: float = 0.0

    # ------------------------------------------------------------------ set-up helpers

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

    # ------------------------------------------------------------------ white balance

    def white_balance(self, image: U8Array | Mat) -> tuple[tuple[float, float, float], float]:
        """Grey-world gains (B, G, R) from the low-saturation pixels, and the scene's grey level.

        Measured on a ≈ 48-pixel-wide subsample. Only pixels that already look grey count: the
        less saturated part of the frame (saturation up to 25 above its 40th percentile, within
        60..160, so a strong cast that lifts grey to S ≈ 100 still counts as grey while marks
        at S ≈ 255 do not), neither black nor clipped (unless nearly all greys are clipped, as in
        an overexposed frame: then the clipped ones count). A second pass keeps the pixels that are
        grey (``S < 40``) after the first gains. Coloured marks and clutter therefore cannot
        pull the gains, however large they are in the frame. With fewer than 5 % grey pixels
        there is nothing to balance against: gains 1. Gains are clamped to
        ``config.gain_limits``.
        """
        h, w = image.shape[:2]
        step = max(1, w // 48)
        tiny = cv2.resize(image, (max(1, w // step), max(1, h // step)),
                          interpolation=cv2.INTER_NEAREST)
        lo, hi = self.config.gain_limits
        gains = (1.0, 1.0, 1.0)
        grey = -1.0
        hsv = cv2.cvtColor(tiny, cv2.COLOR_BGR2HSV)
        hist = cv2.calcHist([hsv], [1], None, [256], [0, 256]).ravel()
        s40 = int(np.searchsorted(np.cumsum(hist), 0.4 * float(hist.sum())))
        s_max = min(160, max(60, s40 + 25))
        for attempt in range(2):
            greyish = cv2.inRange(hsv, (0, 0, 16), (255, s_max, 250))
            if attempt == 0 and cv2.countNonZero(greyish) < 0.05 * greyish.size:
                # An overexposed scene: its greys are clipped. Clipping flattens a cast but keeps
                # its direction, so the clipped near-whites still say which way to correct.
                greyish = cv2.inRange(hsv, (0, 0, 16), (255, s_max, 255))
            if cv2.countNonZero(greyish) < 0.05 * greyish.size:
                break
            mean = cv2.mean(tiny, mask=greyish)
            grey = (mean[0] + mean[1] + mean[2]) / 3.0
            b, g, r = (min(hi, max(lo, grey / max(c, 1.0))) for c in mean[:3])
            gains = (b, g, r)
            if max(abs(b - 1.0), abs(g - 1.0), abs(r - 1.0)) <= 0.02:
                break
            hsv = cv2.cvtColor(cv2.transform(tiny, _diagonal(gains)), cv2.COLOR_BGR2HSV)
            s_max = 40
        if grey < 0:  # no grey to measure: the scene's mean level
            mean = cv2.mean(tiny)
            grey = (mean[0] + mean[1] + mean[2]) / 3.0
        return gains, grey

    def _value_floor(self, grey: float) -> int:
        cfg = self.config
        exposure = min(1.0, grey / cfg.val_ref_grey) if cfg.val_ref_grey > 0 else 1.0
        return int(max(self._val_min * exposure, cfg.val_rel_min * grey))

    # ------------------------------------------------------------------ pipeline

    def detect(self, image: U8Array) -> list[Mark]:
        """All marks in a BGR ``uint8`` image (H×W×3), largest first."""
        if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim != 3 \
                or image.shape[2] != 3:
            raise ValueError("detect() needs a BGR uint8 image of shape (H, W, 3)")
        cfg = self.config
        h, w = image.shape[:2]
        scale = cfg.downscale if min(h, w) >= 64 * cfg.downscale else 1
        if scale > 1:
            sw, sh = w // scale, h // scale
            small = cv2.resize(image, (sw, sh), interpolation=cv2.INTER_AREA)
        else:
            sw, sh, small = w, h, image
        if cfg.white_balance:
            gains, grey = self.white_balance(small)
        else:
            gains, grey = (1.0, 1.0, 1.0), float(np.mean(cv2.mean(small)[:3]))
        self.last_gains, self.last_grey_level = gains, grey
        balance = None
        if max(abs(g - 1.0) for g in gains) > 0.02:
            balance = _diagonal(gains)
            small = cv2.transform(small, balance)
        hsv = cv2.cvtColor(small, cv2.COLOR_BGR2HSV)
        v_floor = self._value_floor(grey)
        mask = cv2.inRange(hsv, (0, self._sat_min, v_floor), (255, 255, 255))
        if cfg.open_size > 1:
            mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, self._kernel)
        contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
        frame = _Frame(image, w, h, small, hsv, mask, w / sw, h / sh, balance, v_floor)
        min_area = 0.4 * math.pi * (cfg.min_radius / scale) ** 2
        marks: list[Mark] = []
        for contour in contours:
            if len(contour) < 6:
                continue
            area = cv2.contourArea(contour)
            if area < min_area:
                continue
            marks.extend(self._blob(frame, contour, area))
        marks = _suppress_duplicates(marks)
        marks.sort(key=lambda m: (-m.radius, m.x, m.y))
        return marks

    # ------------------------------------------------------------------ per blob (search scale)

    def _blob(self, frame: _Frame, contour: Contour, area: float) -> list[Mark]:
        cfg = self.config
        s = frame.sx
        bx, by, bw, bh = cv2.boundingRect(contour)
        box = (bx, by, bw, bh)
        sh, sw = frame.mask.shape
        border = bx <= 0 or by <= 0 or bx + bw >= sw or by + bh >= sh
        _, (rw, rh), _ = cv2.minAreaRect(contour)
        # Cheap clutter rejection: slivers and stripes (a mark's visible part, even cut by the
        # image edge down to ``min_arc`` of its outline, is at least a quarter as wide as long),
        # rectangles (they fill their minimum bounding rectangle).
        if (min(rw, rh) + 1.0) * s < 1.2 * cfg.min_radius or min(rw, rh) < 0.3 * max(rw, rh):
            return []
        if area > cfg.max_extent * rw * rh and min(rw, rh) * s >= 24.0:
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
        single: list[Mark] = []
        if colours.colour is not None:
            # One mark's reading: every palette-coloured pixel of the blob is the mark (its
            # shading may straddle a palette boundary). A convex blob inside the image already
            # failed as a whole mark.
            single = self._window_marks(frame, colours.region, box, [colours.colour],
                                        purity={colours.colour: colours.purity},
                                        try_whole=border or not convex, merged=True)
        if not split:
            return single
        # Touching marks of different colours: each colour on its own, the others hiding it.
        # It stands when it finds more marks, or as many and at least two (one mark whose
        # shading straddles two palette colours is one mark).
        # (Each colour's part is that colour by construction: purity 1.)
        present = colours.present
        marks = self._window_marks(frame, colours.region, box, present,
                                   purity=dict.fromkeys(present, 1.0), try_whole=True)
        if len(marks) > len(single) or len(marks) == len(single) >= 2:
            return marks
        return single

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

    def _has_arc(self, frame: _Frame, contour: Contour, r_est: float) -> bool:
        """Whether a search-resolution contour holds an arc that could be a mark's: a circle
        through some of its convex stretches (off the image border) that its points follow
        within about a pixel over at least ~``min_arc`` of the circle, and beyond which its
        colour does not go on (as it does past the rounded end of a bar; a touching mark of
        another colour does not count). Cheap, so that clutter does not reach the
        full-resolution arc path."""
        cfg = self.config
        scale = frame.sx
        pts = contour.reshape(-1, 2).astype(np.float64)
        sh, sw = frame.mask.shape
        on_border = (pts[:, 0] <= 0) | (pts[:, 1] <= 0) | (pts[:, 0] >= sw - 1) | \
            (pts[:, 1] >= sh - 1)
        for fit, group in self._arc_candidates(pts, on_border, r_est, scale):
            if fit.major * scale < 0.9 * cfg.min_partial_radius:
                continue
            tol = max(0.75, 0.05 * fit.major)
            near = group[np.abs(fit.residuals(group)) <= 2.0 * tol]
            if len(near) < 6:
                continue
            ang = np.arctan2(near[:, 1] - fit.cy, near[:, 0] - fit.cx)
            seen = np.zeros(37, bool)
            seen[((ang + math.pi) * (36 / (2 * math.pi))).astype(np.intp)] = True
            if int(np.count_nonzero(seen)) < 0.8 * cfg.min_arc * 36:
                continue
            # The palette label 1.5 px outside the circle against the one 1.5 px inside it.
            cos, sin = _COS_36, _SIN_36
            xo = np.rint(fit.cx + (fit.major + 1.5) * cos).astype(np.intp)
            yo = np.rint(fit.cy + (fit.major + 1.5) * sin).astype(np.intp)
            r_in = max(0.5, fit.minor - 1.5)
            xi = np.clip(np.rint(fit.cx + r_in * cos).astype(np.intp), 0, sw - 1)
            yi = np.clip(np.rint(fit.cy + r_in * sin).astype(np.intp), 0, sh - 1)
            inside = (xo >= 0) & (xo < sw) & (yo >= 0) & (yo < sh)
            if not inside.any():
                continue
            xo, yo, xi, yi = xo[inside], yo[inside], xi[inside], yi[inside]
            label_out = self._hue_lut[frame.hsv[yo, xo, 0]]
            label_in = self._hue_lut[frame.hsv[yi, xi, 0]]
            beyond = np.count_nonzero((frame.mask[yo, xo] > 0) & (label_out == label_in))
            if beyond <= 0.25 * len(xo):
                return True
        return False

    def _whole_fit(self, contour: Contour, *, tolerance_px: float) -> _Ellipse | None:
        """The ellipse with a closed contour's area and second moments, if the contour is one:
        every contour point within ``max(tolerance_px, 9 % of the major axis)`` of it (radially),
        axis ratio at least ``min_axis_ratio``. ``tolerance_px`` is one pixel of the contour's
        own resolution."""
        e = _moments_ellipse(cv2.moments(contour))
        if e is None or e.minor < self.config.min_axis_ratio * 0.9 * e.major:
            return None
        # Normalised radius of every contour point: (u/a)² + (v/b)² through one 2×2 product.
        c, s = math.cos(e.theta), math.sin(e.theta)
        to_unit = np.array([[c / e.a, -s / e.b], [s / e.a, c / e.b]])
        q = (contour.reshape(-1, 2) - np.array([e.cx, e.cy])) @ to_unit
        lo, hi, _, _ = cv2.minMaxLoc(np.einsum("ij,ij->i", q, q))
        limit = max(tolerance_px, 0.09 * e.major) / math.sqrt(e.a * e.b)
        if math.sqrt(hi) > 1.0 + limit or math.sqrt(lo) < 1.0 - limit:
            return None
        return e

    @staticmethod
    def _to_full(frame: _Frame, e: _Ellipse) -> _Ellipse:
        """A search-resolution ellipse in full-resolution pixels (pixel centres at integers)."""
        return _Ellipse((e.cx + 0.5) * frame.sx - 0.5, (e.cy + 0.5) * frame.sy - 0.5,
                        e.a * frame.sx, e.b * frame.sy, e.theta)

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

    # ------------------------------------------------------------------ coverage (α)

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

    def _measure_whole(self, frame: _Frame, coarse: _Ellipse, colour: int | None,
                       purity: float, exclude: tuple[Mat, int, int] | None = None,
                       ) -> Mark | None:
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
        if exclude is None and frame.sx > 1 and coarse.major >= cfg.fine_radius:
            sx, sy = frame.sx, frame.sy
            local = _Ellipse((coarse.cx + 0.5) / sx - 0.5, (coarse.cy + 0.5) / sy - 0.5,
                             coarse.a / sx, coarse.b / sy, coarse.theta)
            measured = self._measure_in(frame.small, local, None, sx)
            if measured is None:
                return None
            e = measured.ellipse
            fitted = _Ellipse((e.cx + 0.5) * sx - 0.5, (e.cy + 0.5) * sy - 0.5, e.a * sx,
                              e.b * sy, e.theta)
            balanced = measured.mark_bgr  # the search image is white-balanced
        else:
            measured = self._measure_in(frame.image, coarse, exclude)
            if measured is None:
                return None
            fitted = measured.ellipse
            b, g, r = measured.mark_bgr
            gb, gg, gr = self.last_gains
            balanced = (b * gb, g * gg, r * gr)
        error = measured.error
        if error > cfg.max_outline_error:
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
        quality = max(0.0, 1.0 - 0.5 * error / cfg.max_outline_error)
        return self._mark(fitted, colour, purity * quality)

    def _measure_in(self, image: Mat, coarse: _Ellipse,
                    exclude: tuple[Mat, int, int] | None,
                    scale: float = 1.0) -> _Measured | None:
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
        cv2.bitwise_and(binary, domain, dst=binary)
        cv2.bitwise_or(binary, inner, dst=binary)
        fitted = _moments_ellipse(cv2.moments(binary, binaryImage=True))
        if fitted is None:
            return None
        mismatch = cv2.countNonZero(cv2.bitwise_xor(binary, _draw(shape, fitted)))
        error = mismatch / max(fitted.perimeter(), 1.0)
        out = _Ellipse(fitted.cx + x0, fitted.cy + y0, fitted.a, fitted.b, fitted.theta)
        return _Measured(out, error, (mark_bgr[0], mark_bgr[1], mark_bgr[2]))

    def _mark(self, e: _Ellipse, colour: int, score: float) -> Mark | None:
        cfg = self.config
        major, minor = e.major, e.minor
        if major < cfg.min_radius or (cfg.max_radius is not None and major > cfg.max_radius):
            return None
        if minor < cfg.min_axis_ratio * major or score < cfg.min_score:
            return None
        angle = math.degrees(e.theta) if major == e.a else math.degrees(e.theta) + 90.0
        angle %= 180.0
        shape: Shape = "circle" if minor >= cfg.circle_ratio * major else "ellipse"
        if shape == "circle":
            angle = 0.0
        return Mark(self.palette[colour].name, e.cx, e.cy, major, (major, minor), angle, shape,
                    min(1.0, score))

    # ------------------------------------------------------------------ full-resolution window

    def _window(self, frame: _Frame, region: Mat, box: tuple[int, int, int, int],
                pad: int) -> _Window:
        """The blob's bounding box at full resolution (plus ``pad`` px) with palette labels;
        pixels outside the blob (dilated) are unlabelled, so neighbours stay out."""
        bx, by, bw, bh = box
        s_x, s_y = frame.sx, frame.sy
        x0 = max(0, int(bx * s_x) - pad)
        y0 = max(0, int(by * s_y) - pad)
        x1 = min(frame.width, math.ceil((bx + bw) * s_x) + pad)
        y1 = min(frame.height, math.ceil((by + bh) * s_y) + pad)
        bgr = frame.image[y0:y1, x0:x1]
        balanced = bgr if frame.balance is None else cv2.transform(bgr, frame.balance)
        hsv = cv2.cvtColor(balanced, cv2.COLOR_BGR2HSV)
        coloured = cv2.inRange(hsv, (0, self._sat_min, frame.v_floor), (255, 255, 255))
        # The blob's own pixels: its search-resolution region, enlarged and dilated.
        blob = np.zeros((y1 - y0, x1 - x0), np.uint8)
        full_box = (int(bx * s_x) - x0, int(by * s_y) - y0)
        up = cv2.resize(region, (round(bw * s_x), round(bh * s_y)),
                        interpolation=cv2.INTER_NEAREST)
        fx0, fy0 = full_box
        hh = min(up.shape[0], blob.shape[0] - fy0)
        ww = min(up.shape[1], blob.shape[1] - fx0)
        blob[fy0:fy0 + hh, fx0:fx0 + ww] = up[:hh, :ww]
        k = 2 * pad + 1
        cv2.dilate(blob, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k)), dst=blob)
        cv2.bitwise_and(coloured, blob, dst=coloured)
        labels = cv2.LUT(np.ascontiguousarray(hsv[:, :, 0]), self._hue_lut)
        labels[coloured == 0] = _NO_COLOUR
        return _Window(x0, y0, bgr, labels, blob)

    def _window_marks(self, frame: _Frame, region: Mat,
                      box: tuple[int, int, int, int], colours: list[int],
                      purity: dict[int, float], *, try_whole: bool,
                      merged: bool = False) -> list[Mark]:
        """Marks of the given colours in the blob's full-resolution window (arc path). With
        ``try_whole``, each part of a colour's mask is first tried as a whole mark. ``merged``
        (one colour given): every palette-coloured pixel counts as that colour."""
        cfg = self.config
        win = self._window(frame, region, box, pad=4)
        labels = win.labels
        background = cv2.inRange(labels, _NO_COLOUR, _NO_COLOUR)
        if cv2.countNonZero(background) < 8:
            return []
        back_bgr = cv2.mean(win.bgr, mask=background)
        min_area = 0.4 * math.pi * cfg.min_radius ** 2
        marks: list[Mark] = []
        for k in colours:
            own = cv2.bitwise_not(background) if merged else cv2.inRange(labels, k, k)
            core = cv2.erode(own, self._kernel3)
            if cv2.countNonZero(core) < min_area:
                continue
            transform = self._alpha_transform(cv2.mean(win.bgr, mask=core), back_bgr)
            if transform is None:
                continue
            alpha = cv2.transform(win.bgr, transform)
            # Pixels of the other palette colours are not this mark; blob pixels of this colour
            # below the mid-level (a highlight) are.
            others = cv2.bitwise_xor(cv2.bitwise_not(background), own)
            alpha[others > 0] = 0
            binary = cv2.threshold(alpha, 127, 255, cv2.THRESH_BINARY)[1]
            cv2.bitwise_and(binary, win.blob, dst=binary)
            cv2.bitwise_or(binary, core, dst=binary)
            binary = cv2.morphologyEx(binary, cv2.MORPH_OPEN, self._kernel3)
            parts, _ = cv2.findContours(binary, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
            alpha_f = alpha.astype(np.float32) * (1.0 / 255.0)
            for part in parts:
                area = cv2.contourArea(part)
                if len(part) < 8 or area < min_area:
                    continue
                found = self._part_marks(frame, win, part, area, binary, alpha_f, k,
                                         purity.get(k, 1.0), others, try_whole)
                if merged:
                    found = [self._own_colour(m, win) for m in found]
                marks.extend(found)
        return marks

    def _own_colour(self, mark: Mark, win: _Window) -> Mark:
        """``mark`` named after the palette colour most of its own pixels have."""
        disc = _draw(win.labels.shape, _Ellipse(mark.x - win.x0, mark.y - win.y0, mark.axes[0],
                                                mark.axes[1], math.radians(mark.angle_deg)))
        hist = cv2.calcHist([win.labels], [0], disc, [len(self.palette)],
                            [0, len(self.palette)]).ravel()
        k = int(np.argmax(hist))
        if hist[k] <= 0 or self.palette[k].name == mark.colour:
            return mark
        return Mark(self.palette[k].name, mark.x, mark.y, mark.radius, mark.axes, mark.angle_deg,
                    mark.shape, mark.score * float(hist[k] / hist.sum()))

    def _part_marks(self, frame: _Frame, win: _Window, part: Contour, area: float,
                    binary: Mat, alpha: npt.NDArray[np.float32], colour: int,
                    purity: float, others: Mat, try_whole: bool) -> list[Mark]:
        """Marks in one connected part of a colour's α mask (window coordinates); ``others``
        marks the window's pixels of other palette colours."""
        cfg = self.config
        pts = part.reshape(-1, 2)
        gx = pts[:, 0] + win.x0
        gy = pts[:, 1] + win.y0
        on_border = (gx <= 0) | (gy <= 0) | (gx >= frame.width - 1) | (gy >= frame.height - 1)
        hull = cv2.convexHull(part)
        hull_area = cv2.contourArea(hull)
        if try_whole and not on_border.any() and hull_area > 0 and \
                area / hull_area >= cfg.min_solidity:
            coarse = self._whole_fit(part, tolerance_px=1.5)
            if coarse is not None:
                e = _Ellipse(coarse.cx + win.x0, coarse.cy + win.y0, coarse.a + 0.5,
                             coarse.b + 0.5, coarse.theta)
                exclude = (others, win.x0, win.y0) if cv2.countNonZero(others) else None
                mark = self._measure_whole(frame, e, colour, purity, exclude)
                if mark is not None:
                    return [mark]
        marks: list[Mark] = []
        r_est = math.sqrt(max(hull_area, 1.0) / math.pi)
        for cand in self._arc_candidates(pts.astype(np.float64), on_border, r_est):
            mark = self._refine_arc(frame, win, cand, binary, alpha, colour, purity, others)
            if mark is not None:
                marks.append(mark)
        return marks

    # ------------------------------------------------------------------ arcs

    def _arc_candidates(self, pts: FloatArray, on_border: npt.NDArray[np.bool_],
                        r_est: float, scale: float = 1.0) -> list[tuple[_Ellipse, FloatArray]]:
        """Coarse circles/ellipses, each with its contour points, from the convex arcs of a
        contour: points on the image border and in concave stretches (contour spans whose
        hull edge is long, or much shorter than the span) are dropped; the remaining runs are
        fitted and the runs of one circle merged."""
        n = len(pts)
        keep = ~on_border
        # A digital circle's flattest stretch (at its extremes) is ≈ 2√r long: longer hull
        # edges bridge something that is not the mark's outline.
        long_edge = max(6.0, 3.0 * math.sqrt(max(r_est, 1.0)) + 2.0)
        hull = np.sort(cv2.convexHull(pts.astype(np.int32).reshape(-1, 1, 2),
                                      returnPoints=False).ravel())
        if len(hull) >= 2:
            nxt = np.concatenate((hull[1:], hull[:1]))
            step = pts[nxt] - pts[hull]
            lengths = np.sqrt(np.einsum("ij,ij->i", step, step))
            spans = (nxt - hull) % n
            bad = (lengths > long_edge) | (spans > 1.4 * lengths + 3)
            for i, j in zip(hull[bad].tolist(), nxt[bad].tolist(), strict=True):
                if j > i:
                    keep[i + 1:j] = False
                else:
                    keep[i + 1:] = False
                    keep[:j] = False
        min_radius = self.config.min_partial_radius / scale
        min_run = max(6, int(0.1 * math.pi * min_radius))
        runs = sorted((r for r in _runs(keep) if len(r) >= min_run), key=len, reverse=True)
        candidates: list[tuple[_Ellipse, FloatArray]] = []
        if len(runs) >= 2:
            # All the convex stretches together: one mark cut or hidden in several places
            # (a tilted mark's arcs have different curvatures and do not merge as circles).
            every = pts[np.concatenate(runs)]
            whole = _fit_arc(every)
            if whole is not None and whole.major >= 0.8 * min_radius and \
                    float(np.mean(np.abs(whole.residuals(every)))) <= max(0.75, 0.02 * whole.major):
                candidates.append((whole, every))
        while runs:
            group = pts[runs.pop(0)]
            fit = _fit_arc(group)
            if fit is None:
                continue
            rest: list[npt.NDArray[np.intp]] = []
            for other in runs:
                other_pts = pts[other]
                tol = max(1.5, 0.06 * fit.major)
                if float(np.mean(np.abs(fit.residuals(other_pts)))) > tol:
                    rest.append(other)
                    continue
                merged = np.concatenate([group, other_pts])
                refit = _fit_arc(merged)
                limit = max(1.0, 0.04 * fit.major)
                if refit is None or float(np.mean(np.abs(refit.residuals(merged)))) > limit:
                    rest.append(other)
                    continue
                group, fit = merged, refit
            runs = rest
            # Trim outliers (a chord of an occluder, a joint with a neighbour) and refit.
            for _ in range(2):
                res = np.abs(fit.residuals(group))
                inl = res <= max(1.0, 2.5 * 1.25 * float(res.mean()))
                if inl.all() or inl.sum() < 6:
                    break
                group = group[inl]
                refit = _fit_arc(group)
                if refit is None:
                    break
                fit = refit
            if fit.major >= 0.8 * min_radius:
                candidates.append((fit, group))
        return candidates

    def _refine_arc(self, frame: _Frame, win: _Window, cand: tuple[_Ellipse, FloatArray],
                    binary: Mat, alpha: npt.NDArray[np.float32], colour: int,
                    purity: float, others: Mat) -> Mark | None:
        """Move the candidate's contour points to the α = 0.5 crossing along its normals,
        refit, and check support, fill and continuation (window coordinates inside)."""
        cfg = self.config
        fit, pts = cand
        if fit.major > 3.0 * max(binary.shape) or fit.minor < 0.8 * cfg.min_partial_radius:
            return None
        edge = _subpixel_edges(alpha, fit, pts)
        if len(edge) < 6:
            return None
        refit = _fit_arc(edge)
        if refit is None:
            return None
        res = refit.residuals(edge)
        tol = max(0.4, 0.03 * refit.major)
        inliers = np.abs(res) <= 2.5 * tol
        if int(inliers.sum()) < 6:
            return None
        if not inliers.all():
            again = _fit_arc(edge[inliers])
            if again is not None:
                refit = again
                res = refit.residuals(edge)
                inliers = np.abs(res) <= 2.5 * tol
        rms = _rms(res[inliers])
        if rms > tol:
            log.debug("arc at (%.1f, %.1f) r=%.1f: rms %.2f > %.2f", refit.cx + win.x0,
                      refit.cy + win.y0, refit.major, rms, tol)
            return None
        g = _Ellipse(refit.cx + win.x0, refit.cy + win.y0, refit.a, refit.b, refit.theta)
        support, arc, continued = self._outline_stats(frame, win, refit, edge[inliers], alpha)
        # Small arcs are cheap to come by in clutter: they need 0.1 more support.
        min_support = cfg.min_support + (0.1 if g.major < 2.5 * cfg.min_partial_radius else 0.0)
        if support < min_support or arc < cfg.min_arc or continued > cfg.max_continued:
            log.debug("arc at (%.1f, %.1f) r=%.1f: support %.2f arc %.2f continued %.2f",
                      g.cx, g.cy, g.major, support, arc, continued)
            return None
        fill = self._fill(frame, win, g, binary, others)
        if fill < cfg.min_fill:
            log.debug("arc at (%.1f, %.1f) r=%.1f: fill %.2f", g.cx, g.cy, g.major, fill)
            return None
        if g.major < cfg.min_partial_radius:
            return None
        quality = max(0.0, 1.0 - 0.5 * rms / tol)
        return self._mark(g, colour, purity * arc * quality)

    def _outline_stats(self, frame: _Frame, win: _Window, e: _Ellipse, edge: FloatArray,
                       alpha: npt.NDArray[np.float32]) -> tuple[float, float, float]:
        """(support, arc, continued): the shares of the outline inside the image that the edge
        points cover, of the whole outline they cover, and of the outline inside the window
        where the colour goes on outside it."""
        m = int(min(180, max(24, e.perimeter() / 3.0)))
        phi = np.arange(m) * (2.0 * math.pi / m)
        c, s = math.cos(e.theta), math.sin(e.theta)
        cp, sp = np.cos(phi), np.sin(phi)
        ox = e.a * cp * c - e.b * sp * s
        oy = e.a * cp * s + e.b * sp * c
        gx, gy = ox + e.cx + win.x0, oy + e.cy + win.y0
        inside = (gx >= -0.5) & (gx <= frame.width - 0.5) & (gy >= -0.5) & \
                 (gy <= frame.height - 0.5)
        visible = int(inside.sum())
        if visible == 0:
            return 0.0, 0.0, 1.0
        dx, dy = edge[:, 0] - e.cx, edge[:, 1] - e.cy
        u = (dx * c + dy * s) / e.a
        v = (-dx * s + dy * c) / e.b
        bins = (np.floor(np.arctan2(v, u) % (2.0 * math.pi) * (m / (2.0 * math.pi)))
                .astype(np.intp) % m)
        seen = np.zeros(m, bool)
        seen[bins] = True
        seen_visible = int((seen & inside).sum())
        # Colour beyond the outline: α sampled 2.5 px outside it, along the outward normal.
        gu, gv = cp / e.a, sp / e.b
        norm = np.hypot(gu, gv)
        nx, ny = (gu * c - gv * s) / norm, (gu * s + gv * c) / norm
        px = (e.cx + ox + 2.5 * nx).astype(np.float32)
        py = (e.cy + oy + 2.5 * ny).astype(np.float32)
        h, w = alpha.shape
        in_win = inside & (px >= 0) & (px <= w - 1) & (py >= 0) & (py <= h - 1)
        outside = cv2.remap(alpha, px.reshape(1, -1), py.reshape(1, -1), cv2.INTER_LINEAR,
                            borderMode=cv2.BORDER_CONSTANT, borderValue=0.0).ravel()
        n_win = int(in_win.sum())
        continued = float(np.count_nonzero((outside >= 0.5) & in_win & ~seen)) / max(n_win, 1)
        return seen_visible / visible, float(seen.sum()) / m, continued

    def _fill(self, frame: _Frame, win: _Window, e: _Ellipse, binary: Mat,
              others: Mat) -> float:
        """Share of the ellipse's area inside the image that the colour's mask covers, not
        counting pixels of other palette colours (a mark in front hides part of it)."""
        x0 = max(0, math.floor(e.cx - e.major) - 1)
        y0 = max(0, math.floor(e.cy - e.major) - 1)
        x1 = min(frame.width, math.ceil(e.cx + e.major) + 2)
        y1 = min(frame.height, math.ceil(e.cy + e.major) + 2)
        if x1 <= x0 or y1 <= y0:
            return 0.0
        disc = _draw((y1 - y0, x1 - x0), _Ellipse(e.cx - x0, e.cy - y0, e.a, e.b, e.theta))
        hidden = _paste((others, win.x0, win.y0), x0, y0, disc.shape)
        cv2.subtract(disc, hidden, dst=disc)
        inside = cv2.countNonZero(disc)
        if inside == 0:
            return 0.0
        covered = cv2.bitwise_and(disc, _paste((binary, win.x0, win.y0), x0, y0, disc.shape))
        return cv2.countNonZero(covered) / inside

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


def _longest_edge(polygon: Contour) -> float:
    """Length of the longest side of a closed polygon (e.g. a simplified convex hull)."""
    pts = polygon.reshape(-1, 2).tolist()
    px, py = pts[-1]
    longest = 0
    for x, y in pts:
        longest = max(longest, (x - px) * (x - px) + (y - py) * (y - py))
        px, py = x, y
    return math.sqrt(longest)


def _flat_stretch(e: _Ellipse) -> float:
    """Longest edge expected on the convex hull of the digitised outline of ``e``, simplified
    to 0.75 px: its flattest part (curvature radius major²/minor) stays that close to a chord
    ≈ 2.5·√radius long."""
    return 3.0 * math.sqrt(e.major * e.major / e.minor) + 2.0


def _diagonal(gains: tuple[float, float, float]) -> npt.NDArray[np.float32]:
    out = np.zeros((3, 3), np.float32)
    out[0, 0], out[1, 1], out[2, 2] = gains
    return out


def _paste(mask: tuple[Mat, int, int], x0: int, y0: int, shape: tuple[int, int]) -> Mat:
    """The part of ``mask`` (placed at its origin in the image) inside the window of ``shape``
    at (x0, y0); zero elsewhere."""
    src, sx0, sy0 = mask
    out = np.zeros(shape, np.uint8)
    ax0, ay0 = max(x0, sx0), max(y0, sy0)
    ax1 = min(x0 + shape[1], sx0 + src.shape[1])
    ay1 = min(y0 + shape[0], sy0 + src.shape[0])
    if ax1 > ax0 and ay1 > ay0:
        out[ay0 - y0:ay1 - y0, ax0 - x0:ax1 - x0] = src[ay0 - sy0:ay1 - sy0, ax0 - sx0:ax1 - sx0]
    return out


def _draw(shape: tuple[int, int], e: _Ellipse) -> Mat:
    """A filled ellipse (255) on a zero mask, with 1/16 px precision."""
    out = np.zeros(shape, np.uint8)
    shift = 4
    one = 1 << shift
    cv2.ellipse(out, (round(e.cx * one), round(e.cy * one)), (round(e.a * one), round(e.b * one)),
                math.degrees(e.theta), 0, 360, 255, cv2.FILLED, cv2.LINE_8, shift)
    return out


def _moments_ellipse(mom: dict[str, float]) -> _Ellipse | None:
    """The ellipse with a region's area, centroid and second-moment shape (``cv2.moments`` of a
    binary image or of a contour polygon).

    For a uniform ellipse the covariance eigenvalues are a²/4 and b²/4; the axes are then scaled
    so that πab equals the area (for a binary image: the count of pixel centres inside the edge,
    an unbiased area).
    """
    m00 = mom["m00"]
    if m00 < 6:
        return None
    cx, cy = mom["m10"] / m00, mom["m01"] / m00
    mu20, mu02, mu11 = mom["mu20"] / m00, mom["mu02"] / m00, mom["mu11"] / m00
    half = 0.5 * (mu20 + mu02)
    diff = math.hypot(0.5 * (mu20 - mu02), mu11)
    l1, l2 = half + diff, half - diff
    if l2 <= 0:
        return None
    ratio = math.sqrt(l2 / l1)
    theta = 0.5 * math.atan2(2.0 * mu11, mu20 - mu02)
    a = math.sqrt(m00 / (math.pi * ratio))
    return _Ellipse(cx, cy, a, a * ratio, theta)


def _subpixel_edges(alpha: npt.NDArray[np.float32], fit: _Ellipse,
                    pts: FloatArray) -> FloatArray:
    """Contour points moved along the fit's normals to where α crosses 0.5 (bilinear samples,
    linear interpolation between the two samples that bracket it); points whose profile does not
    go from mark (α > 0.5) to background are dropped."""
    dx, dy = pts[:, 0] - fit.cx, pts[:, 1] - fit.cy
    c, s = math.cos(fit.theta), math.sin(fit.theta)
    u = dx * c + dy * s
    v = -dx * s + dy * c
    gu, gv = u / (fit.a * fit.a), v / (fit.b * fit.b)  # gradient of the ellipse equation
    norm = np.hypot(gu, gv)
    norm[norm == 0] = 1.0
    nx = (gu * c - gv * s) / norm
    ny = (gu * s + gv * c) / norm
    xs = (pts[:, 0:1] + nx[:, None] * _RAY_T[None, :]).astype(np.float32)
    ys = (pts[:, 1:2] + ny[:, None] * _RAY_T[None, :]).astype(np.float32)
    prof = cv2.remap(alpha, xs, ys, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    above = prof >= 0.5
    # The first sample below 0.5 after the inner end must follow one above it.
    crossing = above[:, :-1] & ~above[:, 1:]
    has = crossing.any(axis=1) & above[:, 0] & ~above[:, -1]
    if not has.any():
        return np.zeros((0, 2), np.float64)
    j = np.argmax(crossing, axis=1)
    rows = np.arange(len(pts))
    p0, p1 = prof[rows, j].astype(np.float64), prof[rows, j + 1].astype(np.float64)
    denom = p0 - p1
    denom[denom <= 1e-6] = 1e-6
    t = _RAY_T[j] + (p0 - 0.5) / denom * (_RAY_T[j + 1] - _RAY_T[j])
    out: FloatArray = np.column_stack([pts[:, 0] + nx * t, pts[:, 1] + ny * t])[has]
    return out


def _fit_arc(pts: FloatArray, iterations: int = 0) -> _Ellipse | None:
    """Model of one or more arcs: a circle, or an ellipse when that fits clearly better and the
    points go round enough of it to pin it down."""
    circle = _fit_circle(pts, iterations)
    if circle is None:
        return None
    if len(pts) < 12:
        return circle
    ang = np.sort(np.arctan2(pts[:, 1] - circle.cy, pts[:, 0] - circle.cx))
    gaps = np.diff(np.concatenate([ang, ang[:1] + 2 * math.pi]))
    span = 2 * math.pi - float(gaps.max())
    if span < math.radians(200):
        return circle
    ell = _fit_ellipse(pts)
    if ell is None or ell.minor / ell.major < 0.3 or ell.major > 1.5 * circle.major:
        return circle
    if _rms(ell.residuals(pts)) < 0.7 * _rms(circle.residuals(pts)):
        return ell
    return circle


def _centre_in(a: Mark, b: Mark) -> bool:
    """Whether ``a``'s centre lies inside ``b``'s ellipse."""
    t = math.radians(b.angle_deg)
    dx, dy = a.x - b.x, a.y - b.y
    u = (dx * math.cos(t) + dy * math.sin(t)) / max(b.axes[0], 1e-9)
    v = (-dx * math.sin(t) + dy * math.cos(t)) / max(b.axes[1], 1e-9)
    return u * u + v * v < 1.0


def _suppress_duplicates(marks: list[Mark]) -> list[Mark]:
    """Drop a mark whose centre lies inside a better-scoring mark of similar size, and a mark
    that holds the centres of two smaller marks (an outline fitted across touching marks).
    Of two marks one of whose centres lies inside the other, only the better-scoring one
    stands: a visible mark's centre cannot be behind another mark's face, so one of the two is
    an outline fitted across a mark and something touching it (clutter of the same colour)."""
    def inside(small: Mark, big: Mark) -> bool:
        return small.radius < 0.8 * big.radius and \
            math.hypot(small.x - big.x, small.y - big.y) < big.radius
    marks = [m for m in marks if sum(inside(o, m) for o in marks if o is not m) < 2]
    kept: list[Mark] = []
    for mark in sorted(marks, key=lambda m: -m.score):
        duplicate = any(
            (math.hypot(mark.x - k.x, mark.y - k.y) < 0.5 * min(mark.radius, k.radius)
             and 0.6 <= mark.radius / k.radius <= 1.67)
            or _centre_in(mark, k) or _centre_in(k, mark)
            for k in kept
        )
        if not duplicate:
            kept.append(mark)
    return kept


def detect_marks(image: U8Array, palette: Palette = DEFAULT_PALETTE) -> list[Mark]:
    """Convenience: the marks in one BGR image with a fresh :class:`Detector`."""
    return Detector(palette).detect(image)
