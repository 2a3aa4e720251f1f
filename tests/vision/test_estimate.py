"""Range, offset and tilt estimation (paper eqs. 2–4, 19–21)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from marknav.vision.estimate import (
    Pinhole,
    PowerLaw,
    ellipse_axis_ratio,
    estimate,
    estimate_disc,
    lateral_offset_mm,
    tilt_from_axes,
    upright_extents,
)


def test_power_law_is_eq_19() -> None:
    law = PowerLaw(58958, -0.9434)
    assert law.distance_mm(36) == pytest.approx(58958 * 36**-0.9434)
    assert law.distance_mm(62) == pytest.approx(1201.1, abs=0.1)
    assert law.radius_px(law.distance_mm(50.0)) == pytest.approx(50.0)


def test_pinhole_is_eq_2() -> None:
    cam = Pinhole(focal_px=590, radius_mm=100)
    assert cam.distance_mm(59) == pytest.approx(1000.0)
    assert cam.radius_px(2000) == pytest.approx(29.5)


@pytest.mark.parametrize(
    ("a", "b", "message"),
    [(0, -1, "a must be a positive"), (5, 0.5, "b must be negative"), (float("nan"), -1, "a must")],
)
def test_power_law_rejects_nonsense(a: float, b: float, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        PowerLaw(a, b)


def test_radius_must_be_positive() -> None:
    with pytest.raises(ValueError, match="radius must be positive"):
        Pinhole(590, 100).distance_mm(0)


def test_lateral_offset_eq_21_sign_and_scale() -> None:
    # A mark whose centre is two of its radii right of the image centre is 2R to the right.
    assert lateral_offset_mm(420, 320, 50, 100) == pytest.approx(200.0)
    assert lateral_offset_mm(220, 320, 50, 100) == pytest.approx(-200.0)


def test_estimate_puts_right_offset_on_negative_left() -> None:
    est = estimate(x_px=420, radius_px=59, cx=320, model=Pinhole(590, 100), mark_radius_mm=100)
    assert est.forward_mm == pytest.approx(1000.0)
    assert est.left_mm == pytest.approx(-100 / 59 * 100)
    assert est.lateral_mm == pytest.approx(100 / 59 * 100)
    assert est.bearing_rad < 0  # to the right
    assert est.tilt_rad == 0.0


def test_estimate_matches_pinhole_geometry_of_an_off_axis_mark() -> None:
    # A disc at (forward 1500, left 400) facing the camera plane: centre column and radius
    # from the pinhole model; the estimate must invert it exactly.
    f, radius, cx = 590.0, 100.0, 320.0
    fwd, left = 1500.0, 400.0
    x_px = cx - f * left / fwd
    r_px = f * radius / fwd
    est = estimate(x_px=x_px, radius_px=r_px, cx=cx, model=Pinhole(f, radius),
                   mark_radius_mm=radius)
    assert est.forward_mm == pytest.approx(fwd)
    assert est.left_mm == pytest.approx(left)
    assert est.range_mm == pytest.approx(math.hypot(fwd, left))


@given(
    alpha=st.floats(min_value=0.0, max_value=math.radians(80)),
    distance=st.floats(min_value=300.0, max_value=4000.0),
    radius=st.floats(min_value=30.0, max_value=200.0),
)
def test_tilt_inverts_eq_4(alpha: float, distance: float, radius: float) -> None:
    q = ellipse_axis_ratio(alpha, distance, radius)
    major = 590 * radius / distance
    got = tilt_from_axes(major, q * major, distance, radius)
    assert got == pytest.approx(alpha, abs=1e-9)


def test_eq_3_horizontal_radius_matches_ratio() -> None:
    # eq. 3: r = f R cos α / (d + R sin α); its ratio to eq. 2 is eq. 4 / (f R / d)
    f, radius, d, alpha = 590.0, 100.0, 1000.0, math.radians(30)
    r3 = f * radius * math.cos(alpha) / (d + radius * math.sin(alpha))
    assert r3 / (f * radius / d) == pytest.approx(ellipse_axis_ratio(alpha, d, radius))


def test_estimate_reports_tilt_from_ellipse() -> None:
    d, radius = 1200.0, 100.0
    major = 590 * radius / d
    minor = major * ellipse_axis_ratio(math.radians(40), d, radius)
    est = estimate(x_px=320, radius_px=major, minor_px=minor, cx=320, model=Pinhole(590, radius),
                   mark_radius_mm=radius)
    assert math.degrees(est.tilt_rad) == pytest.approx(40.0, abs=1e-6)
    # The range uses the semi-major axis, so tilt does not bias it.
    assert est.distance_mm == pytest.approx(d)


# --------------------------------------------------------------- a disc standing at camera height

FOCAL = 579.4  # a 45° vertical field of view at 640×480
CX = 319.5


def _project_disc(x_mm: float, z_mm: float, yaw: float, radius_mm: float = 100.0,
                  ) -> tuple[float, tuple[float, float], float]:
    """The exact pinhole image of a vertical disc centred at (x, 0, z) (camera height), turned by
    ``yaw`` from facing the camera's ray, fitted with an ellipse: (u, axes, angle_deg)."""
    import cv2

    facing = math.atan2(x_mm, z_mm) + yaw  # turn of the disc's plane from the image plane
    tx, tz = math.cos(facing), -math.sin(facing)  # horizontal unit vector in the disc's plane
    phi = np.linspace(0.0, 2.0 * math.pi, 720, endpoint=False)
    px = x_mm + radius_mm * np.cos(phi) * tx
    py = radius_mm * np.sin(phi)
    pz = z_mm + radius_mm * np.cos(phi) * tz
    pts = np.stack([CX + FOCAL * px / pz, 239.5 + FOCAL * py / pz], axis=1)
    (u, _v), (w, h), angle = cv2.fitEllipse(pts.astype(np.float32))
    major, minor = 0.5 * max(w, h), 0.5 * min(w, h)
    if w < h:
        angle += 90.0
    return float(u), (float(major), float(minor)), float(angle) % 180.0


def _cases() -> list[tuple[float, float, float]]:
    out = []
    for z in (500.0, 1000.0, 2000.0, 3000.0):
        for bearing_deg in (-24.0, -12.0, 0.0, 12.0, 24.0):  # inside the 57° horizontal view
            for yaw_deg in (-60.0, -30.0, 0.0, 20.0, 45.0, 60.0):
                out.append((z * math.tan(math.radians(bearing_deg)), z, math.radians(yaw_deg)))
    return out


def test_a_vertical_disc_is_ranged_by_its_upright_semi_axis() -> None:
    """Exact projections of discs at 0.5–3 m, up to 24° off the axis, turned up to 60°: forward
    distance and lateral offset within 2.5 % of the range at 0.5 m and 0.6 % from 1 m, the turn
    within 1°, where the longest axis reads a mark facing the camera 24° off the axis 8 % short."""
    model = Pinhole(focal_px=FOCAL, radius_mm=100.0)
    for x, z, yaw in _cases():
        u, axes, angle = _project_disc(x, z, yaw)
        est = estimate_disc(x_px=u, axes=axes, angle_deg=angle, cx=CX, model=model,
                            mark_radius_mm=100.0, focal_px=FOCAL)
        limit = 0.025 if z < 1000.0 else 0.006
        assert abs(est.forward_mm - z) <= limit * z
        assert abs(est.left_mm + x) <= limit * math.hypot(x, z)
        assert est.tilt_rad == pytest.approx(abs(yaw), abs=math.radians(1.0))
    x, z = 2000.0 * math.tan(math.radians(24.0)), 2000.0
    u, axes, angle = _project_disc(x, z, 0.0)
    longest = estimate(x_px=u, radius_px=axes[0], cx=CX, model=model, mark_radius_mm=100.0)
    assert longest.forward_mm < 0.93 * z


def test_upright_extents_follow_the_axis_angle() -> None:
    assert upright_extents((10.0, 6.0), 0.0) == pytest.approx((10.0, 6.0))
    assert upright_extents((10.0, 6.0), 90.0) == pytest.approx((6.0, 10.0))
    w, h = upright_extents((10.0, 6.0), 45.0)
    assert w == pytest.approx(h) and 6.0 < h < 10.0


def test_without_a_focal_length_the_offset_is_eq_21_with_the_upright_semi_axis() -> None:
    est = estimate_disc(x_px=420.0, axes=(22.0, 20.0), angle_deg=0.0, cx=320.0,
                        model=Pinhole(focal_px=600.0, radius_mm=100.0), mark_radius_mm=100.0)
    assert est.distance_mm == pytest.approx(600.0 * 100.0 / 20.0)
    assert est.left_mm == pytest.approx(-(420.0 - 320.0) / 20.0 * 100.0)
    assert est.radius_px == pytest.approx(20.0)
