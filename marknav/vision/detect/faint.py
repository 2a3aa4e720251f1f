"""Faint blobs are not marks: a mark's colour stands out from what surrounds it.

A painted mark is a saturated disc against a room: its colour (white-balanced, grey removed)
differs from that of a ring just outside it by well over a hundred BGR units in a lit room.
Out-of-focus clutter that happens to be round and of a palette hue — a spectator's shirt in a
blurred crowd, the shaded side of a fruit, a tinted patch of a wall — barely differs from its
surroundings: the detector finds its outline in the α mask, but there is little colour to it.

The test compares the mean colour inside 0.6 of the mark's ellipse with the mean colour of the
ring from 2 to 6 px outside it, in the frame's own pixels (the white-balance gains applied to the
two means), each with its grey component removed. The floor scales down in dim scenes (grey level
below ``val_ref_grey``), as the palette's value floors do.

Measured on the project's corpus (``tests/data``; chroma difference in BGR units, divided by the
dim-scene scale): marks in composited frames 49-256 (the lowest a large mark crossed by a pole;
the rest 64 and more), labelled real marks 119-187, synthetic benchmark marks 66 and more,
simulator marks 108 and more; the false marks of natural photographs and composites 17-121, most
of them 17-41.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import numpy as np

from marknav.vision.detect.geometry import U8Array
from marknav.vision.detect.glow import _ellipse_into, _ellipse_mask
from marknav.vision.detect.model import Mark

__all__ = ["chroma_contrast"]

#: Ellipse scale of the inside's outline; the ring's inner and outer outlines (px beyond the
#: mark's own).
_INSIDE = 0.6
_RING_FROM, _RING_TO = 2.0, 6.0


def chroma_contrast(image: U8Array, mark: Mark, gains: Sequence[float]) -> float | None:
    """The chroma difference (BGR units, grey removed) between the inside of ``mark`` and the
    ring just outside it, white-balanced by ``gains`` (B, G, R); None when either holds no
    pixel inside the image."""
    h, w = image.shape[:2]
    a, b = mark.axes
    reach = a + _RING_TO + 2.0
    x0, y0 = max(0, math.floor(mark.x - reach)), max(0, math.floor(mark.y - reach))
    x1, y1 = min(w, math.ceil(mark.x + reach) + 1), min(h, math.ceil(mark.y + reach) + 1)
    if x1 - x0 < 2 or y1 - y0 < 2:
        return None
    # A large mark is read on a sparser grid (~10 samples across its semi-major axis): two
    # means need no more, and the cost stays that of a small mark. The ring stays ≥ 1 sample
    # wide.
    k = max(1, min(int(a // 10), int((_RING_TO - _RING_FROM) // 1)))
    roi = image[y0:y1, x0:x1] if k == 1 else np.ascontiguousarray(image[y0:y1:k, x0:x1:k])
    shape = roi.shape[:2]
    cx, cy = (mark.x - x0) / k, (mark.y - y0) / k
    inside = _ellipse_mask(shape, cx, cy, _INSIDE * a / k, _INSIDE * b / k, mark.angle_deg)
    ring = _ellipse_mask(shape, cx, cy, (a + _RING_TO) / k, (b + _RING_TO) / k, mark.angle_deg)
    _ellipse_into(ring, cx, cy, (a + _RING_FROM) / k, (b + _RING_FROM) / k, mark.angle_deg, 0)
    if not inside.any() or not ring.any():
        return None
    m_in = cv2.mean(roi, mask=inside)
    m_out = cv2.mean(roi, mask=ring)
    d = [gains[c] * (m_in[c] - m_out[c]) for c in range(3)]
    grey = (d[0] + d[1] + d[2]) / 3.0
    return math.sqrt(sum((x - grey) ** 2 for x in d))
