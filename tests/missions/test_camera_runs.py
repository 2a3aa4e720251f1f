"""Closed-loop runs with the camera model: a wrong range law is learnt while driving, and small
cameras (the paper's webcam class) drive the slalom, both through randomised webcam lenses."""

from __future__ import annotations

from pathlib import Path

import pytest

from marknav.cli.main import main
from marknav.runs.loop.run import RunRequest, execute, load
from marknav.sim.camera_model import SIM_RANGE_A, SIM_RANGE_B
from marknav.vision.estimate import PowerLaw

SLALOM = Path(__file__).resolve().parents[2] / "missions" / "slalom.yaml"
TRUE = PowerLaw(SIM_RANGE_A, SIM_RANGE_B)


def _rel(law: dict[str, float], d: float) -> float:
    return PowerLaw(law["a"], law["b"]).distance_mm(TRUE.radius_px(d)) / d - 1.0


@pytest.mark.slow
def test_the_papers_law_on_the_simulated_camera_is_learnt(tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]
                                                         ) -> None:
    """Eq. 19 of the paper reads 26 % too far at 1 m on this camera; learnt while driving."""
    text = SLALOM.read_text().replace("range: {model: power, a: 59752, b: -1.00242}",
                                      "range: {model: power, a: 58958, b: -0.9434}\n"
                                      "  learn_range: true")
    text = text.replace("world: worlds/", f"world: {SLALOM.parent}/worlds/")
    mission = tmp_path / "paper-law.yaml"
    mission.write_text(text)
    report = tmp_path / "report.json"
    assert main(["run", str(mission), "--world", "random", "--seed", "103",
                 "--report", str(report)]) == 0
    out = capsys.readouterr().out
    assert "range law learnt from" in out and "range: {model: power, a: " in out
    import json

    law = json.loads(report.read_text())["range_law"]
    assert law["source"] == "mission camera.range" and law["started_from"]["b"] == -0.9434
    assert abs(_rel(law["started_from"], 1000.0)) > 0.2
    # From 26 % (1 m) and 20 % (2 m) too far to within 5 % where the bypass is decided, by
    # the third mark: the randomised world's wheel acceleration (a real Create's) leaves fewer
    # steady stretches to learn from before the second.
    third = law["at"][2]  # the law in use when the third mark was passed
    for d in (600.0, 1000.0, 1500.0):
        assert abs(_rel(third, d)) < 0.05
    assert law["rejected"] <= law["steps"]


@pytest.mark.slow
@pytest.mark.parametrize(("width", "height", "focal", "seed"),
                         [(320, 240, 295.0, 7), (160, 120, 147.5, 5)])
def test_small_cameras_drive_the_slalom(width: int, height: int, focal: float, seed: int) -> None:
    mission = load(str(SLALOM))
    camera = mission.camera.model_copy(update={"width": width, "height": height,
                                               "focal_px": focal, "learn_range": True})
    camera.__pydantic_fields_set__.discard("range")  # the simulated camera's own law
    mission = mission.model_copy(update={"camera": camera})
    result = execute(RunRequest(mission=mission, seed=seed, generate_world=True, randomise=True))
    env = result.environment
    assert env.world.conditions.lens.distorted  # type: ignore[attr-defined]
    rep = result.report
    assert (rep.outcome, rep.collisions) == ("success", 0), rep.reason
    assert all(w.passed_on == w.side for w in rep.waypoints)
    assert rep.range_law is not None
    assert rep.range_law["source"] == "the simulated camera's own law"
