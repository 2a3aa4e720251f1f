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

**A disc standing at camera height** (paper §3.1; :func:`estimate_disc`, what perception uses).
The disc's vertical diameter lies on the vertical through its centre, whatever its turn about
the vertical axis, and the disc is symmetric about the camera's horizontal plane, so its image is
an ellipse with one axis upright whose vertical semi-axis is h = f·R / √(Z² − (R·sin ψ)²) ≈ f·R/Z
(Z the centre's depth along the camera axis, ψ the disc's turn from the image plane: the
correction is under 0.5 % beyond 1 m for ψ up to 85°). Turning the disc by α (from facing the
camera) shrinks only the horizontal semi-axis, and looking at it off the axis (bearing β)
stretches it by 1/cos β: w ≈ h·cos α / cos β. So the **range is read from h**, not from the
longest axis (which for a disc facing the camera off to the side is w, 1/cos β too long: 10 %
at the edge of a 57° view), and |α| = arccos(w·cos β / h) (the full width averages eq. 3's near
and far halves, so eq. 4's perspective term drops out: within 1° beyond 0.5 m). The rim's
horizontal ends lie on the horizontal diameter and subtend equal angles about the centre's ray
for a disc facing the camera: the **bearing** is the mean of the ends' angles,
atan((u ± w − c_x)/f), and the lateral offset Z·tan β (eq. 21 on the axis: (u − c_x)·R/h).

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


def upright_extents(axes: tuple[float, float], angle_deg: float) -> tuple[float, float]:
    """(half-width, half-height) in px of an ellipse with semi-axes ``axes`` (first, second),
    the first at ``angle_deg`` from +u towards +v: for a disc's upright ellipse (a level camera)
    its horizontal and vertical semi-axes; a small camera roll changes them by (1 − cos roll)."""
    a, b = axes
    t = math.radians(angle_deg)
    c, s = math.cos(t), math.sin(t)
    return math.hypot(a * c, b * s), math.hypot(a * s, b * c)


def estimate_disc(
    *,
    x_px: float,
    axes: tuple[float, float],
    angle_deg: float,
    cx: float,
    model: RangeModel,
    mark_radius_mm: float,
    focal_px: float | None = None,
) -> MarkEstimate:
    """A vertical disc's position from its image ellipse (centre column ``x_px``, semi-axes
    ``axes`` with the first at ``angle_deg``): range from the vertical semi-axis, bearing from
    the angles of the rim's horizontal ends (with ``focal_px``; without, eq. 21 with the
    vertical semi-axis), |α| from the axis ratio corrected for the off-axis stretch (see the
    module docstring). Exact projections: range within 2 % at 0.5 m and 0.5 % beyond 1 m for
    turns up to 60° (the neglected √(Z² − (R·sin ψ)²)). ``radius_px`` of the result is the
    vertical semi-axis."""
    w, h = upright_extents(axes, angle_deg)
    if not (w > 0 and h > 0):
        raise ValueError(f"axes must be positive, got {axes}")
    d = model.distance_mm(h)
    if focal_px is not None and focal_px > 0:
        beta = 0.5 * (math.atan((x_px - w - cx) / focal_px) + math.atan((x_px + w - cx) / focal_px))
        right = d * math.tan(beta)
        cos_beta = math.cos(beta)
    else:
        right = lateral_offset_mm(x_px, cx, h, mark_radius_mm)
        cos_beta = 1.0
    tilt = math.acos(min(1.0, w * cos_beta / h))
    return MarkEstimate(forward_mm=d, left_mm=-right, distance_mm=d,
                        bearing_rad=math.atan2(-right, d), tilt_rad=tilt, radius_px=h)
