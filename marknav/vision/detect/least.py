"""The least OpenCV detector: the floor every detector of marknav is measured against.

Half size, HSV, one ``inRange`` per palette colour with the colour's own floors, a 3×3 opening,
external contours, ``fitEllipse``. Nothing else: no photometry, no shape test beyond a minimum
area, no suppression. ``marknav bench`` times every detector as a multiple of this one on the
same frames, in the same run."""

from __future__ import annotations

import math
from collections.abc import Callable

import cv2
import numpy as np
import numpy.typing as npt

from marknav.vision.palette import Palette

__all__ = ["MIN_RADIUS_PX", "least_opencv_detector"]

Image = npt.NDArray[np.uint8]


#: The smallest mark radius every detector here looks for (px, full resolution): the
#: detector's own default minimum (:class:`~marknav.vision.detect.DetectorConfig`).
MIN_RADIUS_PX = 5.0


def least_opencv_detector(palette: Palette, *, min_radius_px: float = MIN_RADIUS_PX,
                          ) -> Callable[[Image], list[tuple[str, float, float, float, float]]]:
    """The least OpenCV detector of ``palette`` (see the module docstring): returns
    ``[(colour, x, y, semi-major, semi-minor)]`` in full-resolution pixels."""
    kernel = np.ones((3, 3), np.uint8)
    min_area = 0.4 * math.pi * (0.5 * min_radius_px) ** 2
    bounds = []
    for c in palette:
        spans = ((c.hue_lo, 179), (0, c.hue_hi)) if c.wraps else ((c.hue_lo, c.hue_hi),)
        bounds.append((c.name, [(np.array([lo, c.sat_min, c.val_min], np.uint8),
                                 np.array([hi, 255, 255], np.uint8)) for lo, hi in spans]))

    def detect(image: Image) -> list[tuple[str, float, float, float, float]]:
        h, w = image.shape[:2]
        small = cv2.resize(image, (w // 2, h // 2), interpolation=cv2.INTER_AREA)
        hsv = cv2.cvtColor(small, cv2.COLOR_BGR2HSV)
        found = []
        for name, spans in bounds:
            mask = cv2.inRange(hsv, spans[0][0], spans[0][1])
            for lo, hi in spans[1:]:
                mask = cv2.bitwise_or(mask, cv2.inRange(hsv, lo, hi))
            mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, kernel)
            contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
            for contour in contours:
                if len(contour) >= 5 and cv2.contourArea(contour) >= min_area:
                    (x, y), (a, b), _ = cv2.fitEllipse(contour)
                    found.append((name, 2.0 * x + 0.5, 2.0 * y + 0.5, max(a, b), min(a, b)))
        return found

    return detect
