"""From a mark's image to its position in millimetres (paper §3.1 and §4.5).

Range models (distance along the camera axis from the image radius r, in px):

- power law, eq. 19:  d = a · r^b            (fitted to a table, e.g. a=58958, b=-0.9434)
- pinhole, eq. 2:     d = f · R / r          (focal length f in px, mark radius R in mm)

Lateral offset, eqs. 20–21: d_x = (x0 − x_c) / r0 · R, positive to the right of the image centre.

A disc turned by α about the vertical axis projects as an ellipse (eq. 3):
r_h = f · R cos α / (d + R sin α), while its vertical semi-axis stays ≈ f·R/d. The semi-major
axis is therefore the one to use as "the radius", and the axis ratio q = minor/major gives α
through eq. 4: q = cos α / (1 + (R/d) sin α). With k = R/d this is
cos α − q·k·sin α = q, i.e. √(1 + q²k²) · cos(α + β) = q with β = atan(q·k), so
α = arccos(q / √(1 + q²k²)) − β. The sign of α cannot be told from one ellipse: |α| is returned.

All functions are pure; frames follow ``docs/architecture.md`` (robot frame: x forward, y left).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable


@runtime_checkable
class RangeModel(Protocol):
    """Turns an image radius (px) into a distance along the camera axis (mm)."""

    def distance_mm(self, radius_px: float) -> float: ...


@dataclass(frozen=True)
class PowerLaw:
    """Eq. 19: d = a · r^b, fitted by :func:`marknav.vision.calibrate.fit_power_law`."""

    a: float
    b: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.a) and self.a > 0):
            raise ValueError(f"power law: a must be a positive number, got {self.a}")
        if not (math.isfinite(self.b) and self.b < 0):
            raise ValueError(f"power law: b must be negative (farther = smaller), got {self.b}")

    def distance_mm(self, radius_px: float) -> float:
        if radius_px <= 0:
            raise ValueError(f"radius must be positive, got {radius_px}")
        return self.a * radius_px**self.b

    def radius_px(self, distance_mm: float) -> float:
        """Inverse of :meth:`distance_mm`: the image radius expected at ``distance_mm``."""
        if distance_mm <= 0:
            raise ValueError(f"distance must be positive, got {distance_mm}")
        return float((distance_mm / self.a) ** (1.0 / self.b))


@dataclass(frozen=True)
class Pinhole:
    """Eq. 2: d = f · R / r for a disc facing the camera."""

    focal_px: float
    radius_mm: float

    def __post_init__(self) -> None:
        if not (self.focal_px > 0 and self.radius_mm > 0):
            raise ValueError(
                f"pinhole: focal_px and radius_mm must be positive, got {self.focal_px}, "
                f"{self.radius_mm}"
            )

    def distance_mm(self, radius_px: float) -> float:
        if radius_px <= 0:
            raise ValueError(f"radius must be positive, got {radius_px}")
        return self.focal_px * self.radius_mm / radius_px

    def radius_px(self, distance_mm: float) -> float:
        """Inverse of :meth:`distance_mm`."""
        if distance_mm <= 0:
            raise ValueError(f"distance must be positive, got {distance_mm}")
        return self.focal_px * self.radius_mm / distance_mm


def lateral_offset_mm(x0: float, xc: float, r0: float, radius_mm: float) -> float:
    """Eq. 21: d_x = (x0 − x_c) / r0 · R — positive when the mark is right of the image centre."""
    if r0 <= 0:
        raise ValueError(f"radius must be positive, got {r0}")
    return (x0 - xc) / r0 * radius_mm


def tilt_from_axes(major_px: float, minor_px: float, distance_mm: float, radius_mm: float) -> float:
    """|α| in radians from the ellipse's axis ratio, by inverting eq. 4 (see module docstring).

    ``distance_mm`` is the range along the camera axis (from the semi-major axis); it only
    matters for the small perspective term R·sin α.
    """
    if major_px <= 0 or minor_px <= 0:
        raise ValueError(f"axes must be positive, got {major_px}, {minor_px}")
    q = min(minor_px / major_px, 1.0)
    k = radius_mm / distance_mm if distance_mm > 0 else 0.0
    beta = math.atan(q * k)
    c = q / math.sqrt(1.0 + (q * k) ** 2)
    return max(0.0, math.acos(min(1.0, c)) - beta)


def ellipse_axis_ratio(alpha_rad: float, distance_mm: float, radius_mm: float) -> float:
    """Eq. 4 divided by eq. 2: minor/major of a disc turned by α at ``distance_mm``."""
    return math.cos(alpha_rad) / (1.0 + (radius_mm / distance_mm) * math.sin(abs(alpha_rad)))


@dataclass(frozen=True)
class MarkEstimate:
    """A mark's position relative to the camera, in the robot frame (x forward, y left), mm.

    ``distance_mm`` is the range along the camera axis (the paper's d_yp, equal to
    ``forward_mm``); ``range_mm`` is the straight-line distance; ``bearing_rad`` is positive to
    the left; ``tilt_rad`` is |α|, the disc's turn away from facing the camera.
    """

    forward_mm: float
    left_mm: float
    distance_mm: float
    bearing_rad: float
    tilt_rad: float
    radius_px: float

    @property
    def range_mm(self) -> float:
        return math.hypot(self.forward_mm, self.left_mm)

    @property
    def lateral_mm(self) -> float:
        """The paper's d_x (eq. 21): positive to the right."""
        return -self.left_mm


def estimate(
    *,
    x_px: float,
    radius_px: float,
    minor_px: float | None = None,
    cx: float,
    model: RangeModel,
    mark_radius_mm: float,
) -> MarkEstimate:
    """Estimate a mark's position from its image centre column and radius (eqs. 19/2 and 21).

    ``radius_px`` is the semi-major axis for an ellipse; ``minor_px`` (optional) its semi-minor
    axis, used only to estimate the tilt. ``cx`` is the image centre column.
    """
    d = model.distance_mm(radius_px)
    dx = lateral_offset_mm(x_px, cx, radius_px, mark_radius_mm)
    tilt = 0.0
    if minor_px is not None and minor_px < radius_px:
        tilt = tilt_from_axes(radius_px, minor_px, d, mark_radius_mm)
    return MarkEstimate(
        forward_mm=d,
        left_mm=-dx,
        distance_mm=d,
        bearing_rad=math.atan2(-dx, d),
        tilt_rad=tilt,
        radius_px=radius_px,
    )
