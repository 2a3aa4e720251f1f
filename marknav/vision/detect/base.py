"""What every stage of :class:`~marknav.vision.detect.Detector` shares: the frame's search
products (:class:`_Frame`), the detector's tables, and turning an ellipse into a :class:`Mark`."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from marknav.vision.detect.geometry import Mat, _Ellipse
from marknav.vision.detect.model import DetectorConfig, Mark, Shape
from marknav.vision.palette import Palette


@dataclass
class _Frame:
    """One frame's shared data: the full image, the half-resolution search products, and the
    white-balance matrix (applied to full-resolution windows when their hues are needed)."""

    image: Mat
    width: int
    height: int
    small: Mat  # search resolution, white-balanced
    hsv: Mat  # search resolution, white-balanced
    mask: Mat  # search resolution
    sx: float  # full-resolution px per search px
    sy: float
    balance: npt.NDArray[np.float32] | None  # 3×3 white-balance matrix, None when identity
    v_floor: int
    #: A hue cluster's part of a blob (:meth:`Detector._split_hues`): 256 entries, 0 for the
    #: hues of the blob's other clusters. Pixels of those hues are another object (a board of a
    #: near colour inside the mark's palette range), not the mark going on. None: every hue.
    hue_keep: Mat | None = None


class _DetectorBase:
    """The state the stage mixins read (set up by :class:`Detector.__init__`)."""

    palette: Palette
    config: DetectorConfig
    _sat_min: int
    _val_min: int
    _uniform_floors: bool
    _hue_lut: Mat
    _gate_lut: Mat
    _fine_lut: Mat
    _membership: npt.NDArray[np.float64]
    _kernel: Mat
    _kernel3: Mat
    last_gains: tuple[float, float, float]
    last_grey_level: float

    def _mark(self, e: _Ellipse, colour: int, score: float) -> Mark | None:
        cfg = self.config
        major, minor = e.major, e.minor
        if major < cfg.min_radius or (cfg.max_radius is not None and major > cfg.max_radius):
            return None
        if minor < cfg.min_axis_ratio * major or score < cfg.min_score:
            return None
        angle = math.degrees(e.theta) if major == e.a else math.degrees(e.theta) + 90.0
        angle %= 180.0
        shape: Shape = "circle" if minor >= cfg.circle_ratio * major else "ellipse"
        return Mark(self.palette[colour].name, e.cx, e.cy, major, (major, minor), angle, shape,
                    min(1.0, score))
