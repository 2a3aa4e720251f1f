"""Stage 4, shape: each blob measured as an ellipse, kept if it is a painted disc.

**Screen** (search image, per blob): the ellipse ``fitEllipse`` gives the contour must be
filled by the blob (area / πab ≥ ``min_fill``: a disc fills its ellipse, a triangle, a bar's
end or a pair of touching things do not), its outline must follow the ellipse
(``max_outline_share``) and it must be no flatter than ``min_axis_ratio`` (a disc seen θ off
its face has axis ratio cos θ).

**Measure** (full resolution, a window of the frame's own pixels around the blob: the correction's
gain could clip a channel, and clipping is not linear): a blurred rim mixes the paint's colour P
(median inside the blob) and its surroundings' B (median of the window outside it) linearly, so each
pixel's coverage α is its colour's projection on P − B, from 0 at B to 1 at P. The pixels of α ≥ 0.5
within the blob grown by a few pixels are the mark: across a symmetric blur the count of pixels past
the mid-level is an unbiased area, and their image moments give centre and axes (a filled ellipse of
semi-axes a, b has second moments a²/4, b²/4), so the radius is not biased by blur or by where a
contour runs through the rim's pixels: the range (∝ 1/h) depends on it.

**Vetoes** (those that pay on the tuning half; judged in corrected levels, the gains of
:mod:`.photometry` applied): a mark whose chroma (colour less its grey) differs from its
surroundings' by less than ``min_contrast`` (out-of-focus clutter of a palette hue is round but
faint), or whose inside is textured beyond ``max_texture`` (paint is flat; foliage, fabric and skin
are not).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace

import cv2
import numpy as np

from marknav.vision.detect.model import Mark
from marknav.vision.detect.scene import SEARCH_SCALE, Blob, Ellipse, Mat, Scene

__all__ = ["ShapeConfig", "coverage_ellipse", "measure", "screen"]

log = logging.getLogger("marknav.vision.detect")

#: ``circle`` when minor/major is at least this (a disc turned under 25° reads as round).
CIRCLE_RATIO = 0.9
#: Full-resolution px the measuring domain reaches beyond the blob (a blurred rim's width at
#: the project's cameras: blur σ up to 1.2 px, ±2σ) and where the ring behind it ends.
_DOMAIN_PX = 3
_RING_PX = 8
#: Pixels (full resolution) of a rim at least this far inside the domain count as the mark's.
_CORE_PX = 2
_DOMAIN_KERNEL = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * _DOMAIN_PX + 1,) * 2)
_CORE_KERNEL = np.ones((2 * _CORE_PX + 1,) * 2, np.uint8)
#: Half a search pixel (px): how far an outline through pixel centres lies from the true one.
_QUANTUM_PX = 0.5
#: Share of a mark's outline that must lie inside the frame (and of its blob's outline off the
#: frame's edge) for a mark cut by the frame's edge: less is a sliver, which the rounded end
#: of a bar or a corner of a board matches as well.
_MIN_SEEN = 0.3
#: A mark cut by the frame's edge is at least this many times the smallest radius: a smaller
#: arc cannot be told from the rounded end of a bar or a leaf.
_PARTIAL_RADIUS = 1.6
#: Largest share of its smallest bounding rectangle a blob may fill: an ellipse fills π/4 ≈
#: 0.785 of it, a disc of a few pixels' radius digitised up to 0.88; a rectangle all of it.
_MAX_EXTENT = 0.9
#: Points along an ellipse sampled for the share of it inside the frame.
_OUTLINE_SAMPLES = 64
#: A blob's longer side spans at least this share of a smallest mark's diameter (the major
#: axis of an ellipse turned in the image spans its bounding box's diagonal at most √2 of
#: the longer side, less a pixel of rounding).
_MIN_EXTENT = 0.6
#: The narrowest window (px) a mark is measured in.
_MIN_WINDOW_PX = 3
#: The most pixels a median of paint or surroundings is read from.
_MEDIAN_PIXELS = 1024
#: The fewest pixels the mark's and the ring's chroma are taken from.
_MIN_PIXELS = 4


@dataclass(frozen=True)
class ShapeConfig:
    """What is a painted disc (see the module docstring)."""

    #: The smallest semi-major axis (px, full resolution) a mark is measured at: 5 px is the
    #: robot's smallest useful mark (its range is 10-16 % off below it);
    #: :meth:`~marknav.vision.detect.pipeline.DetectorConfig.for_camera` sets it from the
    #: course's farthest mark.
    min_radius_px: float = 5.0
    #: Share of its fitted ellipse a blob must fill: a disc quantised to the search image's
    #: pixels fills 0.93-1.0 of it; a bar's rounded end, a triangle or two touching things
    #: under 0.9.
    min_fill: float = 0.9
    #: Smallest minor/major ratio: courses turn their marks up to 60° and the robot sees them
    #: from up to about 12° beside the course, so views reach 72°: cos 72° ≈ 0.3.
    min_axis_ratio: float = 0.3
    #: Largest mean distance of the blob's outline from its ellipse, as a share of the radius
    #: (plus half a search pixel for the outline's quantisation): a disc's outline follows
    #: its ellipse to 1-2 %, one with a fifth of it hidden to about 2 %.
    max_outline_share: float = 0.02
    #: Smallest chroma step (colour less its grey; BGR levels after photometry) from the
    #: mark's paint to its surroundings: paint against a grey or other-coloured surface steps
    #: by 90+, out-of-focus clutter and a patch of a coloured surface by under 40.
    min_contrast: float = 50.0
    #: Largest texture inside the mark: the median absolute deviation from its median colour
    #: (summed over B, G, R) as a share of that colour's chroma (its distance from grey, summed
    #: over B, G, R), so neither the exposure nor the gain changes it. Paint is flat, foliage,
    #: fabric and skin vary by as much as their colour. On the tuning half recall holds from
    #: 0.1 to 0.3 and falls below 0.07 (marks' shading and noise); 0.2 is the middle of that
    #: plateau (a glossy sweet's highlights measure 0.17).
    max_texture: float = 0.2
    #: Most blobs one frame's marks are measured from, the largest first: a crowded view (a
    #: poster of coloured squares, a rug) passes hundreds through the screen at about 0.1 ms
    #: each; the rest are left unmeasured. The project's frames pass at most 120.
    max_blobs: int = 400

    def __post_init__(self) -> None:
        if not self.min_radius_px > 0:
            raise ValueError(f"min_radius_px must be > 0, got {self.min_radius_px}")
        for name in ("min_fill", "min_axis_ratio"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {getattr(self, name)}")
        for name in ("max_outline_share", "min_contrast", "max_texture"):
            if not getattr(self, name) >= 0.0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        if self.max_blobs < 1:
            raise ValueError(f"max_blobs must be >= 1, got {self.max_blobs}")


def screen(blob: Blob, config: ShapeConfig) -> Ellipse | None:
    """The blob's fitted ellipse ``((x, y), (a, b), angle_deg)`` (search image, semi-axes) if
    it passes the screen (size, axis ratio, fill, outline), else ``None``."""
    r_min = config.min_radius_px / SEARCH_SCALE
    if blob.area < config.min_fill * config.min_axis_ratio * math.pi * r_min * r_min:
        return None
    if len(blob.contour) < _MIN_PIXELS + 1 or \
            max(cv2.boundingRect(blob.contour)[2:]) < 2.0 * r_min * _MIN_EXTENT:
        return None
    outline = blob.contour.reshape(-1, 2)
    if blob.frame is not None:  # cut by the frame: its own outline is what lies inside it
        outline = _inside(outline, blob.frame)
        if len(outline) < max(_MIN_PIXELS + 1, _MIN_SEEN * len(blob.contour)):
            return None
    (x, y), (w, h), angle = cv2.fitEllipse(outline.astype(np.float32))
    a, b = 0.5 * max(w, h), 0.5 * min(w, h)
    # The outline runs through the rim's pixel centres, half a pixel inside the paint's edge.
    if b <= 0 or b < config.min_axis_ratio * a or \
            SEARCH_SCALE * (a + _QUANTUM_PX) < config.min_radius_px:
        return None
    if blob.frame is None:
        if blob.area < config.min_fill * math.pi * a * b:
            return None
        (_, _), (rw, rh), _ = cv2.minAreaRect(blob.contour)
        if blob.area > _MAX_EXTENT * (rw + 1.0) * (rh + 1.0):
            return None  # a rectangle: an ellipse fills π/4 of its bounding box
    elif SEARCH_SCALE * a < _PARTIAL_RADIUS * config.min_radius_px or \
            not _fills_visible_part(blob, ((x, y), (w, h), angle), config):
        return None
    t = math.radians(angle)
    d = outline - (x, y)
    u = (d[:, 0] * math.cos(t) + d[:, 1] * math.sin(t)) / (0.5 * w)
    v = (d[:, 1] * math.cos(t) - d[:, 0] * math.sin(t)) / (0.5 * h)
    off = float(np.mean(np.abs(np.sqrt(u * u + v * v) - 1.0))) * math.sqrt(a * b)
    if off > _QUANTUM_PX + config.max_outline_share * a:
        return None
    return (x, y), (a, b), angle


def _inside(points: Mat, frame: tuple[int, int]) -> Mat:
    """The points not on the edge of a ``frame`` (width, height) image."""
    w, h = frame
    keep = (points[:, 0] > 0) & (points[:, 1] > 0) & (points[:, 0] < w - 1) & \
        (points[:, 1] < h - 1)
    out: Mat = points[keep]
    return out


def _seen_share(rect: Ellipse, frame: tuple[int, int]) -> float:
    """The share of the ellipse ``rect`` (OpenCV's rotated rectangle) whose outline lies in a
    ``frame`` (width, height) image."""
    (x, y), (w, h), angle = rect
    t = np.linspace(0.0, 2.0 * math.pi, _OUTLINE_SAMPLES, endpoint=False)
    c, s = math.cos(math.radians(angle)), math.sin(math.radians(angle))
    u, v = 0.5 * w * np.cos(t), 0.5 * h * np.sin(t)
    px, py = x + u * c - v * s, y + u * s + v * c
    inside = (px >= 0) & (py >= 0) & (px <= frame[0] - 1) & (py <= frame[1] - 1)
    return float(inside.mean())


def _fills_visible_part(blob: Blob, rect: Ellipse, config: ShapeConfig) -> bool:
    """Whether a blob cut by the frame's edge fills the part of its ellipse inside the frame,
    and enough of the ellipse's outline is inside it to be a mark's (:data:`_MIN_SEEN`)."""
    assert blob.frame is not None
    if _seen_share(rect, blob.frame) < _MIN_SEEN:
        return False
    w, h = blob.frame
    ellipse = np.zeros((h, w), np.uint8)
    cv2.ellipse(ellipse, rect, 1, -1)
    own = np.zeros((h, w), np.uint8)
    cv2.drawContours(own, [blob.contour], -1, 1, -1)
    visible = cv2.countNonZero(ellipse)
    return visible > 0 and cv2.countNonZero(own & ellipse) >= config.min_fill * visible


def coverage_ellipse(alpha: Mat) -> tuple[float, float, float, float, float] | None:
    """``(x, y, a, b, angle_deg)`` of the filled ellipse with ``alpha``'s moments (window px,
    pixel centres at integers; ``angle_deg`` the major axis's, from +x towards +y)."""
    m = cv2.moments(alpha.astype(np.float32))
    if m["m00"] <= 0:
        return None
    x, y = m["m10"] / m["m00"], m["m01"] / m["m00"]
    mu20, mu02, mu11 = m["mu20"] / m["m00"], m["mu02"] / m["m00"], m["mu11"] / m["m00"]
    spread = math.hypot(mu20 - mu02, 2.0 * mu11)
    l1, l2 = 0.5 * (mu20 + mu02 + spread), 0.5 * (mu20 + mu02 - spread)
    if l2 <= 0:
        return None
    angle = math.degrees(0.5 * math.atan2(2.0 * mu11, mu20 - mu02)) % 180.0
    return x, y, 2.0 * math.sqrt(l1), 2.0 * math.sqrt(l2), angle


def _window(scene: Scene, blob: Blob) -> tuple[int, int, Mat, Mat] | None:
    """The blob's full-resolution window: origin, the frame's BGR, and the blob's mask in it."""
    h, w = scene.image.shape[:2]
    bx, by, bw, bh = cv2.boundingRect(blob.contour)
    pad = _RING_PX + SEARCH_SCALE * (1 + blob.cut_px)
    x0, y0 = max(0, bx * SEARCH_SCALE - pad), max(0, by * SEARCH_SCALE - pad)
    x1 = min(w, (bx + bw) * SEARCH_SCALE + pad)
    y1 = min(h, (by + bh) * SEARCH_SCALE + pad)
    if x1 - x0 < _MIN_WINDOW_PX or y1 - y0 < _MIN_WINDOW_PX:
        return None
    roi = np.ascontiguousarray(scene.image[y0:y1, x0:x1])
    inside = np.zeros((y1 - y0, x1 - x0), np.uint8)
    # The contour's pixel centres, scaled: search pixel i covers full pixels 2i, 2i+1.
    full = blob.contour.astype(np.float32) * SEARCH_SCALE + (0.5 * (SEARCH_SCALE - 1))
    cv2.drawContours(inside, [np.round(full - (x0, y0)).astype(np.int32)], -1, 255, -1)
    return x0, y0, roi, inside


def _thinned(pixels: Mat) -> Mat:
    """At most :data:`_MEDIAN_PIXELS` of ``pixels``, evenly taken (a median of a large mark's
    thousands of pixels moves by under a level when read from a thousand of them)."""
    step = max(1, len(pixels) // _MEDIAN_PIXELS)
    out: Mat = pixels[::step]
    return out


def _alpha(roi: Mat, inside: Mat, gains: Mat, config: ShapeConfig,
           grow_px: int = 0) -> Mat | None:
    """The mark's coverage in its window (see the module docstring), or ``None`` when its
    chroma does not stand out from its ring's by ``min_contrast``."""
    kernel = _DOMAIN_KERNEL if grow_px == 0 else cv2.getStructuringElement(
        cv2.MORPH_ELLIPSE, (2 * (_DOMAIN_PX + grow_px) + 1,) * 2)
    domain = cv2.dilate(inside, kernel) > 0
    ring = ~domain  # the rest of the window: up to _RING_PX beyond the blob's box
    core = cv2.erode(inside, _CORE_KERNEL) > 0
    if cv2.countNonZero(core.view(np.uint8)) < _MIN_PIXELS:
        core = inside > 0
    pixels = roi.reshape(-1, 3)
    own = _thinned(pixels[core.ravel()])
    paint = np.median(own, axis=0)
    chroma = float(np.abs(paint - paint.mean()).sum()) + 1.0
    if float(np.median(np.abs(own - paint).sum(axis=1))) > config.max_texture * chroma:
        return None
    behind = _thinned(pixels[ring.ravel()])
    back = np.median(behind, axis=0) if len(behind) >= _MIN_PIXELS else np.zeros(3)
    step = paint - back
    seen = step * gains
    # A piece cut from a surface of its hue has shown its edge against it: no faint blob.
    floor = 1.0 if grow_px else config.min_contrast
    if np.linalg.norm(seen - seen.mean()) < max(floor, 1.0):
        return None  # judged in corrected levels, grey (shading) removed
    step -= step.mean()
    if float(step @ step) < 1.0:
        return None  # paint and surroundings of one chroma: nothing to measure by
    along = (step / float(step @ step)).reshape(1, 3)  # sums to 0: blind to grey
    along = along.astype(np.float32)
    projected = cv2.transform(roi.astype(np.float32), along).reshape(roi.shape[:2])
    out: Mat = ((projected >= float(back @ along.ravel()) + 0.5) & domain).astype(np.float32)
    return out


def _boxy(alpha: Mat) -> bool:
    """Whether the measured paint (full resolution) fills more of its smallest bounding
    rectangle than an ellipse can (:data:`_MAX_EXTENT`): a bar, a square, a board's patch."""
    paint = (alpha > 0).astype(np.uint8)
    points = cv2.findNonZero(paint)
    if points is None:
        return True
    (_, _), (rw, rh), _ = cv2.minAreaRect(points)
    return cv2.countNonZero(paint) > _MAX_EXTENT * (rw + 1.0) * (rh + 1.0)


def _edge_mark(scene: Scene, blob: Blob, alpha: Mat, origin: tuple[int, int],
               config: ShapeConfig) -> Mark | None:
    """A mark cut by the frame's edge: the ellipse fitted to its paint's outline inside the
    frame (full resolution; the outline runs through the rim's pixel centres, half a pixel
    inside the paint's edge)."""
    paint = (alpha > 0).astype(np.uint8)
    contours = cv2.findContours(paint, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)[0]
    if not contours:
        return None
    h, w = scene.image.shape[:2]
    points = max(contours, key=cv2.contourArea).reshape(-1, 2) + origin
    outline = _inside(points, (w, h))
    if len(outline) < _MIN_PIXELS + 1:
        return None
    (x, y), (dw, dh), angle = cv2.fitEllipse(outline.astype(np.float32))
    rect: Ellipse = ((x, y), (dw, dh), angle)
    a, b = 0.5 * max(dw, dh) + _QUANTUM_PX, 0.5 * min(dw, dh) + _QUANTUM_PX
    if b < config.min_axis_ratio * a or a < _PARTIAL_RADIUS * config.min_radius_px:
        return None
    major = angle if dw >= dh else angle + 90.0
    seen = _seen_share(rect, (w, h))
    return Mark(colour=scene.palette[blob.colour].name, x=x, y=y, radius=a, axes=(a, b),
                angle_deg=major % 180.0, shape="circle" if b >= CIRCLE_RATIO * a else "ellipse",
                score=round(seen * min(1.0, b / a + 0.5), 4))


def _measure_blob(scene: Scene, blob: Blob, config: ShapeConfig) -> Mark | None:
    fit = blob.ellipse
    if fit is None:
        return None
    window = _window(scene, blob)
    if window is None:
        return None
    x0, y0, roi, inside = window
    assert scene.gains is not None
    alpha = _alpha(roi, inside, scene.gains, config, SEARCH_SCALE * blob.cut_px)
    if alpha is None:
        return None
    if blob.frame is not None:
        return _edge_mark(scene, blob, alpha, (x0, y0), config)
    if blob.bridged:  # the paint's hull: the occluder's strip is the mark's too
        paint = cv2.findNonZero((alpha > 0).astype(np.uint8))
        if paint is None:
            return None
        alpha = np.zeros_like(alpha)
        cv2.fillConvexPoly(alpha, cv2.convexHull(paint), 1.0)
    elif _boxy(alpha):  # a bar's corners are square in the frame's own pixels at any size
        return None
    ellipse = coverage_ellipse(alpha)
    if ellipse is None:
        return None
    x, y, a, b, angle = ellipse
    (_, _), (sa, sb), _ = fit
    if b < config.min_axis_ratio * a or a < config.min_radius_px:
        return None
    fill = min(1.0, blob.area / (math.pi * sa * sb))
    return Mark(colour=scene.palette[blob.colour].name, x=x + x0, y=y + y0, radius=a,
                axes=(a, b), angle_deg=angle,
                shape="circle" if b >= CIRCLE_RATIO * a else "ellipse",
                score=round(fill * min(1.0, b / a + 0.5), 4))


def measure(scene: Scene, config: ShapeConfig) -> Scene:
    """The scene with the marks its blobs measure as (needs :mod:`.segment`, which screens
    them: :func:`screen`)."""
    screened = sorted((b for b in scene.blobs if b.ellipse is not None), key=lambda b: -b.area)
    if len(screened) > config.max_blobs:
        log.warning("%d blobs look like marks; the largest %d measured", len(screened),
                    config.max_blobs)
    found = (_measure_blob(scene, b, config) for b in screened[:config.max_blobs])
    return replace(scene, marks=tuple(m for m in found if m is not None))
