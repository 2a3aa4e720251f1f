"""Glows are not marks: a round coloured blob whose centre is much brighter than its body.

A mark is a flat painted disc. Its light varies across it (a shading gradient, a shadow's edge),
but a linear gradient is as bright at the centre as on average around a ring about it. A glow
(a galaxy, a lamp, a lit ball's highlight filling its middle) falls off from a bright core. The
test compares the brightness (the largest channel of the mean colour) inside 0.35 of the mark's
ellipse with that on the ring between 0.5 and 0.75 of it, in the frame's own pixels.

Measured on the project's corpus (``tests/data``; ratio core/ring): painted marks, real and
composited, with poles and boards across them, 0.70-1.08; glows that the palette's red takes for
marks (small galaxies in an astronomical photograph) 1.41-1.80. :data:`GLOW_RATIO` sits between.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from marknav.vision.detect.geometry import Mat, U8Array
from marknav.vision.detect.model import Mark

__all__ = ["GLOW_RATIO", "glow_ratio", "is_glow"]

#: Core/ring brightness ratio from which a blob is a glow, not a mark.
GLOW_RATIO = 1.25
#: Ellipse scales of the core's outline and the ring's inner and outer outlines.
_CORE, _RING_IN, _RING_OUT = 0.35, 0.5, 0.75


def _ellipse_mask(shape: tuple[int, int], cx: float, cy: float, a: float, b: float,
                  angle_deg: float) -> Mat:
    mask = np.zeros(shape, np.uint8)
    _ellipse_into(mask, cx, cy, a, b, angle_deg, 255)
    return mask


def _ellipse_into(mask: Mat, cx: float, cy: float, a: float, b: float, angle_deg: float,
                  value: int) -> None:
    """Fill an ellipse of ``mask`` with ``value`` (1/16 px precision)."""
    shift = 4
    k = 1 << shift
    cv2.ellipse(mask, (round(cx * k), round(cy * k)),
                (max(1, round(a * k)), max(1, round(b * k))), angle_deg, 0, 360, value,
                cv2.FILLED, cv2.LINE_8, shift)


def glow_ratio(image: U8Array | Mat, mark: Mark) -> float | None:
    """Brightness inside ``mark``'s core over that on its ring (see the module docstring);
    None when either holds no pixel inside the image."""
    h, w = image.shape[:2]
    a, b = mark.axes
    reach = _RING_OUT * a + 2.0
    x0, y0 = max(0, math.floor(mark.x - reach)), max(0, math.floor(mark.y - reach))
    x1, y1 = min(w, math.ceil(mark.x + reach) + 1), min(h, math.ceil(mark.y + reach) + 1)
    if x1 - x0 < 2 or y1 - y0 < 2:
        return None
    # A large mark is read on a sparser grid: ~10 samples across its semi-major axis are
    # plenty for two means, and the cost stays that of a small mark.
    k = max(1, int(a // 10))
    roi = np.ascontiguousarray(image[y0:y1:k, x0:x1:k])
    shape = roi.shape[:2]
    cx, cy = (mark.x - x0) / k, (mark.y - y0) / k
    a, b = a / k, b / k
    core = _ellipse_mask(shape, cx, cy, _CORE * a, _CORE * b, mark.angle_deg)
    ring = _ellipse_mask(shape, cx, cy, _RING_OUT * a, _RING_OUT * b, mark.angle_deg)
    cv2.subtract(ring, _ellipse_mask(shape, cx, cy, _RING_IN * a, _RING_IN * b,
                                     mark.angle_deg), dst=ring)
    if cv2.countNonZero(core) == 0 or cv2.countNonZero(ring) == 0:
        return None
    core_v = max(cv2.mean(roi, mask=core)[:3])
    ring_v = max(cv2.mean(roi, mask=ring)[:3])
    return core_v / max(ring_v, 1.0)


def is_glow(image: U8Array | Mat, mark: Mark) -> bool:
    """Whether ``mark`` is a glow: its core at least :data:`GLOW_RATIO` times as bright as its
    ring."""
    ratio = glow_ratio(image, mark)
    return ratio is not None and ratio >= GLOW_RATIO
