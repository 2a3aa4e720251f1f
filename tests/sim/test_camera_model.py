"""One simulator-camera definition: the renderer, `calibrate --sim`, the schema's defaults and
the example missions agree, and a simulator mission without camera.range uses the camera's law."""

from __future__ import annotations

from pathlib import Path

import pytest

from marknav.core.clock import ManualClock
from marknav.missions.camera import mission_range_model
from marknav.missions.schema import Camera, PinholeRange, PowerRange, load_mission
from marknav.planning.kinematics import Pose
from marknav.sim.builtin_camera import CameraConfig, SimCamera
from marknav.sim.calibration import sim_calibration_fit
from marknav.sim.camera_model import (
    SIM_FOCAL_PX,
    SIM_HEIGHT,
    SIM_RANGE_A,
    SIM_RANGE_B,
    SIM_WIDTH,
    sim_range_law,
)
from marknav.sim.world import World
from marknav.testing.missions import make_mission
from marknav.vision.estimate import Pinhole, PowerLaw
from marknav.vision.palette import DEFAULT_PALETTE

MISSIONS = Path(__file__).resolve().parents[2] / "missions"
SIM_LAW = PowerLaw(SIM_RANGE_A, SIM_RANGE_B)


def test_calibrate_sim_measures_the_shared_law() -> None:
    fit = sim_calibration_fit()
    for d in (300.0, 500.0, 1000.0, 1500.0, 2000.0):
        r = fit.model.radius_px(d)
        assert SIM_LAW.distance_mm(r) == pytest.approx(d, rel=0.005)


def test_camera_defaults_are_the_shared_camera() -> None:
    cfg, cam = CameraConfig(), Camera()
    assert (cfg.width, cfg.height, cfg.focal_px) == (SIM_WIDTH, SIM_HEIGHT, SIM_FOCAL_PX)
    assert (cam.width, cam.height, cam.focal_px) == (SIM_WIDTH, SIM_HEIGHT, SIM_FOCAL_PX)


def test_example_missions_carry_the_simulator_camera() -> None:
    slalom = load_mission(MISSIONS / "slalom.yaml")
    assert slalom.camera.range == PowerRange(model="power", a=SIM_RANGE_A, b=SIM_RANGE_B)
    assert slalom.camera.focal_px == SIM_FOCAL_PX
    for name in ("long-course.yaml", "figure-eight.yaml"):
        m = load_mission(MISSIONS / name)
        assert m.camera.focal_px == SIM_FOCAL_PX
        rng = m.camera.range
        if isinstance(rng, PinholeRange):
            assert rng.focal_px == SIM_FOCAL_PX
        elif "range" in m.camera.model_fields_set:
            assert (rng.a, rng.b) == (SIM_RANGE_A, SIM_RANGE_B)


def test_sim_law_scales_with_focal_length_and_mark_radius() -> None:
    assert sim_range_law() == (SIM_RANGE_A, SIM_RANGE_B)
    a, b = sim_range_law(SIM_FOCAL_PX / 2, 150.0)
    small = PowerLaw(a, b)
    # half the focal length, 1.5× the radius: the same distance shows 0.75× the radius
    assert small.distance_mm(0.75 * SIM_LAW.radius_px(1200.0)) == pytest.approx(1200.0)


def _sim_camera() -> SimCamera:
    clock = ManualClock()
    return SimCamera(World(), DEFAULT_PALETTE, pose_fn=lambda: Pose(0, 0, 0), clock=clock)


def test_mission_without_range_uses_the_simulated_cameras_law() -> None:
    cam = _sim_camera()
    mission = make_mission()
    del_range = mission.model_copy(update={"camera": Camera(width=640, height=480,
                                                            focal_px=590)})
    model, source = mission_range_model(del_range, cam)
    assert model == SIM_LAW and "simulated camera" in source
    # Without a simulated camera: the schema's default, the paper's eq. 19.
    model, source = mission_range_model(del_range, object())
    assert model == PowerLaw(58958.0, -0.9434) and "paper" in source
    # Written in the mission: the mission's.
    model, source = mission_range_model(mission, cam)
    assert model == Pinhole(590.0, 100.0) and source == "mission camera.range"
    # Intrinsics and no range: the pinhole law of their focal length.
    with_intr = make_mission(camera={"width": 640, "height": 480,
                                     "intrinsics": {"fx": 600, "fy": 604, "cx": 330,
                                                    "cy": 238, "dist": [-0.2, 0.05, 0, 0]}})
    with_intr = with_intr.model_copy(update={"camera": with_intr.camera.model_copy()})
    with_intr.camera.__pydantic_fields_set__.discard("range")
    model, source = mission_range_model(with_intr, cam)
    assert model == Pinhole(602.0, 100.0) and "intrinsics" in source
