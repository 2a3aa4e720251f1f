"""Stage 2, colour classification: one mask per palette colour.

**Design.** After :mod:`.photometry` the frame is exposed for its marks and lit white, so each
colour is the palette's own box in HSV: its hue range (widened by ``hue_margin``), its value
floor (which now holds relative to the frame's exposure), and its saturation floor. Each hue
has one colour at most: the one whose range holds it, else the nearest within the margin
(a table of 180 hues, :func:`hue_table`). The
saturation floor is the palette's scaled by ``sat_share``: a mark printed on paper or seen
through haze keeps its hue but loses saturation, and the colour of the surroundings no longer
adds to it once the light is white; what the lower floor lets in, the shape (:mod:`.shape`)
and the contrast with the mark's surroundings decide. The palette taught by ``marknav palette``
is the same box (:mod:`marknav.vision.palette_teach`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, replace

import cv2
import numpy as np

from marknav.vision.detect.scene import Mat, Scene
from marknav.vision.palette import HUE_MAX, ColourRange

__all__ = ["ClassifyConfig", "classify", "floors", "hue_table"]


#: Hue tables kept (one per palette and margin a process uses).
_TABLES_KEPT = 32


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


@functools.lru_cache(maxsize=_TABLES_KEPT)
def hue_table(palette: tuple[ColourRange, ...], margin: int) -> Mat:
    """The 256-entry table from a pixel's hue (0..179) to its palette colour's index + 1 (0:
    none): the colour whose range holds the hue, else the nearest one within ``margin``
    (hue units; the first of equally near ones). Kept per palette and margin (a pure
    function of them; read-only)."""
    table = np.zeros(256, np.uint8)
    for hue in range(HUE_MAX):
        near = [(c.distance(hue), k) for k, c in enumerate(palette) if c.distance(hue) <= margin]
        if near:
            table[hue] = min(near)[1] + 1
    table.setflags(write=False)
    return table


def floors(colour: ColourRange, config: ClassifyConfig) -> tuple[int, int]:
    """A pixel's least saturation and value (0..255) for ``colour``."""
    return round(colour.sat_min * config.sat_share), colour.val_min


def classify(scene: Scene, config: ClassifyConfig) -> Scene:
    """The scene with one mask per palette colour (needs :mod:`.photometry`)."""
    assert scene.hsv is not None, "classify needs photometry first"
    label = cv2.LUT(np.ascontiguousarray(scene.hsv[..., 0]),
                    hue_table(scene.palette, config.hue_margin))
    masks = []
    for k, colour in enumerate(scene.palette):
        s, v = floors(colour, config)
        floor = cv2.inRange(scene.hsv, np.array([0, s, v], np.uint8),
                            np.array([255, 255, 255], np.uint8))
        masks.append(cv2.bitwise_and(cv2.inRange(label, k + 1, k + 1), floor))
    return replace(scene, masks=tuple(masks))
