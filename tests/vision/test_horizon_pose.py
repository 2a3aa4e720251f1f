"""The horizon prior's band follows the camera's pose and the marks' heights."""

from __future__ import annotations

import math

import numpy as np
import pytest

from marknav.missions.mission_detector import (
    HORIZON_SLACK_PX,
    CameraDetector,
    CameraPose,
    camera_detector_config,
    horizon_band,
)
from marknav.sim.builtin_camera import CameraConfig, tilt_homography

F, W, H = 590.0, 640, 480
CY = (H - 1) / 2.0
SLACK3 = (F + W / 2.0) * math.tan(math.radians(3.0)) + HORIZON_SLACK_PX


def band(**pose: float | tuple[float, float]) -> tuple[float, float]:
    return horizon_band(CameraPose(**pose), width=W, focal_px=F,  # type: ignore[arg-type]
                        centre_row=CY, tolerance_deg=3.0)


def test_level_camera_at_mark_height_keeps_the_old_band() -> None:
    assert band() == (pytest.approx(CY - SLACK3), pytest.approx(CY + SLACK3))
    config = camera_detector_config(width=W, height=H, focal_px=F, mark_radius_mm=100.0,
                                    max_range_mm=None, horizon_tolerance_deg=3.0)
    assert config.suppress.horizon_row == pytest.approx(CY)
    assert config.suppress.horizon_tolerance_px == pytest.approx(SLACK3)


@pytest.mark.parametrize("pitch", [-8.0, -4.0, 4.0, 8.0])
def test_the_band_follows_the_pitch(pitch: float) -> None:
    lo, hi = band(pitch_deg=pitch)
    shift = F * math.tan(math.radians(pitch))  # looking up: the horizon lower in the image
    assert (lo, hi) == (pytest.approx(CY + shift - SLACK3), pytest.approx(CY + shift + SLACK3))
    # and the simulator draws a level point ahead on that row
    h = tilt_homography(CameraConfig(), pitch_deg=pitch, roll_deg=0.0)
    assert h is not None
    p = h @ np.array([CameraConfig().cx, CameraConfig().cy, 1.0])
    assert p[1] / p[2] == pytest.approx(CameraConfig().cy + shift, abs=1e-6)


def test_marks_above_the_camera_widen_the_band_upward_to_the_nearest_range() -> None:
    lo, hi = band(rise_mm=(0.0, 120.0), near_mm=300.0)
    assert hi == pytest.approx(CY + SLACK3)  # far marks: on the horizon
    assert lo == pytest.approx(CY - F * 120.0 / 300.0 - SLACK3)  # nearest: 236 px above it
    lo, hi = band(rise_mm=(-120.0, -120.0), near_mm=300.0)
    assert (lo, hi) == (pytest.approx(CY - SLACK3), pytest.approx(CY + 236.0 + SLACK3))


def test_roll_widens_the_band_by_half_the_width() -> None:
    lo, hi = band(roll_deg=5.0)
    extra = W / 2.0 * math.tan(math.radians(5.0))
    assert (lo, hi) == (pytest.approx(CY - SLACK3 - extra), pytest.approx(CY + SLACK3 + extra))


def test_the_mission_pose_reaches_the_detector(mission_factory) -> None:
    m = mission_factory(camera={"pitch_deg": -6.0, "height_mm": 300.0},
                        marks={"height_mm": [280, 420]})
    pose = CameraPose.of_mission(m)
    assert pose == CameraPose(pitch_deg=-6.0, roll_deg=0.0, rise_mm=(-20.0, 120.0),
                              near_mm=m.navigation.clearance_mm)
    cfg = CameraDetector.for_mission(m).config_for(W, H)
    lo, hi = band(pitch_deg=-6.0, rise_mm=(-20.0, 120.0), near_mm=m.navigation.clearance_mm)
    assert cfg.suppress.horizon_row == pytest.approx(0.5 * (lo + hi))
    assert cfg.suppress.horizon_tolerance_px == pytest.approx(0.5 * (hi - lo))
