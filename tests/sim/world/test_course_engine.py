"""A world file that sets a camera condition the MuJoCo engine does not model is refused for
``--engine mujoco`` (exit 2 naming the file and the key); the built-in engine takes it."""

from __future__ import annotations

from pathlib import Path

import pytest

from marknav.cli.main import main
from marknav.core.errors import InputErrors
from marknav.sim.world import Conditions, World
from marknav.sim.world.course import BUILTIN_ONLY_CONDITIONS, check_engine_conditions

#: A non-default value for each condition the MuJoCo engine does not model.
_SET = {"frame_rate_hz": 15.0, "dropped_frames": 0.1, "exposure_ms": 30.0,
        "exposure_drift": 0.2, "mark_saturation": 0.5, "mark_saturation_spread": 0.1,
        "mark_hue_spread": 3.0, "camera_pitch_deg": 2.0, "camera_roll_deg": 2.0}


def test_every_builtin_only_condition_has_a_case() -> None:
    assert set(_SET) == set(BUILTIN_ONLY_CONDITIONS)


@pytest.mark.parametrize("key", sorted(_SET))
def test_each_unmodelled_condition_is_refused_for_mujoco_only(key: str) -> None:
    world = World(conditions=Conditions(**{key: _SET[key]}))
    assert getattr(world.conditions, key) != getattr(Conditions(), key)
    check_engine_conditions(world, "builtin", "w.yaml")
    check_engine_conditions(World(), "mujoco", "w.yaml")  # defaults: nothing to refuse
    with pytest.raises(InputErrors) as caught:
        check_engine_conditions(world, "mujoco", "w.yaml")
    [error] = caught.value.errors
    assert error.file == "w.yaml" and error.field == f"conditions.{key}"
    assert key in error.message


def test_run_with_mujoco_refuses_the_world_file_naming_file_and_key(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["examples", str(tmp_path / "ex")]) == 0
    world = tmp_path / "ex" / "worlds" / "slalom-world.yaml"
    text = world.read_text(encoding="utf-8")
    world.write_text(text.replace("  wheel_slip: 0.0", "  wheel_slip: 0.0\n  exposure_ms: 30.0"),
                     encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("marknav.cli.requirements._module_present", lambda name: True)
    monkeypatch.setattr("marknav.sim.mujoco.gl._library_present", lambda name: True)
    capsys.readouterr()
    assert main(["run", str(tmp_path / "ex" / "slalom.yaml"), "--engine", "mujoco"]) == 2
    err = capsys.readouterr().err
    assert f"{world}: conditions.exposure_ms: the MuJoCo engine does not model" in err, err
    assert "Traceback" not in err
