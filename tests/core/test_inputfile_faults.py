"""Hostile input files, read through the one bounded reader (issue 15, item 10; issue 31,
B1, B2, B4): deep or recursive YAML, alias bombs, control characters, huge files, character
devices, directories, names too long for the OS and FIFOs: exit 2 naming the file (and the
line), never a traceback, never a wait.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from marknav.cli.main import main
from marknav.sim.pty import PtyServer
from tests.faultkit import (
    SLALOM,
    hardware_mission,
    marknav,
    pty_robot,
    run_main,
    slalom_with,
)


@pytest.fixture
def robot() -> Iterator[PtyServer]:
    """A simulated Create 2 on a real pseudo-terminal."""
    with pty_robot() as server:
        yield server


LONG_NAME = "w" * 300 + ".yaml"  # longer than any one file name the OS takes (255 bytes)


def _alias_bomb() -> str:
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x]"]
    for i in range(1, 9):
        lines.append(f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 9) + "]")
    return "\n".join(lines) + "\n"


@pytest.mark.slow
def test_hostile_yaml_files_exit_2_naming_file_and_line(tmp_path: Path) -> None:
    files = {
        "deep.yaml": "name: " + "[" * 2000 + "]" * 2000 + "\n",
        "deepmap.yaml": "".join("  " * i + f"k{i}:\n" for i in range(600)) + "  " * 600 + "x\n",
        "recursive.yaml": "name: &a [*a]\n",
        "control.yaml": "name: a\x1bb\nroute: [red]\n",
        "bomb.yaml": _alias_bomb(),
        "big.yaml": "name: x\n" + "# padding\n" * 100_000,
    }
    for name, text in files.items():
        (tmp_path / name).write_text(text, encoding="utf-8")
    os.mkfifo(tmp_path / "fifo.yaml")
    names = [*files, "fifo.yaml", "/dev/zero", "/dev/urandom", str(tmp_path)]
    proc = marknav("validate", *names, cwd=tmp_path, timeout=60, mem_bytes=2 << 30)
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr and "MemoryError" not in proc.stderr
    err = proc.stderr
    assert "deep.yaml:1:" in err and "nested deeper than" in err
    assert "deepmap.yaml:" in err
    assert "recursive.yaml:1:" in err
    assert "control.yaml:1:8: control character U+001B" in err
    assert "bomb.yaml:" in err and "expands to more than" in err
    assert "big.yaml: too large" in err
    assert "fifo.yaml: is a pipe (FIFO)" in err
    assert "/dev/zero: is a character device" in err and "/dev/urandom: is a character" in err
    assert "is a directory" in err
    assert "\x1b" not in err


def test_dev_zero_as_world_and_table(tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    proc = marknav("run", str(SLALOM), "--world", "/dev/zero", cwd=tmp_path, timeout=60,
                   mem_bytes=2 << 30)
    assert proc.returncode == 2, proc.stderr
    assert "/dev/zero: is a character device" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert main(["calibrate", "/dev/urandom"]) == 2  # refused before a byte is read
    assert "/dev/urandom: is a character device" in capsys.readouterr().err


@pytest.mark.parametrize("command", [
    ["validate"], ["tree"], ["run", "--tree", "none", "--max-time", "1"],
])
def test_a_missions_world_name_too_long_is_exit_2_at_its_line(tmp_path: Path,
                                                              command: list[str]) -> None:
    mission = slalom_with(tmp_path, "world: " + str(SLALOM.parent) + "/worlds/slalom-world.yaml",
                           "world: " + LONG_NAME)
    code, err = run_main([command[0], str(mission), *command[1:]], tmp_path)
    assert code == 2, err
    assert "Traceback" not in err and "OSError" not in err
    line = next(i for i, ln in enumerate(mission.read_text().splitlines(), 1)
                if ln.startswith("  world:"))
    assert f"{mission}:{line}:" in err and "sim.world" in err, err
    assert "name too long" in err.lower()


@pytest.mark.parametrize("argv", [
    ["run", str(SLALOM), "--world", LONG_NAME, "--tree", "none"],
    ["validate", str(SLALOM), "--world", LONG_NAME],
    ["replay", LONG_NAME, "--at", "0"],
    ["view", LONG_NAME + ".mcap"],
    ["validate", LONG_NAME],
    ["detect", LONG_NAME],
    ["calibrate", LONG_NAME],
    ["calibrate-camera", LONG_NAME, LONG_NAME + "1", LONG_NAME + "2", "--board", "9x6",
     "--square-mm", "25"],
    ["serve-camera", "--camera", LONG_NAME, "--port", "0"],
])
def test_any_path_too_long_is_exit_2_naming_it(tmp_path: Path, argv: list[str]) -> None:
    code, err = run_main(argv, tmp_path)
    assert code == 2, err
    assert "Traceback" not in err and "OSError" not in err
    assert LONG_NAME[:40] in err and "name too long" in err.lower(), err


def _fifo(tmp_path: Path, name: str) -> Path:
    path = tmp_path / name
    os.mkfifo(path)
    return path


def test_a_fifo_as_the_camera_is_refused_at_once(robot: PtyServer, tmp_path: Path) -> None:
    """A FIFO with no writer blocked ``run`` in OpenCV's open() (signals could not end it)."""
    fifo = _fifo(tmp_path, "fifo.avi")
    t0 = time.monotonic()
    proc = marknav("run", str(hardware_mission(tmp_path)), "--robot", robot.path,
                   "--camera", str(fifo), "--report", str(tmp_path / "r.json"), "--tree", "none",
                   cwd=tmp_path, timeout=60)
    assert time.monotonic() - t0 < 30
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    assert f"{fifo}: is a pipe (FIFO)" in proc.stderr
    assert robot.bytes_in == 0  # refused before the robot was opened


def test_serve_camera_refuses_a_fifo(tmp_path: Path) -> None:
    fifo = _fifo(tmp_path, "fifo.avi")
    proc = marknav("serve-camera", "--camera", str(fifo), "--port", "0", cwd=tmp_path,
                   timeout=60)
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    assert f"{fifo}: is a pipe (FIFO)" in proc.stderr


@pytest.mark.parametrize("what", ["world", "replay", "images", "table"])
def test_no_path_opens_a_fifo(tmp_path: Path, what: str) -> None:
    """Every file marknav reads goes through one reader that refuses FIFOs before opening."""
    if what == "world":
        argv = ["run", str(SLALOM), "--world", str(_fifo(tmp_path, "w.yaml")), "--tree", "none"]
    elif what == "replay":
        argv = ["replay", str(_fifo(tmp_path, "r.events.jsonl")), "--at", "0"]
    elif what == "images":
        argv = ["calibrate-camera", *(str(_fifo(tmp_path, f"board{i}.png")) for i in range(3)),
                "--board", "9x6", "--square-mm", "25"]
    else:
        argv = ["calibrate", str(_fifo(tmp_path, "t.csv"))]
    proc = marknav(*argv, cwd=tmp_path, timeout=60)
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    assert "is a pipe (FIFO)" in proc.stderr
