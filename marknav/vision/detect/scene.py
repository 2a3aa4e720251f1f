"""The value that flows from stage to stage (:class:`Scene`) and the blobs it carries."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from marknav.vision.detect.model import Mark
from marknav.vision.palette import ColourRange

__all__ = ["SEARCH_SCALE", "Blob", "Ellipse", "Mat", "Scene", "U8Array"]

U8Array = npt.NDArray[np.uint8]
#: What OpenCV returns (images, masks, contours): its stubs type the element loosely.
Mat = npt.NDArray[Any]
#: An ellipse as ``((x, y), (semi-major, semi-minor), angle_deg)``.
Ellipse = tuple[tuple[float, float], tuple[float, float], float]

#: The search image is the frame at 1/SEARCH_SCALE of its size (area-averaged): a mark of the
#: smallest radius worth steering by (5 px) is still 2.5 px there, and the search costs a
#: quarter; marks are measured at full resolution (:mod:`.shape`).
SEARCH_SCALE = 2


@dataclass(frozen=True, eq=False)
class Blob:
    """One connected piece of a colour's mask, in search-image pixels; ``ellipse`` is its
    fitted ellipse ``((x, y), (a, b), angle_deg)`` once :mod:`.shape`'s screen passed it."""

    colour: int
    contour: Mat
    area: float
    ellipse: Ellipse | None = None
    #: Search-image pixels the blob may have lost at its rim to :mod:`.segment`'s cut.
    cut_px: int = 0
    #: Whether the blob is two pieces joined across a thin occluder (:mod:`.segment`).
    bridged: bool = False
    #: The search image's (width, height) when the blob touches its edge (a mark cut by the
    #: frame's edge), else ``None``.
    frame: tuple[int, int] | None = None


@dataclass(frozen=True, eq=False)
class Scene:
    """One frame as far as the stages have taken it. Stages fill fields; none changes one.

    ``image``: the BGR frame; ``gains``: the per-channel gains (B, G, R) that take out its exposure
    and the light's colour, ``lut`` the table applying them (:mod:`.photometry`); ``small``: the
    search image through it; ``hsv``: its HSV; ``masks``: one per palette colour (:mod:`.classify`);
    ``blobs`` (:mod:`.segment`); ``marks`` (:mod:`.shape`, then :mod:`.suppression`)."""

    image: U8Array
    palette: tuple[ColourRange, ...]
    gains: Mat | None = None
    lut: Mat | None = None
    small: Mat | None = None
    hsv: Mat | None = None
    masks: tuple[Mat, ...] = ()
    blobs: tuple[Blob, ...] = ()
    marks: tuple[Mark, ...] = ()
