"""Learning the camera's pose from the marks it sees (the horizon prior's inputs)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from marknav.missions.mission_detector import LEARN_SPAN_DEG, CameraDetector
from marknav.vision.horizon_learning import HorizonLearner

F, W, H = 590.0, 640, 480
CX, CY = (W - 1) / 2.0, (H - 1) / 2.0


def row(u: float, d: float, *, pitch: float, rise: float, roll: float) -> float:
    """The exact row of a mark centre ``rise`` mm above the camera, ``d`` mm ahead, column u."""
    return CY + F * math.tan(math.radians(pitch) - math.atan2(rise, d)) \
        + (u - CX) * math.tan(math.radians(roll))


def sightings(n: int, *, pitch: float, rise: float, roll: float, seed: int = 0,
              near: float = 800.0, far: float = 3000.0) -> list[tuple[float, float, float]]:
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        d, u = float(rng.uniform(near, far)), float(rng.uniform(40, W - 40))
        out.append((u, row(u, d, pitch=pitch, rise=rise, roll=roll) + rng.normal(0, 0.3), d))
    return out


def test_recovers_pitch_rise_and_roll_from_marks_at_several_ranges() -> None:
    learner = HorizonLearner(focal_px=F, cx=CX, cy=CY)
    for u, v, d in sightings(60, pitch=6.0, rise=100.0, roll=2.0):
        learner.add(u, v, d)
    fit = learner.fit()
    assert fit is not None and fit.rise_fitted
    assert fit.pitch_deg(cy=CY, focal_px=F) == pytest.approx(6.0, abs=0.3)
    assert fit.rise_mm(focal_px=F) == pytest.approx(100.0, abs=15.0)
    assert fit.roll_deg() == pytest.approx(2.0, abs=0.2)


def test_false_detections_off_the_marks_height_are_dropped() -> None:
    learner = HorizonLearner(focal_px=F, cx=CX, cy=CY)
    rng = np.random.default_rng(1)
    for k, (u, v, d) in enumerate(sightings(60, pitch=-5.0, rise=0.0, roll=0.0)):
        learner.add(u, float(rng.uniform(0, H)) if k % 6 == 0 else v, d)  # 1 in 6: clutter
    fit = learner.fit()
    assert fit is not None and fit.samples <= 52
    assert fit.pitch_deg(cy=CY, focal_px=F) == pytest.approx(-5.0, abs=0.3)


def test_at_one_range_the_rise_is_not_separated_from_the_pitch() -> None:
    learner = HorizonLearner(focal_px=F, cx=CX, cy=CY)
    for u, v, d in sightings(30, pitch=4.0, rise=0.0, roll=0.0, near=1500.0, far=1510.0):
        learner.add(u, v, d)
    fit = learner.fit()
    assert fit is not None and not fit.rise_fitted and fit.k_px_mm == 0.0
    assert learner.fit() is not None
    assert HorizonLearner(focal_px=F, cx=CX, cy=CY).fit() is None  # no sightings, no fit


def test_the_detector_moves_its_band_to_the_learnt_pose(mission_factory) -> None:
    m = mission_factory()  # no camera.pitch_deg: learnt
    detector = CameraDetector.for_mission(m)
    assert detector.learner is not None
    # searching wide while learning ...
    cfg = detector.config_for(W, H)
    assert cfg.suppress.horizon_tolerance_px > (F + W / 2) * math.tan(math.radians(LEARN_SPAN_DEG))
    pitched = CY + F * math.tan(math.radians(8.0))  # a camera looking 8° up: 83 px lower
    # ... but the level band is the one in use until a fit says otherwise
    assert detector.accepts(CY, H) and not detector.accepts(pitched, H)
    messages = [detector.learn([(u, v, d)], W, H)
                for u, v, d in sightings(40, pitch=8.0, rise=0.0, roll=0.0)]
    said = [t for t in messages if t is not None]
    assert said and said[0].startswith("camera pose learnt from 20 sightings: pitch +8.0°")
    assert "give camera.pitch_deg" in said[0]
    assert detector.accepts(pitched, H) and not detector.accepts(CY - 40.0, H)
    # the detector now searches the learnt band, not the wide one
    cfg = detector.config_for(W, H)
    assert cfg.suppress.horizon_row == pytest.approx(pitched, abs=3.0)


def test_a_camera_too_far_off_level_is_said_so(mission_factory) -> None:
    detector = CameraDetector.for_mission(mission_factory())
    said = [detector.learn([s], W, H) for s in sightings(20, pitch=11.0, rise=0.0, roll=0.0)]
    assert said[-1] is not None and said[-1].startswith(
        "the camera looks too far off level: pitched +11.0°")


def test_a_given_pitch_is_not_learnt(mission_factory) -> None:
    detector = CameraDetector.for_mission(mission_factory(camera={"pitch_deg": 0.0}))
    assert detector.learner is None and detector.accepts(0.0, H)
    assert detector.learn([(CX, CY, 1000.0)], W, H) is None
