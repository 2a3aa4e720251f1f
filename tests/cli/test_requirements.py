"""Each option's requirements are checked before the command does anything (exit 2, no run
folder), and every mission argument takes a built-in example's name."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from marknav.cli.main import main
from marknav.cli.requirements import MATPLOTLIB, MUJOCO, RERUN, missing

ROOT = Path(__file__).resolve().parents[2]
FRAME = ROOT / "tests" / "data" / "sim-frames" / "seed54-pole-floor.png"


def _without(monkeypatch: pytest.MonkeyPatch, module: str) -> None:
    """``import module`` fails, as it does where the package is not installed."""
    monkeypatch.setitem(sys.modules, module, None)


def _no_run_started(monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(*_a: object, **_k: object) -> None:
        raise AssertionError("the run started")

    monkeypatch.setattr("marknav.runs.loop.run.execute", refuse)
    monkeypatch.setattr("marknav.runs.loop.run.prepare", refuse)


@pytest.mark.parametrize(("argv", "module", "words"), [
    (["run", "slalom", "--plot", "x.png"], "matplotlib", "--plot: needs matplotlib"),
    (["run", "slalom", "--record", "x.mcap"], "mcap", "--record: needs the MCAP writer"),
    (["run", "slalom", "--foxglove"], "foxglove", "--foxglove: needs the Foxglove SDK"),
    (["run", "slalom", "--engine", "mujoco"], "mujoco", "--engine mujoco: needs MuJoCo"),
    (["tune", "slalom", "--trials", "2", "--plot", "t.png"], "matplotlib",
     "--plot: needs matplotlib"),
    (["view", "some-run"], "rerun", "view: needs the Rerun SDK"),
])
def test_a_missing_extra_is_refused_before_anything_runs(
    argv: list[str], module: str, words: str, tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    _without(monkeypatch, module)
    _no_run_started(monkeypatch)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert words in err and "pip install 'marknav[" in err, err
    assert list(tmp_path.iterdir()) == []  # no run folder, no file


def test_mujoco_without_its_opengl_library_is_refused_naming_the_package(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    monkeypatch.setattr("marknav.sim.mujoco.gl._library_present", lambda name: False)
    monkeypatch.setattr("marknav.cli.requirements._module_present", lambda name: True)
    _no_run_started(monkeypatch)
    assert main(["run", "slalom", "--engine", "mujoco"]) == 2
    err = capsys.readouterr().err
    assert "--engine mujoco" in err and "apt-get install -y libosmesa6" in err, err
    assert list(tmp_path.iterdir()) == []


def test_a_missions_own_mujoco_engine_is_checked_before_its_run_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["examples", str(tmp_path / "ex")]) == 0
    mission = tmp_path / "ex" / "slalom.yaml"
    monkeypatch.chdir(tmp_path)
    _without(monkeypatch, "mujoco")
    _no_run_started(monkeypatch)
    capsys.readouterr()
    assert main(["run", str(mission), "--set", "sim.engine=mujoco"]) == 2
    err = capsys.readouterr().err
    assert "sim.engine: needs MuJoCo" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ex"]  # no runs/


def test_what_is_installed_is_not_missing() -> None:
    # the test environment has every extra (pyproject's test extra)
    assert missing(MATPLOTLIB) is None
    assert missing(RERUN) is None
    assert missing(MUJOCO) is None or "system library" in str(missing(MUJOCO))


def test_a_readme_path_outside_the_repository_says_how_to_run_the_built_in_one(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["run", "missions/slalom.yaml"]) == 2
    err = capsys.readouterr().err
    assert "missions/slalom.yaml: no such file; slalom is a built-in example" in err, err
    assert "'marknav run slalom'" in err and "'marknav examples DIR'" in err, err
    assert list(tmp_path.iterdir()) == []
    # a path naming no example keeps the loader's plain message
    assert main(["run", "missions/mine.yaml"]) == 2
    assert "built-in example" not in capsys.readouterr().err


def test_detect_takes_an_example_name_for_its_mission(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    by_name = main(["detect", str(FRAME), "--mission", "slalom", "--json"])
    out_name = json.loads(capsys.readouterr().out)
    by_file = main(["detect", str(FRAME), "--mission", str(ROOT / "missions" / "slalom.yaml"),
                    "--json"])
    out_file = json.loads(capsys.readouterr().out)
    assert by_name == by_file == 0
    assert out_name == out_file  # the same mission: the same marks at the same distances
    assert all("distance_mm" in m for m in out_name[0]["marks"])


def test_palette_check_takes_an_example_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    code = main(["palette", str(FRAME), "--check", "slalom"])
    captured = capsys.readouterr()
    assert "no such file" not in captured.err, captured.err
    assert code in (0, 1), captured.err
    assert "how its palette separates the marks found" in captured.out, captured.out
    assert main(["palette", str(FRAME), "--check", "slalmo"]) == 2
    assert "did you mean slalom?" in capsys.readouterr().err
