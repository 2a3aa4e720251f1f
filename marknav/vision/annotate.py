"""Draw detected marks on a frame, for people to look at (``marknav detect --annotate``).

Each mark gets its fitted outline (a dark halo under a white line, visible on any background), a
centre cross, and a label ``colour r=RADIUS`` on a tab filled with the mark's palette colour.
Frames narrower than :data:`MIN_WIDTH` are enlarged first so the labels stay legible; the
drawing is sub-pixel (OpenCV ``shift``), so outlines sit where the detector put them.
"""

from __future__ import annotations

import colorsys
import math
from collections.abc import Sequence

import cv2
import numpy as np
import numpy.typing as npt

from marknav.vision.detect import Mark
from marknav.vision.palette import Palette

__all__ = ["MIN_WIDTH", "annotate"]

Image = npt.NDArray[np.uint8]

#: Frames narrower than this are scaled up (by an integer factor) before drawing.
MIN_WIDTH = 640
_SHIFT = 4
_ONE = 1 << _SHIFT


def _palette_bgr(name: str, palette: Palette | None) -> tuple[int, int, int]:
    hue = None
    if palette is not None:
        for colour in palette:
            if colour.name == name:
                hue = colour.centre_hue
                break
    if hue is None:
        return (200, 200, 200)
    r, g, b = colorsys.hsv_to_rgb(hue * 2.0 / 360.0, 1.0, 1.0)
    return (round(b * 255), round(g * 255), round(r * 255))


def _fx(v: float, scale: int) -> int:
    """Image coordinate (pixel centres at integers) → shifted coordinate in the scaled frame."""
    return round(((v + 0.5) * scale - 0.5) * _ONE)


def annotate(image: Image, marks: Sequence[Mark], palette: Palette | None = None) -> Image:
    """A copy of ``image`` (BGR) with ``marks`` drawn and labelled; enlarged if narrow."""
    if image.ndim == 2:
        image = np.asarray(cv2.cvtColor(image, cv2.COLOR_GRAY2BGR), np.uint8)
    scale = max(1, math.ceil(MIN_WIDTH / image.shape[1])) if image.shape[1] < MIN_WIDTH else 1
    if scale > 1:
        out = np.asarray(cv2.resize(image, None, fx=scale, fy=scale,
                                    interpolation=cv2.INTER_LINEAR), np.uint8)
    else:
        out = image.copy()
    h, w = out.shape[:2]
    font = cv2.FONT_HERSHEY_SIMPLEX
    font_scale = max(0.4, min(0.8, w / 1200.0))
    thick = 1 if w < 1000 else 2
    labels: list[tuple[Mark, tuple[int, int, int]]] = []
    for mark in marks:
        colour = _palette_bgr(mark.colour, palette)
        centre = (_fx(mark.x, scale), _fx(mark.y, scale))
        axes = (round(mark.axes[0] * scale * _ONE), round(mark.axes[1] * scale * _ONE))
        cv2.ellipse(out, centre, axes, mark.angle_deg, 0, 360, (0, 0, 0), thick + 2, cv2.LINE_AA,
                    _SHIFT)
        cv2.ellipse(out, centre, axes, mark.angle_deg, 0, 360, (255, 255, 255), thick,
                    cv2.LINE_AA, _SHIFT)
        arm = max(3, round(0.15 * mark.axes[1] * scale))
        cx, cy = round((mark.x + 0.5) * scale - 0.5), round((mark.y + 0.5) * scale - 0.5)
        for dx, dy in ((arm, 0), (0, arm)):
            cv2.line(out, (cx - dx, cy - dy), (cx + dx, cy + dy), (0, 0, 0), thick + 2,
                     cv2.LINE_AA)
            cv2.line(out, (cx - dx, cy - dy), (cx + dx, cy + dy), (255, 255, 255), thick,
                     cv2.LINE_AA)
        labels.append((mark, colour))
    # Labels last, so no outline crosses a label.
    for mark, colour in labels:
        text = f"{mark.colour} r={mark.radius:.1f}"
        (tw, th), base = cv2.getTextSize(text, font, font_scale, thick)
        pad = 3
        mid = (mark.x + 0.5) * scale - 0.5
        top = (mark.y + 0.5) * scale - 0.5 - mark.axes[0] * scale - 6
        x0 = round(mid - tw / 2 - pad)
        y1 = round(top)
        y0 = y1 - th - base - 2 * pad
        if y0 < 0:  # no room above: put it below the mark
            y0 = round((mark.y + 0.5) * scale + mark.axes[0] * scale + 6)
            y1 = y0 + th + base + 2 * pad
        x0 = min(max(0, x0), max(0, w - tw - 2 * pad))
        y0 = min(max(0, y0), max(0, h - th - base - 2 * pad))
        y1 = y0 + th + base + 2 * pad
        cv2.rectangle(out, (x0, y0), (x0 + tw + 2 * pad, y1), colour, cv2.FILLED)
        cv2.rectangle(out, (x0, y0), (x0 + tw + 2 * pad, y1), (0, 0, 0), 1)
        ink = (0, 0, 0) if sum(np.array(colour) * (0.114, 0.587, 0.299)) > 110 else (255, 255, 255)
        cv2.putText(out, text, (x0 + pad, y1 - pad - base), font, font_scale, ink, thick,
                    cv2.LINE_AA)
    return out
