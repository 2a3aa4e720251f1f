"""A world file or a mission's ``sim.conditions`` that sets a condition of the built-in engine's
painted room is refused for ``--engine mujoco`` (exit 2 naming the file, the line and the key:
MuJoCo's room is the world's ``mujoco`` section); the built-in engine takes it. ``validate
--engine`` refuses what ``run --engine`` would, and builds a MuJoCo world's model. Randomised
MuJoCo worlds draw no built-in room."""

from __future__ import annotations

from pathlib import Path

import pytest

from marknav.cli.main import main
from marknav.core.errors import InputErrors
from marknav.sim.world import Conditions, World, generate_world
from marknav.sim.world.course import BUILTIN_ONLY_CONDITIONS, check_engine_conditions

#: A non-default value for each condition only the built-in engine draws.
_SET = {"floor": "wood", "floor_saturation": 60.0, "wall": "photo", "wall_hue": 40.0,
        "occluders": 2, "distractors": 3}


def test_every_builtin_only_condition_has_a_case() -> None:
    assert set(_SET) == set(BUILTIN_ONLY_CONDITIONS)


@pytest.mark.parametrize("key", sorted(_SET))
def test_each_builtin_room_condition_is_refused_for_mujoco_only(key: str) -> None:
    world = World(conditions=Conditions(**{key: _SET[key]}))
    assert getattr(world.conditions, key) != getattr(Conditions(), key)
    check_engine_conditions(world, "builtin", "w.yaml")
    check_engine_conditions(World(), "mujoco", "w.yaml")  # defaults: nothing to refuse
    with pytest.raises(InputErrors) as caught:
        check_engine_conditions(world, "mujoco", "w.yaml")
    [error] = caught.value.errors
    assert error.file == "w.yaml" and error.field == f"conditions.{key}"
    assert key in error.message and "mujoco section" in error.message


def _examples(tmp_path: Path, extra: str) -> tuple[Path, Path]:
    assert main(["examples", str(tmp_path / "ex")]) == 0
    world = tmp_path / "ex" / "worlds" / "slalom-world.yaml"
    text = world.read_text(encoding="utf-8")
    assert "  wheel_slip: 0.0\n" in text
    world.write_text(text.replace("  wheel_slip: 0.0\n", f"  wheel_slip: 0.0\n{extra}"),
                     encoding="utf-8")
    return tmp_path / "ex" / "slalom.yaml", world


def _line_of(path: Path, text: str) -> int:
    return next(i for i, line in enumerate(path.read_text().splitlines(), 1) if text in line)


def test_run_with_mujoco_refuses_the_world_file_naming_file_line_and_key(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
) -> None:
    mission, world = _examples(tmp_path, "  floor: wood\n")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("marknav.cli.requirements._module_present", lambda name: True)
    monkeypatch.setattr("marknav.sim.mujoco.gl._library_present", lambda name: True)
    capsys.readouterr()
    assert main(["run", str(mission), "--engine", "mujoco"]) == 2
    err = capsys.readouterr().err
    line = _line_of(world, "floor: wood")
    assert f"{world}:{line}:10: conditions.floor: the MuJoCo engine does not draw" in err, err
    assert "Traceback" not in err


def test_validate_is_engine_aware(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    mission, world = _examples(tmp_path, "  occluders: 2\n")
    assert main(["validate", str(mission)]) == 0  # the built-in engine draws it
    capsys.readouterr()
    assert main(["validate", str(mission), "--engine", "mujoco"]) == 2
    err = capsys.readouterr().err
    assert f"{world}:{_line_of(world, 'occluders: 2')}:" in err and "conditions.occluders" in err
    # a mission's own sim.conditions, through --set
    assert main(["validate", str(mission), "--engine", "mujoco",
                 "--set", "sim.conditions.wall=photo"]) == 2
    assert "sim.conditions.wall: the MuJoCo engine does not draw" in capsys.readouterr().err
    # the mission asking for MuJoCo is the same as --engine
    assert main(["validate", str(mission), "--set", "sim.engine=mujoco"]) == 2


def test_validate_for_mujoco_builds_the_model_and_reports_what_mujoco_refuses(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch,
) -> None:
    pytest.importorskip("mujoco")
    from marknav.sim.mujoco import model

    mission, world = _examples(tmp_path, "")
    assert main(["validate", str(mission), "--engine", "mujoco"]) == 0
    # whatever MuJoCo's compiler refuses is a problem of the world file, not a traceback
    real = model.build_model

    def broken(*args: object, **kwargs: object) -> model.MjcfModel:
        built = real(*args, **kwargs)  # type: ignore[arg-type]
        return model.MjcfModel(xml=built.xml.replace('type="plane"', 'type="planet"'),
                               assets=built.assets, obstacles=built.obstacles)

    monkeypatch.setattr(model, "build_model", broken)
    capsys.readouterr()
    assert main(["validate", str(mission), "--engine", "mujoco"]) == 2
    err = capsys.readouterr().err
    assert f"{world}: MuJoCo cannot build this world:" in err and "Traceback" not in err
    assert main(["validate", str(mission)]) == 0  # the built-in engine builds no model


@pytest.mark.parametrize("seed", range(6))
def test_randomised_mujoco_worlds_draw_no_builtin_room(seed: int) -> None:
    route = ["red", "green", "red", "blue"]
    mujoco = generate_world(route, seed=seed, conditions="randomised", engine="mujoco",
                            clearance_mm=300.0)
    builtin = generate_world(route, seed=seed, conditions="randomised", engine="builtin",
                             clearance_mm=300.0)
    check_engine_conditions(mujoco, "mujoco")
    assert mujoco.mujoco is not None
    # the course and every other condition are the same in both engines
    assert [(m.x_mm, m.y_mm) for m in mujoco.marks] == [(m.x_mm, m.y_mm) for m in builtin.marks]
    same = {k: v for k, v in mujoco.conditions.model_dump().items()
            if k not in BUILTIN_ONLY_CONDITIONS}
    assert same == {k: v for k, v in builtin.conditions.model_dump().items()
                    if k not in BUILTIN_ONLY_CONDITIONS}
