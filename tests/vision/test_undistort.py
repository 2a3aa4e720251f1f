"""Undistorting detections: points, ellipses and round marks (marknav.vision.undistort)."""

from __future__ import annotations

import math
from dataclasses import replace

import cv2
import numpy as np
import pytest

from marknav.vision.detect import Mark
from marknav.vision.undistort import Intrinsics, ellipse_outline, undistort_mark, undistort_points

LENS = Intrinsics(fx=590.0, fy=588.0, cx=331.0, cy=236.0, dist=(-0.35, 0.09, 0.0015, -0.001))


def _distort(points: np.ndarray, intr: Intrinsics) -> np.ndarray:
    norm = np.stack([(points[:, 0] - intr.cx) / intr.fx, (points[:, 1] - intr.cy) / intr.fy,
                     np.ones(len(points))], axis=1)
    out, _ = cv2.projectPoints(norm, np.zeros(3), np.zeros(3), intr.matrix, intr.coefficients)
    return out.reshape(-1, 2)


def test_points_are_the_inverse_of_opencvs_projection() -> None:
    ideal = np.array([[331.0, 236.0], [5.0, 5.0], [630.0, 470.0], [100.0, 400.0]])
    back = undistort_points(_distort(ideal, LENS), LENS)
    assert np.abs(back - ideal).max() < 1e-3
    plain = Intrinsics(590.0, 590.0, 319.5, 239.5)
    assert np.array_equal(undistort_points(ideal, plain), ideal)


def test_intrinsics_check_and_scale() -> None:
    with pytest.raises(ValueError, match="4, 5 or 8"):
        Intrinsics(500, 500, 1, 1, (0.1, 0.2))
    with pytest.raises(ValueError, match="positive"):
        Intrinsics(0, 500, 1, 1)
    half = LENS.scaled(0.5, 0.5)
    assert (half.fx, half.fy) == (295.0, 294.0)
    assert half.cx == pytest.approx((331.0 + 0.5) / 2 - 0.5)
    assert half.dist == LENS.dist and LENS.focal_px == 589.0


def _mark(pts: np.ndarray, shape: str) -> Mark:
    (x, y), (w, h), angle = cv2.fitEllipse(pts.astype(np.float32))
    major, minor = 0.5 * max(w, h), 0.5 * min(w, h)
    if w < h:
        angle += 90.0
    return Mark(colour="red", x=x, y=y, radius=major, axes=(major, minor),
                angle_deg=angle % 180.0 if shape == "ellipse" else 0.0, shape=shape,  # type: ignore[arg-type]
                score=1.0)


@pytest.mark.parametrize(("shape", "u", "r", "q"), [
    (shape, u, r, 1.0) for shape in ("ellipse", "circle")
    for u, r in ((60.0, 30.0), (560.0, 70.0), (331.0, 50.0))
] + [("ellipse", 120.0, 40.0, 0.6)])  # the detector calls only round marks circles
def test_a_distorted_mark_is_restored(shape: str, u: float, r: float, q: float) -> None:
    """An ideal ellipse (semi-axes r·q across, r upright), seen through the lens, detected,
    undistorted: its centre and radius come back (the radius within 1 %)."""
    ideal = ellipse_outline(u, LENS.cy, (r, r * q), 90.0, 180)
    seen = _mark(_distort(ideal, LENS), shape)
    if u < 100:
        assert seen.radius < 0.95 * r  # the lens shrank it: the raw range reads far
    back = undistort_mark(seen, LENS)
    assert back.radius == pytest.approx(r, rel=0.01)
    assert math.hypot(back.x - u, back.y - LENS.cy) < 0.5
    assert back.axes[1] == pytest.approx(r * q, rel=0.02)
    assert back.colour == "red" and back.shape == shape


@pytest.mark.parametrize(("u", "r"), [(60.0, 21.0), (91.0, 21.6), (600.0, 26.0), (150.0, 40.0)])
@pytest.mark.parametrize("rounder", [0.0, 0.5, 1.0])
def test_a_round_mark_detected_rounder_than_the_lens_made_it_keeps_its_radius(
        u: float, r: float, rounder: float) -> None:
    """Off-axis, the lens squashes a round mark radially about three times as much as
    tangentially; small marks come out of the detector rounder than that (issue 13: 20.6 × 20.1
    px where the lens gives ~20.6 × 19.3). Undistorting such a radial axis stretches it past the
    true radius; the radius must still come back within 1 % (it is read along the stretch)."""
    seen = _mark(_distort(ellipse_outline(u, LENS.cy, (r, r), 0.0, 180), LENS), "circle")
    squash = seen.axes[0] - seen.axes[1]
    assert squash > 0.04 * r  # the lens did squash it
    detected = replace(seen, axes=(seen.axes[0], seen.axes[1] + rounder * squash))
    back = undistort_mark(detected, LENS)
    assert back.radius == pytest.approx(r, rel=0.01)
    assert back.axes[0] == back.radius and back.axes[1] <= back.radius


def test_no_distortion_no_change() -> None:
    m = Mark(colour="red", x=10.0, y=20.0, radius=5.0, axes=(5.0, 4.0), angle_deg=30.0,
             shape="ellipse", score=0.9)
    assert undistort_mark(m, Intrinsics(500, 500, 320, 240)) is m
