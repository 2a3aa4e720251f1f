"""Node plugins: a separate user package (tests/data/plugin_pkg) whose behaviour is used in a
mission's tree — its own kit test, validate, tree, schema and a simulated run — through a
mission's ``plugins:`` and through the ``marknav.nodes`` entry point of the installed package;
broken plugins exit 2 at their line."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from marknav.cli.main import main
from marknav.missions.schema import mission_json_schema
from marknav.robot.oi import Opcode
from marknav.runs.loop.checks import checked_mission
from marknav.runs.loop.run import RunRequest, execute

PKG = Path(__file__).resolve().parents[1] / "data" / "plugin_pkg"
MISSION = PKG / "missions" / "wiggle-at-each-mark.yaml"


def _env(pythonpath: Path) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(pythonpath)
    env["PY_TREES_DISABLE_COLORS"] = "1"
    return env


@pytest.mark.slow
def test_the_user_package_passes_its_own_kit_test() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider"], cwd=PKG,
        env=_env(PKG), capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "1 passed" in done.stdout


@pytest.fixture
def on_path(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.syspath_prepend(str(PKG))


@pytest.mark.usefixtures("on_path")
def test_mission_plugin_validate_tree_schema(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["validate", str(MISSION)]) == 0
    assert capsys.readouterr().out == f"{MISSION}: ok (route: red → green, 2 waypoints)\n"

    assert main(["tree", str(MISSION), "--tree", "ascii"]) == 0
    out = capsys.readouterr().out
    assert "-    Dance after red\n" in out and "-    Dance after green\n" in out
    # indices derived from the order
    assert "-    ?? Waypoint 1: red (pass on its left)\n" in out
    assert "-    ?? Waypoint 2: green (pass on its right)\n" in out

    assert main(["schema", "--plugin", "marknav_wiggle"]) == 0
    schema = json.loads(capsys.readouterr().out)
    node = schema["$defs"]["TreeNode"]
    assert "Wiggle" in node["properties"]["type"]["examples"]
    [clause] = [c for c in node["allOf"] if c["if"]["properties"]["type"]["const"] == "Wiggle"]
    params = clause["then"]["properties"]["params"]
    assert params["description"].startswith("Wiggle: Turn on the spot left and right")
    assert params["properties"]["swings"] == {
        "default": 3, "description": "Turns, alternately left and right.", "maximum": 10,
        "minimum": 1, "title": "Swings", "type": "integer"}
    assert params["additionalProperties"] is False
    # without the plugin, the default schema does not know Wiggle
    assert "Wiggle" not in mission_json_schema()["$defs"]["TreeNode"]["properties"]["type"][
        "examples"]


@pytest.mark.usefixtures("on_path")
def test_mission_plugin_params_are_validated(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(MISSION.read_text().replace("swings: 4", "swings: 40, swng_s: 1"))
    assert main(["validate", str(bad)]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"{bad}:30:68: tree.children[3].children[3].params.swings: Input should be less than or "
        "equal to 10",
        f"{bad}:30:72: tree.children[3].children[3].params.swng_s: unknown key 'swng_s'; did you "
        "mean 'swing_s'?",
        "marknav validate: 1 of 1 mission file invalid",
    ]


@pytest.mark.usefixtures("on_path")
def test_mission_plugin_runs_in_the_simulator(tmp_path: Path) -> None:
    mission = checked_mission(MISSION)
    result = execute(RunRequest(mission=mission, report_path=tmp_path / "r.json"))
    report = result.report
    assert (report.outcome, [w.outcome for w in report.waypoints]) == (
        "success", ["passed", "passed"]), report.reason
    assert [w.passed_on for w in report.waypoints] == ["left", "right"]  # ground truth
    spins = set()
    for cmd in result.environment.create.commands:  # the bytes the simulated Create received
        if cmd.opcode == Opcode.DRIVE_DIRECT:
            right = int.from_bytes(cmd.data[0:2], "big", signed=True)
            left = int.from_bytes(cmd.data[2:4], "big", signed=True)
            if left == -right != 0:
                spins.add(right)
    # Dance after red: 45 °/s × 235 mm / 2 = 92 mm/s; after green: 60 °/s (the default) = 123,
    # each both ways (searching turns at 40 °/s = 82 mm/s).
    assert {92, -92, 123, -123} <= spins


def test_broken_plugins_exit_2_at_their_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # The mission's own folder is searched too: modules next to the mission file.
    (tmp_path / "raises_on_import.py").write_text("raise RuntimeError('no camera here')\n")
    (tmp_path / "bad_register.py").write_text(
        "def register(registry):\n    registry.register('Pause', lambda *a: None)\n")
    (tmp_path / "good_nodes.py").write_text(
        "from marknav.missions.registry import NoParams\n"
        "import py_trees\n"
        "def register(registry):\n"
        "    registry.register('Hello', lambda name, p, c: py_trees.behaviours.Success(name))\n")
    path = tmp_path / "m.yaml"
    path.write_text(
        "name: p\n"
        "route: [red]\n"
        "marks: {colours: {red: {hue: [170, 10], side: left}}}\n"
        "plugins:\n"
        "  - raises_on_import\n"
        "  - bad_register\n"
        "  - good_nodes\n"
        "  - ''\n"
        "tree: {type: Sequence, memory: true, children: [{type: Hello}, {type: Route}]}\n")
    assert main(["validate", str(path)]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"{path}:5:5: plugins[0]: importing 'raises_on_import' failed: RuntimeError: no camera "
        "here",
        f"{path}:6:5: plugins[1]: bad_register: register() failed: node type 'Pause' is already "
        "registered",
        f"{path}:8:5: plugins[3]: String should have at least 1 character",
        "marknav validate: 1 of 1 mission file invalid",
    ]
    assert main(["run", str(path), "--max-time", "1"]) == 2
    assert "plugins[1]: bad_register" in capsys.readouterr().err


@pytest.mark.slow
def test_entry_point_of_the_installed_package(tmp_path: Path) -> None:
    source = tmp_path / "src"
    shutil.copytree(PKG, source)  # pip builds in the source tree: keep the repository clean
    target = tmp_path / "site"
    pip = [sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", str(target)]
    # Offline with the environment's setuptools when it can build wheels; else pip's isolated
    # build (which fetches setuptools).
    install = subprocess.run([*pip, "--no-build-isolation", "--no-index", str(source)],
                             capture_output=True, text=True, timeout=300)
    if install.returncode != 0:
        install = subprocess.run([*pip, str(source)], capture_output=True, text=True,
                                 timeout=300)
    if install.returncode != 0:
        pytest.skip(f"cannot install the user package here: {install.stderr[-500:]}")
    assert any(target.glob("marknav_wiggle-0.1.0.dist-info/entry_points.txt"))
    # No plugins: line: the installed package's entry point registers Wiggle for every mission.
    mission = tmp_path / "m.yaml"
    text = MISSION.read_text()
    assert "plugins: [marknav_wiggle]\n" in text
    mission.write_text(text.replace("plugins: [marknav_wiggle]\n", ""))
    named_too = tmp_path / "named.yaml"  # installed and named under plugins: registered once
    named_too.write_text(text)
    marknav = [sys.executable, "-m", "marknav"]
    env = _env(target)
    for argv, expect in (
        (["validate", str(mission)], f"{mission}: ok (route: red → green, 2 waypoints)"),
        (["validate", str(named_too)], f"{named_too}: ok (route: red → green, 2 waypoints)"),
        (["tree", str(mission)], " Dance after green\n"),  # the plugin node in the drawn tree
        (["schema"], '"const": "Wiggle"'),
    ):
        done = subprocess.run([*marknav, *argv], env=env, capture_output=True, text=True,
                              timeout=120, cwd=tmp_path)
        assert done.returncode == 0, done.stderr
        assert expect in done.stdout
    # and without the package, the same mission is refused where Wiggle is used
    done = subprocess.run([*marknav, "validate", str(mission)], env=_env(tmp_path / "none"),
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    assert "unknown node type 'Wiggle'" in done.stderr


def test_a_broken_entry_point_is_an_input_error(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from importlib.metadata import EntryPoint

    from marknav.missions import plugins

    broken = EntryPoint(name="broken", value="no_such_marknav_nodes_module", group="marknav.nodes")
    monkeypatch.setattr(plugins, "_entry_points", lambda: (broken,))
    monkeypatch.setattr(plugins, "_default", None)  # rebuilt with the broken entry point
    assert main(["validate", str(PKG.parents[2] / "missions" / "slalom.yaml")]) == 2
    assert capsys.readouterr().err.splitlines() == [
        "entry point marknav.nodes broken = no_such_marknav_nodes_module (package ?): loading "
        "failed: ModuleNotFoundError: No module named 'no_such_marknav_nodes_module'",
        "marknav validate: 1 of 1 mission file invalid"]
    monkeypatch.setattr(plugins, "_default", None)  # not cached: the next test rebuilds it
