"""Output paths (issue 15, items 11 and 12): a mission's name never becomes a path and its
control characters are refused unprinted; bad ``--report``/``--events``/``--plot``/``--dot``
paths exit 2 before the run, and no folder is created silently.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from marknav.cli.main import main
from tests.faultkit import SLALOM


def mission_named(tmp_path: Path, name: str, file: str = "m.yaml") -> Path:
    text = SLALOM.read_text(encoding="utf-8")
    lines = [f"name: {json.dumps(name)}" if ln.startswith("name:") else ln
             for ln in text.splitlines()]
    text = "\n".join(lines).replace("world: worlds/", f"world: {SLALOM.parent}/worlds/")
    path = tmp_path / file
    path.write_text(text + "\n", encoding="utf-8")
    return path


@pytest.mark.parametrize("name", ["../../../tmp/i15-escape", "/tmp/i15-absolute", "a/b/c",
                                  "x" * 199 + "/"])
def test_the_mission_name_never_becomes_a_path(tmp_path: Path, name: str,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    mission = mission_named(tmp_path, name)
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    before = set(Path("/tmp").glob("i15-*"))
    assert main(["run", str(mission), "--max-time", "0.2", "--tree", "none"]) == 1
    assert set(Path("/tmp").glob("i15-*")) == before
    assert [p.parent for p in work.rglob("report.json")] == list((work / "runs").iterdir())
    (folder,) = (work / "runs").iterdir()
    assert folder.parent == work / "runs" and len(folder.name) <= 64 + 20


@pytest.mark.parametrize("name", ["a\u0000b", "a\nb", "a\u001b[2Jb"])
def test_control_characters_in_names_are_refused_and_never_printed(
        tmp_path: Path, name: str, capsys: pytest.CaptureFixture[str]) -> None:
    mission = mission_named(tmp_path, name)
    assert main(["validate", str(mission)]) == 2
    err = capsys.readouterr().err
    assert re.search(re.escape(str(mission)) + r":\d+:7: name: .*control character U\+00",
                     err), err
    assert not any(c in err for c in "\x00\x1b")


@pytest.mark.parametrize(("option", "value", "message"), [
    ("--report", "{tmp}", "is a directory"),
    ("--report", "{tmp}/missing/r.json", "does not exist"),
    ("--events", "{tmp}/missing/e.jsonl", "does not exist"),
    ("--plot", "{tmp}/missing/p.png", "does not exist"),
])
def test_bad_output_paths_exit_2_before_the_run(tmp_path: Path, option: str, value: str,
                                                message: str,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    monkey_runs = tmp_path / "runs"
    assert main(["run", str(SLALOM), option, value.format(tmp=tmp_path), "--tree", "none"]) == 2
    err = capsys.readouterr().err
    assert message in err and option in err
    assert "waypoints" not in err and not monkey_runs.exists()
    assert not (tmp_path / "missing").exists()  # no folder created silently


def test_dot_into_a_missing_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["tree", str(SLALOM), "--dot", str(tmp_path / "no" / "t.dot")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert not (tmp_path / "no").exists()
