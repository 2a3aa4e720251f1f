"""Stage 3, segmentation: each colour's mask cut into blobs, one per object.

The mask is opened (a square of :data:`OPEN_PX`: single pixels of noise and one-pixel bridges go).
A mark standing against a surface of its own hue — a carpet under it, a board or a ball behind
it — joins it in the mask, but not in the frame: the paint's edge against the other surface
is a brightness or saturation step the frame's own edges (Canny on the corrected grey) show.
So the mask is cut along those edges, the pieces smaller than a mark's smallest area are given
back to their neighbours, and every piece is grown back over the edge pixels it lost (two
pixels, the width Canny's edges and the opening take); where two pieces meet one seam pixel
stays, and each piece is its own blob. A mark on a background of another colour has no such
seam: the cut only ever runs inside a colour's mask.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import cv2
import numpy as np

from marknav.vision.detect.model import MIN_RADIUS_FLOOR_PX
from marknav.vision.detect.scene import SEARCH_SCALE, Blob, Mat, Scene

__all__ = ["SegmentConfig", "cut_along_edges", "segment"]

#: Pixels (search image) a piece is grown back over the edges cut from it.
_GROW_PX = 2
#: Fewest contour points an ellipse is fitted to.
_MIN_POINTS = 5
_CROSS = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))
_SQUARE = np.ones((3, 3), np.uint8)


@dataclass(frozen=True)
class SegmentConfig:
    """How masks become blobs (see the module docstring)."""

    #: Grey-level step (after :mod:`.photometry`) that is an edge between two surfaces: a
    #: paint's edge against a surface of its hue steps by 30+ levels, a surface's own texture
    #: and shading by under 20 (Canny's high threshold; the low one is half). 0: no cut.
    edge_step: float = 40.0


#: Side (search-image px) of the opening: 3 removes the single pixels JPEG and sensor noise
#: classify as a colour.
OPEN_PX = 3
#: The smallest blob (search-image px): a disc of the smallest radius the stages measure
#: (2.5 px full resolution, :data:`~marknav.vision.detect.model.MIN_RADIUS_FLOOR_PX`) seen at
#: the steepest view an axis ratio allows (0.3).
MIN_AREA_PX = max(4.0, 0.3 * math.pi * (MIN_RADIUS_FLOOR_PX / SEARCH_SCALE) ** 2)


def cut_along_edges(mask: Mat, edges: Mat, min_area: float) -> Mat:
    """``mask`` (0/255) with a one-pixel seam wherever two of its pieces, once cut along
    ``edges``, meet (see the module docstring)."""
    cut = cv2.bitwise_and(mask, cv2.bitwise_not(edges))
    n, labels, stats, _ = cv2.connectedComponentsWithStats(cut, connectivity=4)
    if n <= 2:  # one piece or none: nothing to separate
        return mask
    keep = stats[:, cv2.CC_STAT_AREA] >= min_area
    keep[0] = False
    table = np.where(keep, np.arange(n), 0).astype(np.float32)
    pieces = table[labels]
    inside = mask > 0
    for _ in range(_GROW_PX):
        grown = cv2.dilate(pieces, _CROSS)
        pieces = np.where((pieces == 0) & inside, grown, pieces)
    high = cv2.dilate(pieces, _SQUARE)
    seam = (high != pieces) & (pieces > 0)
    out: Mat = np.where(inside & (pieces > 0) & ~seam, 255, 0).astype(np.uint8)
    # Pixels no piece reached (a region of small pieces only) stay as they were.
    out[inside & (pieces == 0)] = 255
    return out


def _pieces(contour: Mat, mask: Mat, edges: Mat | None, min_area: float,
            whole: Callable[[Blob], bool], colour: int) -> list[Blob]:
    """The blob of ``contour``, or, when it is not a whole mark's shape, the pieces the frame's
    edges cut it into (within its bounding box)."""
    blob = Blob(colour, contour, cv2.contourArea(contour))
    if edges is None or whole(blob) or blob.area < 2 * min_area:
        return [blob]
    x, y, w, h = cv2.boundingRect(contour)
    own = np.zeros((h, w), np.uint8)
    cv2.drawContours(own, [contour - (x, y)], -1, 255, -1)
    own &= mask[y:y + h, x:x + w]
    cut = cut_along_edges(own, edges[y:y + h, x:x + w], min_area)
    out = []
    for part in cv2.findContours(cut, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)[0]:
        area = cv2.contourArea(part)
        if area >= min_area and len(part) >= _MIN_POINTS:
            out.append(Blob(colour, np.add(part, (x, y)), area))
    return out


def segment(scene: Scene, config: SegmentConfig,
            whole: Callable[[Blob], bool] = lambda blob: True) -> Scene:
    """The scene with its edges and blobs (needs :mod:`.classify`); a blob ``whole`` says is
    not a mark's shape is cut along the frame's edges."""
    assert scene.small is not None, "segment needs photometry first"
    edges = None
    if config.edge_step > 0:
        grey = cv2.cvtColor(scene.small, cv2.COLOR_BGR2GRAY)
        edges = cv2.Canny(grey, 0.5 * config.edge_step, config.edge_step)
    kernel = np.ones((OPEN_PX, OPEN_PX), np.uint8)
    min_area = MIN_AREA_PX
    blobs: list[Blob] = []
    for k, mask in enumerate(scene.masks):
        mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, kernel)
        contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
        for contour in contours:
            if len(contour) >= _MIN_POINTS and cv2.contourArea(contour) >= min_area:
                blobs.extend(_pieces(contour, mask, edges, min_area, whole, k))
    return replace(scene, edges=edges, blobs=tuple(blobs))
