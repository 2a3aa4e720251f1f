"""The detector a mission's camera calls for (``camera.detect``): minimum radius from the
farthest range that matters, the horizon prior from the principal point and the pitch/roll
tolerance, and perception building it."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest

from marknav.behaviours import keys
from marknav.behaviours.perception import Perception
from marknav.cli.main import main
from marknav.missions.mission_detector import (
    HORIZON_SLACK_PX,
    LEARN_SPAN_DEG,
    ROBOT_FLOOR_PX,
    CameraDetector,
    mission_detector,
)
from marknav.missions.schema import Mission, load_mission
from marknav.testing import FakeRobot
from marknav.vision.sources import Frame

MISSION = """\
name: t
route: [red]
marks: {radius_mm: 100, colours: {red: {hue: [170, 10], side: left}}}
camera:
  focal_px: 590
DETECT"""


def _mission(tmp_path: Path, detect: str = "") -> Path:
    p = tmp_path / "m.yaml"
    p.write_text(MISSION.replace("DETECT", detect))
    return p


def test_the_default_is_the_horizon_band_with_the_fixed_minimum(tmp_path: Path) -> None:
    cfg = CameraDetector.for_mission(load_mission(_mission(tmp_path))).config_for(640, 480)
    assert cfg.shape.min_radius_px == 5.0 and cfg.suppress.horizon_row == pytest.approx(239.5)


def test_a_farthest_range_derives_the_minimum_radius_and_the_horizon_band(
        tmp_path: Path) -> None:
    mission = load_mission(_mission(tmp_path, "  detect: {max_range_mm: 6000}\n"))
    cfg = CameraDetector.for_mission(mission).config_for(640, 480)
    assert cfg.shape.min_radius_px == pytest.approx(0.9 * 590 * 100 / 6000)  # 8.85 px at 6 m
    assert cfg.suppress.horizon_row == pytest.approx(239.5)
    t = math.tan(math.radians(3.0))
    band = (590 + 320) * t + HORIZON_SLACK_PX
    # No camera.pitch_deg: the pose is learnt, so the detector searches wide, and the level
    # band is the one whose marks are used until a fit moves it.
    wide = (590 + 320) * math.tan(math.radians(LEARN_SPAN_DEG)) + HORIZON_SLACK_PX
    assert cfg.suppress.horizon_tolerance_px == pytest.approx(wide)
    det = CameraDetector.for_mission(mission)
    assert det.accepts(239.5 + band - 0.1, 480) and not det.accepts(239.5 + band + 0.1, 480)
    # A given pitch: its band, searched and used
    level = load_mission(_mission(tmp_path, "  detect: {max_range_mm: 6000}\n  pitch_deg: 0\n"))
    cfg = CameraDetector.for_mission(level).config_for(640, 480)
    assert cfg.suppress.horizon_tolerance_px == pytest.approx(band)


def test_a_half_size_frame_gets_the_camera_scaled_to_it(tmp_path: Path) -> None:
    mission = load_mission(_mission(tmp_path, "  detect: {max_range_mm: 6000}\n"))
    det = CameraDetector.for_mission(mission, horizon_row=250.0)
    full, half = det.config_for(640, 480), det.config_for(320, 240)
    assert half.shape.min_radius_px == pytest.approx(
        max(ROBOT_FLOOR_PX, full.shape.min_radius_px / 2))
    assert half.suppress.horizon_row == pytest.approx((250.0 + 0.5) / 2 - 0.5)
    assert half.suppress.horizon_tolerance_px < full.suppress.horizon_tolerance_px


def test_null_settings_give_the_plain_detector(tmp_path: Path) -> None:
    mission = load_mission(_mission(
        tmp_path, "  detect: {max_range_mm: null, horizon_tolerance_deg: null}\n"))
    cfg = CameraDetector.for_mission(mission).config_for(640, 480)
    assert cfg.suppress.horizon_row is None and cfg.shape.min_radius_px == 5.0


def test_the_faint_floor_comes_from_the_mission(tmp_path: Path) -> None:
    """``camera.detect.min_chroma_contrast`` (default 50; 0: off): a dark, slightly blue disc
    (chroma 23 against its grey wall) is dropped by default and reported with the floor off."""
    image = np.full((480, 640, 3), 120, np.uint8)
    cv2.circle(image, (200, 240), 30, (80, 50, 45), -1)
    cv2.circle(image, (420, 240), 30, (40, 40, 230), -1)
    palette_yaml = "marks: {radius_mm: 100, colours: {red: {hue: [170, 10], side: left}, " \
        "blue: {hue: [95, 130], side: right}}}\n"
    text = MISSION.replace(MISSION.splitlines()[2] + "\n", palette_yaml)
    found = {}
    for detect in ("", "  detect: {min_chroma_contrast: 0}\n"):
        p = tmp_path / "m.yaml"
        p.write_text(text.replace("DETECT", detect))
        mission = load_mission(p)
        found[detect] = sorted(m.colour for m in CameraDetector.for_mission(mission).detect(image))
        assert CameraDetector.for_mission(mission).config_for(640, 480).shape.min_contrast == \
            (0.0 if detect else 50.0)
    assert found[""] == ["red"]
    assert found["  detect: {min_chroma_contrast: 0}\n"] == ["blue", "red"]


def test_the_reading_budget_comes_from_the_mission(tmp_path: Path) -> None:
    """``camera.detect.max_readings`` (default 400): with a budget of one blob, of three red
    discs on the horizon only the largest is read; frames of another size keep it."""
    image = np.full((480, 640, 3), 128, np.uint8)
    for x, r in ((120, 14), (320, 40), (520, 18)):
        cv2.circle(image, (x, 240), r, (0, 0, 230), -1, cv2.LINE_AA)
    found = {}
    for budget in (None, 1):
        detect = "" if budget is None else f"  detect: {{max_readings: {budget}}}\n"
        camera = CameraDetector.for_mission(load_mission(_mission(tmp_path, detect)))
        assert camera.config_for(640, 480).shape.max_blobs == (budget or 400)
        assert camera.config_for(320, 240).shape.max_blobs == (budget or 400)
        found[budget] = [round(m.x) for m in camera.detect(image)]
    assert sorted(found[None]) == [120, 320, 520]
    assert found[1] == [320]


def test_marks_off_the_horizon_and_too_far_are_not_reported(tmp_path: Path) -> None:
    mission = load_mission(_mission(tmp_path, "  detect: {max_range_mm: 6000}\n"))
    image = np.full((480, 640, 3), 128, np.uint8)
    cv2.circle(image, (150, 240), 25, (0, 0, 255), -1)  # on the horizon
    cv2.circle(image, (500, 60), 25, (0, 0, 255), -1)  # 10° above it
    cv2.circle(image, (320, 240), 6, (0, 0, 255), -1)  # a mark beyond 6 m
    found = CameraDetector.for_mission(mission).detect(image)
    assert [(m.colour, round(m.x)) for m in found] == [("red", 150)]


@pytest.mark.parametrize(("detect", "message"), [
    ("  detect: {max_range_mm: -5}\n", "6:26: camera.detect.max_range_mm:"),
    ("  detect: {horizon_tolerance_deg: 45}\n", "camera.detect.horizon_tolerance_deg:"),
    ("  detect: {horizon: 3}\n", "camera.detect.horizon:"),
    ("  detect: {min_chroma_contrast: -3}\n", "6:33: camera.detect.min_chroma_contrast:"),
    ("  detect: {max_readings: 0}\n", "6:26: camera.detect.max_readings:"),
    ("  detect: {max_readings: 2.5}\n", "6:26: camera.detect.max_readings:"),
])
def test_bad_detect_settings_name_the_line_and_field(tmp_path: Path, detect: str, message: str,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["validate", str(_mission(tmp_path, detect))]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_perception_reports_only_the_marks_the_camera_detector_accepts(
        blackboard: object, manual_clock: object,
        mission_factory: Callable[..., Mission]) -> None:
    image = np.full((480, 640, 3), 120, np.uint8)
    cv2.circle(image, (200, 240), 30, (0, 0, 230), -1)  # on the horizon
    cv2.circle(image, (480, 70), 30, (0, 0, 230), -1)  # a red lamp far above it
    frames = [Frame(image=image, t=0.0, index=0)]
    counts = []
    for detect in ({}, {"horizon_tolerance_deg": None}):
        perception = Perception()
        perception.setup(robot=FakeRobot(clock=manual_clock), clock=manual_clock,
                         mission=mission_factory(camera={"detect": detect}),
                         camera=_Frames(frames))
        perception.tick_once()
        counts.append(len(perception.blackboard.get(keys.MARKS)))
    assert counts == [1, 2]


class _Frames:
    name = "frames"

    def __init__(self, frames: list[Frame]) -> None:
        self.frames = frames

    def read(self) -> Frame | None:
        return self.frames[0]

    def close(self) -> None:
        pass


ONE_DETECTOR = """\
name: t
route: [red]
marks: {radius_mm: 100, colours: {red: {hue: [170, 10], side: left}}}
camera:
  focal_px: 590
  intrinsics: {fx: 590, fy: 590, cx: 319.5, cy: 300}
  detect: {max_range_mm: 5000, horizon_tolerance_deg: 2, min_chroma_contrast: 30,
           max_readings: 50, tint_limit: 0.1}
"""


def test_run_and_detect_build_one_detector_from_the_mission(
        tmp_path: Path, blackboard: object, manual_clock: object,
        capsys: pytest.CaptureFixture[str]) -> None:
    """Perception (``marknav run``) and ``marknav detect --mission`` take the detector from
    :func:`mission_detector`: the same config (every ``camera.detect`` setting and the horizon
    row of the intrinsics' principal point, 300 here) and the same marks."""
    path = tmp_path / "m.yaml"
    path.write_text(ONE_DETECTOR)
    mission = load_mission(path)
    image = np.full((480, 640, 3), 120, np.uint8)
    cv2.circle(image, (200, 300), 30, (0, 0, 230), -1)  # on the principal point's row
    cv2.circle(image, (480, 240), 30, (0, 0, 230), -1)  # on the image centre's row: 60 px off
    perception = Perception()
    perception.setup(robot=FakeRobot(clock=manual_clock), clock=manual_clock, mission=mission,
                     camera=_Frames([Frame(image=image, t=0.0, index=0)]))
    perception.tick_once()
    robot_cfg = perception._detector.config_for(640, 480)
    expected = mission_detector(mission).config_for(640, 480)
    assert robot_cfg == expected
    assert expected.suppress.horizon_row == pytest.approx(300.0)
    assert expected.shape.min_contrast == 30.0 and expected.shape.max_blobs == 50
    assert expected.photometry.tint_limit == 0.1
    assert expected.shape.min_radius_px == pytest.approx(0.9 * 590 * 100 / 5000)
    seen = perception.blackboard.get(keys.MARKS)
    assert [round(m.x_px) for m in seen] == [200]

    frame = tmp_path / "frame.png"
    cv2.imwrite(str(frame), image)
    assert main(["detect", str(frame), "--mission", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    marks = out[0]["marks"]
    assert [(m["colour"], round(m["x"]), round(m["y"])) for m in marks] == [("red", 200, 300)]
    assert [m.to_dict()["x"] for m in mission_detector(mission).detect(image)] == \
        [m["x"] for m in marks]
    # Without --mission the plain detector finds both.
    assert main(["detect", str(frame), "--json"]) == 0
    assert len(json.loads(capsys.readouterr().out)[0]["marks"]) == 2
