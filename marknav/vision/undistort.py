"""Camera intrinsics and undistortion of detections (not of whole frames).

A real lens bends straight lines: a point at normalised radius ρ from the principal point is
imaged at ρ·(1 + k1ρ² + k2ρ⁴ + k3ρ⁶) plus the tangential terms p1, p2 (OpenCV's model, the one
``cv2.calibrateCamera`` fits). With barrel distortion (k1 < 0) a mark off-axis looks smaller than
it is and reads too far. Undistorting a whole frame costs a remap per frame; undistorting what the
detector found costs a few dozen points: the ellipse's outline is sampled, the points are moved
with ``cv2.undistortPoints(pts, K, dist, P=K)`` (back to pixels of the same camera matrix) and an
ellipse is fitted to them again — centre, axes and angle all come out of the fit.

:class:`Intrinsics` is the mission's ``camera.intrinsics`` (fx, fy, cx, cy, dist) as an object.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import cv2
import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from marknav.vision.detect import Mark

__all__ = ["OUTLINE_POINTS", "Intrinsics", "undistort_mark", "undistort_points"]

FloatArray = npt.NDArray[np.float64]

#: Points sampled on a detected ellipse's outline before undistorting it.
OUTLINE_POINTS = 32
#: Iterations of the undistortion (OpenCV's default of 5 leaves ~0.1 px at strong barrel
#: distortion near the corners).
_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-7)


@dataclass(frozen=True)
class Intrinsics:
    """A calibrated camera: focal lengths and principal point in pixels, distortion
    coefficients in OpenCV's order ``(k1, k2, p1, p2[, k3[, k4, k5, k6]])``."""

    fx: float
    fy: float
    cx: float
    cy: float
    dist: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        if not (self.fx > 0 and self.fy > 0):
            raise ValueError(f"intrinsics: focal lengths must be positive, got {self.fx}, "
                             f"{self.fy}")
        if len(self.dist) not in (0, 4, 5, 8):
            raise ValueError(f"intrinsics: dist needs 4, 5 or 8 coefficients, got "
                             f"{len(self.dist)}")

    @property
    def focal_px(self) -> float:
        """The focal length a round mark's radius sees (mean of fx and fy)."""
        return 0.5 * (self.fx + self.fy)

    @property
    def matrix(self) -> FloatArray:
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def coefficients(self) -> FloatArray:
        return np.array(self.dist if self.dist else (0.0, 0.0, 0.0, 0.0), dtype=np.float64)

    @property
    def distorted(self) -> bool:
        return any(c != 0.0 for c in self.dist)

    def scaled(self, sx: float, sy: float) -> Intrinsics:
        """The same lens at another resolution (image scaled by ``sx``, ``sy``; pixel centres
        at integer coordinates)."""
        return replace(self, fx=self.fx * sx, fy=self.fy * sy,
                       cx=(self.cx + 0.5) * sx - 0.5, cy=(self.cy + 0.5) * sy - 0.5)

    def to_dict(self) -> dict[str, object]:
        return {"fx": self.fx, "fy": self.fy, "cx": self.cx, "cy": self.cy,
                "dist": list(self.dist)}


def undistort_points(points: FloatArray | Sequence[tuple[float, float]],
                     intrinsics: Intrinsics) -> FloatArray:
    """Pixel points (N×2) of the distorted image → where the ideal pinhole camera with the same
    K would have imaged them."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 1, 2)
    if not intrinsics.distorted or len(pts) == 0:
        return pts.reshape(-1, 2).copy()
    k = intrinsics.matrix
    out = cv2.undistortPoints(pts, k, intrinsics.coefficients, R=None, P=k,
                              criteria=_CRITERIA)
    return np.asarray(out, dtype=np.float64).reshape(-1, 2)


def ellipse_outline(x: float, y: float, axes: tuple[float, float], angle_deg: float,
                    n: int = OUTLINE_POINTS) -> FloatArray:
    """``n`` points on the ellipse with centre (x, y), semi-axes ``axes`` (major, minor) and the
    major axis at ``angle_deg`` from +u towards +v."""
    t = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    a, b = axes
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    ex, ey = a * np.cos(t), b * np.sin(t)
    return np.stack([x + ex * c - ey * s, y + ex * s + ey * c], axis=1)


def tangential_radius(outline: FloatArray) -> float:
    """Half the undistorted length of the outline's first diameter (points 0 and n/2 of
    :func:`ellipse_outline`: the detected major axis, laid along the lens's stretch).

    A round mark's radius is read along that direction only, not as the refitted ellipse's
    major axis: undistorting magnifies the detected axes unequally — off-axis, a barrel lens
    squashes a mark radially (1 + 3k1ρ²) about three times as much as tangentially (1 + k1ρ²),
    so undistorting stretches the radial axis that much more, and with it any error of the
    detector there. A small mark the detector finds rounder than the lens made it (1 px on
    20 px is within its noise) then came out with a radial axis several per cent too long,
    which, as the major axis, was taken for the radius: such marks read near (a 21.6 px mark
    near the image edge: 20.6 × 20.1 px detected, 22.5 px undistorted as a whole, 21.35 px
    along the stretch)."""
    n = len(outline)
    return 0.5 * float(np.hypot(*(outline[0] - outline[n // 2])))


def undistort_mark(mark: Mark, intrinsics: Intrinsics) -> Mark:
    """The mark as the ideal (undistorted) camera with the same K would have seen it.

    An ellipse's outline is undistorted and refitted (centre, semi-axes, angle). A mark the
    detector calls a circle reports no orientation (its two axes may still differ by the lens's
    squash): its major axis is taken along the direction the lens stretches most at its centre
    (the distortion's Jacobian's first singular vector), and its radius is that axis
    undistorted (:func:`tangential_radius`). The centre is the refitted one. Marks are returned
    as they are when the lens has no distortion."""
    if not intrinsics.distorted:
        return mark
    h = 2.0
    angle_deg = mark.angle_deg
    if mark.shape == "circle":
        probe = undistort_points([(mark.x, mark.y), (mark.x + h, mark.y),
                                  (mark.x, mark.y + h)], intrinsics)
        centre = probe[0]
        # The lens squashes a round mark along its Jacobian's minor direction: that is where
        # the detected minor axis lies.
        ju = np.stack([probe[1] - centre, probe[2] - centre], axis=1) / h
        u, _, _ = np.linalg.svd(np.linalg.inv(ju))
        angle_deg = math.degrees(math.atan2(u[1, 0], u[0, 0]))
    pts = undistort_points(ellipse_outline(mark.x, mark.y, mark.axes, angle_deg), intrinsics)
    (ux, uy), (w, hh), angle = cv2.fitEllipse(pts.astype(np.float32))
    major, minor = (0.5 * max(w, hh), 0.5 * min(w, hh))
    if w < hh:  # fitEllipse's angle is of its first axis ("width"): turn to the major axis
        angle += 90.0
    # The centre is the refitted one: the lens moves a mark's outline unevenly, so the
    # undistorted image of the detected centre is off by up to a few pixels for big marks.
    if mark.shape == "circle":
        radius = tangential_radius(pts)
        return replace(mark, x=float(ux), y=float(uy), radius=radius,
                       axes=(radius, min(radius, float(minor))))
    return replace(mark, x=float(ux), y=float(uy), radius=float(major),
                   axes=(float(major), float(minor)), angle_deg=float(angle) % 180.0)
