"""The simulated camera's lens: radial and tangential distortion and an off-centre principal point.

A webcam's lens is not a pinhole: OpenCV's model (the one ``marknav calibrate-camera`` fits)
images a point at normalised position (x, y), ρ² = x² + y², at::

    x_d = x (1 + k1 ρ² + k2 ρ⁴) + 2 p1 x y + p2 (ρ² + 2 x²)
    y_d = y (1 + k1 ρ² + k2 ρ⁴) + p1 (ρ² + 2 y²) + 2 p2 x y

around a principal point that is rarely the image centre. The renderer draws the ideal pinhole
image on a canvas large enough for every pixel the lens brings into view (barrel distortion,
k1 < 0, shows more than the pinhole would), then :class:`LensWarp` remaps it to the distorted
image with ``cv2.remap`` (bilinear; the maps are built once per camera and lens, the warp costs
about a millisecond per 640×480 frame). Noise is added after the warp (it is the sensor's).

:func:`random_lens` draws what ordinary webcams show: k1 in −0.4…0 (barrel), k2 positive enough
to keep the distortion monotonic over the image (a real lens never folds the image back), p1, p2
within ±0.002 and the principal point within ±4 % of the image size from its centre.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Annotated

import cv2
import numpy as np
import numpy.typing as npt
from pydantic import BaseModel, ConfigDict, Field, model_validator

from marknav.core.yamlio import Number
from marknav.sim.randomisation import bounds
from marknav.vision.undistort import Intrinsics, undistort_points

__all__ = ["K1_RANGE", "PRINCIPAL_OFFSET_MAX", "TANGENTIAL_MAX", "Lens", "LensWarp",
           "lens_warp", "principal_point", "random_lens"]

#: What :func:`random_lens` draws (ordinary webcams): the ``lens.*`` entries of the one table of
#: randomised ranges, :mod:`marknav.sim.randomisation`.
K1_RANGE = bounds("lens.k1")
TANGENTIAL_MAX = bounds("lens.tangential")[1]
PRINCIPAL_OFFSET_MAX = bounds("lens.principal_offset")[1]  # of the image's width / height
#: The distortion must stay monotonic out to this normalised radius (beyond any webcam's corner).
_MONOTONIC_RHO = 1.2

_Coeff = Annotated[Number, Field(ge=-1.0, le=1.0, allow_inf_nan=False)]
_Tangential = Annotated[Number, Field(ge=-0.05, le=0.05, allow_inf_nan=False)]
_Offset = Annotated[Number, Field(ge=-0.2, le=0.2, allow_inf_nan=False)]


class Lens(BaseModel):
    """Distortion coefficients (OpenCV's k1, k2, p1, p2) and the principal point's offset from
    the image centre, as fractions of the image's width and height. The default is a pinhole."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    k1: _Coeff = 0.0
    k2: _Coeff = 0.0
    p1: _Tangential = 0.0
    p2: _Tangential = 0.0
    principal_offset: tuple[_Offset, _Offset] = (0.0, 0.0)

    @model_validator(mode="after")
    def _monotonic(self) -> Lens:
        rho = np.linspace(0.0, _MONOTONIC_RHO, 241)
        slope = 1.0 + 3.0 * self.k1 * rho**2 + 5.0 * self.k2 * rho**4
        if float(slope.min()) <= 0.05:
            raise ValueError(
                f"k1 {self.k1:g}, k2 {self.k2:g} fold the image back on itself within "
                f"{_MONOTONIC_RHO} focal lengths of the axis (no real lens does): with k1 < 0 "
                f"k2 must be at least about 0.45·k1²")
        return self

    @property
    def distorted(self) -> bool:
        return any(c != 0.0 for c in (self.k1, self.k2, self.p1, self.p2))

    @property
    def ideal(self) -> bool:
        return not self.distorted and self.principal_offset == (0.0, 0.0)

    @property
    def dist(self) -> tuple[float, float, float, float]:
        return (self.k1, self.k2, self.p1, self.p2)


def random_lens(rng: np.random.Generator) -> Lens:
    """A webcam-like lens (see the module doc)."""
    k1 = float(rng.uniform(*K1_RANGE))
    k2 = float(0.5 * k1 * k1 + rng.uniform(*bounds("lens.k2_excess")))
    p1, p2 = (float(v) for v in rng.uniform(*bounds("lens.tangential"), 2))
    off = rng.uniform(*bounds("lens.principal_offset"), 2)
    return Lens(k1=round(k1, 4), k2=round(k2, 4), p1=round(p1, 5), p2=round(p2, 5),
                principal_offset=(round(float(off[0]), 4), round(float(off[1]), 4)))


def principal_point(width: int, height: int, lens: Lens,
                    centre: tuple[float, float] | None = None) -> tuple[float, float]:
    """The principal point (px) of a ``width`` × ``height`` image through ``lens``: ``centre``
    (default the image centre) moved by the lens's offset."""
    cx, cy = centre if centre is not None else ((width - 1) / 2.0, (height - 1) / 2.0)
    return (cx + lens.principal_offset[0] * width, cy + lens.principal_offset[1] * height)


@dataclass(frozen=True)
class LensWarp:
    """The remap from an ideal canvas to the distorted image.

    The canvas is the output image grown by ``margin`` = (left, top, right, bottom) px, with the
    same focal length and the principal point moved with it; render the ideal pinhole image there
    and :meth:`apply` it."""

    intrinsics: Intrinsics
    size: tuple[int, int]  # output (width, height)
    margin: tuple[int, int, int, int]
    map1: npt.NDArray[np.int16]
    map2: npt.NDArray[np.uint16]

    @property
    def canvas_size(self) -> tuple[int, int]:
        left, top, right, bottom = self.margin
        return (self.size[0] + left + right, self.size[1] + top + bottom)

    @property
    def canvas_principal(self) -> tuple[float, float]:
        return (self.intrinsics.cx + self.margin[0], self.intrinsics.cy + self.margin[1])

    def apply(self, canvas: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint8]:
        """The distorted image (output size) of an ideal canvas image."""
        return np.asarray(cv2.remap(canvas, self.map1, self.map2, cv2.INTER_LINEAR,
                                    borderMode=cv2.BORDER_REPLICATE), dtype=np.uint8)


@functools.lru_cache(maxsize=8)
def lens_warp(width: int, height: int, focal_px: float, lens: Lens,
              centre: tuple[float, float] | None = None) -> LensWarp:
    """The (cached) warp of a ``width`` × ``height`` camera of ``focal_px`` through ``lens``
    (principal point: :func:`principal_point`)."""
    cx, cy = principal_point(width, height, lens, centre)
    intr = Intrinsics(fx=focal_px, fy=focal_px, cx=cx, cy=cy, dist=lens.dist)
    u, v = np.meshgrid(np.arange(width, dtype=np.float64), np.arange(height, dtype=np.float64))
    ideal = undistort_points(np.stack([u.ravel(), v.ravel()], axis=1), intr)
    ix, iy = ideal[:, 0].reshape(height, width), ideal[:, 1].reshape(height, width)
    pad = 3  # bilinear taps and anti-aliased edges
    left = max(0, math.ceil(-float(ix.min()))) + pad
    top = max(0, math.ceil(-float(iy.min()))) + pad
    right = max(0, math.ceil(float(ix.max()) - (width - 1))) + pad
    bottom = max(0, math.ceil(float(iy.max()) - (height - 1))) + pad
    mx = (ix + left).astype(np.float32)
    my = (iy + top).astype(np.float32)
    map1, map2 = cv2.convertMaps(mx, my, cv2.CV_16SC2)
    return LensWarp(intrinsics=intr, size=(width, height), margin=(left, top, right, bottom),
                    map1=np.asarray(map1, dtype=np.int16), map2=np.asarray(map2, dtype=np.uint16))
