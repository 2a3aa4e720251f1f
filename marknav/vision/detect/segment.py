"""Stage 3, segmentation: each colour's mask cut into blobs, one per object.

The mask is opened (a square of :data:`OPEN_PX`: single pixels of noise and one-pixel bridges go).
A mark standing against a surface of its own hue — a carpet under it, a board or a ball behind
it — joins it in the mask, but not in the frame: the paint's edge against the other surface
is a step in brightness or in colour, which the frame's own edges show: Canny on each of the
corrected B, G and R (a blue disc before a violet board differs little in grey, much in red).
So a blob that is not a mark's shape is cut along those edges (thickened by a pixel to close
the gaps Canny leaves), and each piece that is a mark's shape is a blob of its own; a textured
surface falls into crumbs no mark is made of. The pieces have lost up to :data:`CUT_PX`
pixels to the cut; they are measured at full resolution in a domain grown by as much, so their
radius is the paint's, not the piece's. Two pieces of a colour that are no mark alone but whose
convex hull they fill but for a thin strip (a pole, a wire in front of a mark) are joined into
one blob, measured as the hull of their paint. A mark on a background of another colour has no such
seam: the cut only ever runs inside a colour's mask.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import cv2
import numpy as np

from marknav.vision.detect.model import MIN_RADIUS_FLOOR_PX
from marknav.vision.detect.scene import SEARCH_SCALE, Blob, Ellipse, Mat, Scene

__all__ = ["SegmentConfig", "cut_along_edges", "segment"]

#: Pixels (search image) a piece loses at most to the cut: Canny's one-pixel edges are
#: thickened by a pixel to close the gaps it leaves (:mod:`.shape` measures the piece in a
#: domain grown by as much).
CUT_PX = 2
#: Fewest contour points an ellipse is fitted to.
_MIN_POINTS = 5
#: How far (search px) a whole mark's fitted outline may reach past the centres of the frame's
#: edge pixels: the outline runs half a pixel inside the paint's edge, so a mark whose paint
#: just reaches the frame's last pixels fits to about there; one cut deeper is a partial mark.
_EDGE_SLACK_PX = 1.0
#: Most pieces of one colour that are no mark alone looked at for joining in pairs: more are
#: a textured surface's crumbs, and pairs of them cost their square.
_MAX_LOOSE = 40
#: Each piece is at least this share of the joined hull (a half or a third of a mark, not a
#: crumb beside one), and the strip between them at most this share.
_MIN_PART = 0.15
_MAX_STRIP = 0.25
#: A whole mark's ellipse, or ``None``: :func:`marknav.vision.detect.shape.screen`.
Screen = Callable[[Blob], Ellipse | None]
_CROSS = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))


@dataclass(frozen=True)
class SegmentConfig:
    """How masks become blobs (see the module docstring)."""

    #: Step in one channel (levels after :mod:`.photometry`) that is an edge between two
    #: surfaces: a paint's edge against a surface of its hue steps by 30+ levels, a surface's
    #: own texture and shading by under 20 (Canny's high threshold; the low one is half).
    #: 0: no cut.
    edge_step: float = 60.0
    #: Widest thin occluder (search-image px; twice that at full resolution) two pieces of a
    #: mark are joined across: a pole or a wire in front of a mark a metre or two away is
    #: 4-8 px wide at 640 px. 0: never joined.
    bridge_px: int = 4

    def __post_init__(self) -> None:
        if not self.edge_step >= 0.0:
            raise ValueError(f"edge_step must be >= 0, got {self.edge_step}")
        if self.bridge_px < 0:
            raise ValueError(f"bridge_px must be >= 0, got {self.bridge_px}")


#: Side (search-image px) of the opening: 3 removes the single pixels JPEG and sensor noise
#: classify as a colour.
OPEN_PX = 3
#: The smallest blob (search-image px): a disc of the smallest radius the stages measure
#: (2.5 px full resolution, :data:`~marknav.vision.detect.model.MIN_RADIUS_FLOOR_PX`) seen at
#: the steepest view an axis ratio allows (0.3).
MIN_AREA_PX = max(4.0, 0.3 * math.pi * (MIN_RADIUS_FLOOR_PX / SEARCH_SCALE) ** 2)
#: The smallest blob worth cutting or joining: two of the smallest blobs.
_MIN_CUT_AREA_PX = 2 * MIN_AREA_PX


def cut_along_edges(mask: Mat, edges: Mat) -> Mat:
    """``mask`` (0/255) less ``edges`` thickened by :data:`CUT_PX` (see the module
    docstring)."""
    out: Mat = cv2.bitwise_and(mask, cv2.bitwise_not(cv2.dilate(edges, _CROSS)))
    return out


def edges_of(bgr: Mat, config: SegmentConfig) -> Mat:
    """The edges (0/255) of a BGR image: Canny at ``edge_step`` and half of it on each
    channel, joined."""
    b, g, r = cv2.split(bgr)
    low, high = 0.5 * config.edge_step, config.edge_step
    out: Mat = cv2.bitwise_or(cv2.bitwise_or(cv2.Canny(b, low, high), cv2.Canny(g, low, high)),
                              cv2.Canny(r, low, high))
    return out


def _pieces(contour: Mat, mask: Mat, bgr: Mat | None, config: SegmentConfig,
            whole: Screen, colour: int) -> list[Blob]:
    """The blob of ``contour`` (with its ellipse when ``whole`` gives one), or, when it is not a
    whole mark's shape, the pieces the frame's edges cut it into (within its bounding box)."""
    area = cv2.contourArea(contour)
    frame = _frame_if_cut(contour, mask)
    fit = whole(Blob(colour, contour, area))
    if fit is not None and frame is not None:
        if _within(fit, frame):
            frame = None  # a whole mark whose rim just reaches the edge's pixels
        else:
            fit = None
    if fit is not None or bgr is None or area < _MIN_CUT_AREA_PX:
        return [Blob(colour, contour, area, fit) if fit is not None or frame is None
                else _partial(colour, contour, area, frame, whole)]
    x, y, w, h = cv2.boundingRect(contour)
    own = np.zeros((h, w), np.uint8)
    cv2.drawContours(own, [contour - (x, y)], -1, 255, -1)
    own &= mask[y:y + h, x:x + w]
    # The blob's own edges only (Canny's gradient needs a pixel beyond the box).
    y0, x0 = max(0, y - 1), max(0, x - 1)
    edges = edges_of(bgr[y0:y + h + 1, x0:x + w + 1], config)
    cut = cut_along_edges(own, edges[y - y0:y - y0 + h, x - x0:x - x0 + w])
    out = []
    for part in cv2.findContours(cut, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)[0]:
        piece_area = cv2.contourArea(part)
        if piece_area >= MIN_AREA_PX and len(part) >= _MIN_POINTS:
            shifted = np.add(part, (x, y))
            frame = _frame_if_cut(shifted, mask)
            fit = whole(Blob(colour, shifted, piece_area, cut_px=CUT_PX, frame=frame))
            if fit is not None:
                out.append(Blob(colour, shifted, piece_area, fit, CUT_PX, frame=frame))
    if out or frame is None:
        return out or [Blob(colour, contour, area)]
    return [_partial(colour, contour, area, frame, whole)]


def _partial(colour: int, contour: Mat, area: float, frame: tuple[int, int],
             whole: Screen) -> Blob:
    """A blob cut by the frame's edge, read as part of a mark (tried after its pieces: a
    surface of the mark's hue reaching the edge is cut from the mark first)."""
    return Blob(colour, contour, area, whole(Blob(colour, contour, area, frame=frame)),
                frame=frame)


def _within(fit: Ellipse, frame: tuple[int, int]) -> bool:
    """Whether the ellipse ``fit`` (centre, semi-axes) lies inside a ``frame`` (width, height)
    image, up to half a pixel past its edge pixels' centres (the pixels' own extent)."""
    (x, y), (a, _), _ = fit
    w, h = frame
    return a - _EDGE_SLACK_PX <= x <= w - 1 - a + _EDGE_SLACK_PX and \
        a - _EDGE_SLACK_PX <= y <= h - 1 - a + _EDGE_SLACK_PX


def _frame_if_cut(contour: Mat, mask: Mat) -> tuple[int, int] | None:
    """The search image's (width, height) if ``contour`` touches its edge, else ``None``."""
    x, y, w, h = cv2.boundingRect(contour)
    height, width = mask.shape[:2]
    if x == 0 or y == 0 or x + w == width or y + h == height:
        return width, height
    return None


def _bridged(blobs: list[Blob], whole: Screen, colour: int, bridge_px: int) -> list[Blob]:
    """Blobs of one colour that are no mark alone but are one together: two pieces within
    ``bridge_px`` of each other whose convex hull they fill but for a thin strip (a pole,
    a wire, a seam in front of a mark), and which is a mark's shape."""
    loose = [b for b in blobs if b.ellipse is None and b.area >= _MIN_CUT_AREA_PX]
    if bridge_px <= 0 or not len(loose) > 1 or len(loose) > _MAX_LOOSE:
        return []
    box = np.array([cv2.boundingRect(b.contour) for b in loose], np.int64)
    x0, y0, x1, y1 = box[:, 0], box[:, 1], box[:, 0] + box[:, 2], box[:, 1] + box[:, 3]
    gap_x = np.maximum(x0[:, None], x0[None, :]) - np.minimum(x1[:, None], x1[None, :])
    gap_y = np.maximum(y0[:, None], y0[None, :]) - np.minimum(y1[:, None], y1[None, :])
    near = np.triu((gap_x <= bridge_px) & (gap_y <= bridge_px), 1)
    out = []
    for i, j in zip(*np.nonzero(near), strict=True):
        a, b = loose[int(i)], loose[int(j)]
        hull = cv2.convexHull(np.vstack([a.contour, b.contour]))
        hull_area = cv2.contourArea(hull)
        if hull_area <= 0 or min(a.area, b.area) < _MIN_PART * hull_area or \
                a.area + b.area < (1.0 - _MAX_STRIP) * hull_area:
            continue
        joined = Blob(colour, hull, hull_area, bridged=True)
        fit = whole(joined)
        if fit is not None:
            out.append(Blob(colour, hull, hull_area, fit, bridged=True))
    return out


def segment(scene: Scene, config: SegmentConfig,
            whole: Screen = lambda blob: None) -> Scene:
    """The scene with its blobs (needs :mod:`.classify`); a blob ``whole`` gives no ellipse for
    (not a mark's shape) is cut along the frame's edges."""
    assert scene.small is not None, "segment needs photometry first"
    bgr = scene.small if config.edge_step > 0 else None
    kernel = np.ones((OPEN_PX, OPEN_PX), np.uint8)
    blobs: list[Blob] = []
    for k, mask in enumerate(scene.masks):
        mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, kernel)
        contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
        own: list[Blob] = []
        for contour in contours:
            if len(contour) < _MIN_POINTS or cv2.contourArea(contour) < MIN_AREA_PX:
                continue
            own.extend(_pieces(contour, mask, bgr, config, whole, k))
        blobs.extend(own)
        blobs.extend(_bridged(own, whole, k, config.bridge_px))
    return replace(scene, blobs=tuple(blobs))
