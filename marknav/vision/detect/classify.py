"""Stage 2, colour classification: one mask per palette colour.

**Design.** After :mod:`.photometry` the frame is exposed for its marks and lit white, so each
colour is the palette's own box in HSV: its hue range (widened by ``hue_margin``), its value
floor (which now holds relative to the frame's exposure), and its saturation floor. The margin
never reaches into another palette colour's range: a pixel has one colour at most. The
saturation floor is the palette's scaled by ``sat_share``: a mark printed on paper or seen
through haze keeps its hue but loses saturation, and the colour of the surroundings no longer
adds to it once the light is white; what the lower floor lets in, the shape (:mod:`.shape`)
and the contrast with the mark's surroundings decide. The palette taught by ``marknav palette``
is the same box (:mod:`marknav.vision.palette_teach`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import cv2
import numpy as np

from marknav.vision.detect.scene import Mat, Scene
from marknav.vision.palette import HUE_MAX, ColourRange

__all__ = ["ClassifyConfig", "classify", "colour_bounds"]


@dataclass(frozen=True)
class ClassifyConfig:
    """How far each palette box reaches (see the module docstring)."""

    #: Hue (OpenCV units, 2° each) a pixel may lie outside its colour's range: a mark's hue
    #: moves by about 1 unit with the light's colour left after correction and with JPEG.
    hue_margin: int = 2
    #: Share of the palette's saturation floor a pixel needs (0..1): printed and pale paint
    #: reaches 0.5-0.7 of a saturated paint's saturation.
    sat_share: float = 0.7

    def __post_init__(self) -> None:
        if not 0 <= self.hue_margin <= HUE_MAX // 4:
            raise ValueError(f"hue_margin must be in [0, {HUE_MAX // 4}], got {self.hue_margin}")
        if not 0.0 <= self.sat_share <= 1.0:
            raise ValueError(f"sat_share must be in [0, 1], got {self.sat_share}")


def _margin(colour: ColourRange, others: Sequence[ColourRange], margin: int, step: int) -> int:
    """How far (hue units, up to ``margin``) ``colour``'s range may widen in direction ``step``
    (-1: down from ``hue_lo``, +1: up from ``hue_hi``) before it reaches another colour's."""
    edge = colour.hue_lo if step < 0 else colour.hue_hi
    for d in range(1, margin + 1):
        if any(o.contains((edge + step * d) % HUE_MAX) for o in others):
            return d - 1
    return margin


def colour_bounds(colour: ColourRange, config: ClassifyConfig,
                  others: Sequence[ColourRange] = ()) -> list[tuple[Mat, Mat]]:
    """The ``inRange`` bounds (low, high; H, S, V) of ``colour``: one pair, two if it wraps. Its
    hue range widens by ``hue_margin`` each way, but not into one of ``others``' ranges."""
    lo = (colour.hue_lo - _margin(colour, others, config.hue_margin, -1)) % HUE_MAX
    hi = (colour.hue_hi + _margin(colour, others, config.hue_margin, +1)) % HUE_MAX
    s = round(colour.sat_min * config.sat_share)
    v = colour.val_min
    spans = ((lo, HUE_MAX - 1), (0, hi)) if lo > hi else ((lo, hi),)
    return [(np.array([a, s, v], np.uint8), np.array([b, 255, 255], np.uint8)) for a, b in spans]


def colour_mask(hsv: Mat, colour: ColourRange, config: ClassifyConfig,
                others: Sequence[ColourRange] = ()) -> Mat:
    """The 0/255 mask of the pixels of ``hsv`` in ``colour``'s box (see :func:`colour_bounds`)."""
    bounds = colour_bounds(colour, config, others)
    mask: Mat = cv2.inRange(hsv, bounds[0][0], bounds[0][1])
    for low, high in bounds[1:]:
        mask = cv2.bitwise_or(mask, cv2.inRange(hsv, low, high))
    return mask


def classify(scene: Scene, config: ClassifyConfig) -> Scene:
    """The scene with one mask per palette colour (needs :mod:`.photometry`)."""
    assert scene.hsv is not None, "classify needs photometry first"
    palette = scene.palette
    return replace(scene, masks=tuple(
        colour_mask(scene.hsv, c, config, [o for o in palette if o is not c]) for c in palette))
