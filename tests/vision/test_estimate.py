"""Range, offset and tilt estimation (paper eqs. 2–4, 19–21)."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from marknav.vision.estimate import (
    Pinhole,
    PowerLaw,
    ellipse_axis_ratio,
    estimate,
    lateral_offset_mm,
    tilt_from_axes,
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
