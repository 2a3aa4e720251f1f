"""Command-line conventions: global options anywhere, did-you-mean, usage errors of the right
command, ``--set`` errors at the setting, library messages kept off the screen."""

from __future__ import annotations

import logging
import os
import subprocess
import sys
from pathlib import Path

import pytest

from marknav.cli.main import main

SLALOM = Path(__file__).resolve().parents[2] / "missions" / "slalom.yaml"


@pytest.mark.parametrize(("argv", "level"), [
    (["validate", str(SLALOM), "-v"], logging.INFO),     # after the command
    (["-v", "validate", str(SLALOM)], logging.INFO),     # before it
    (["-v", "validate", str(SLALOM), "-v"], logging.DEBUG),  # both count
    (["validate", str(SLALOM)], logging.WARNING),
])
def test_verbose_before_or_after_the_command(argv: list[str], level: int,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 0
    assert capsys.readouterr().out.startswith(f"{SLALOM}: ok")
    assert logging.getLogger("marknav").level == level


def test_version_after_the_command(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["run", "--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.startswith("marknav ")


def test_unknown_command_suggests_the_closest(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["rnu", str(SLALOM)])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "marknav: error: unknown command 'rnu' (did you mean run?)" in err


def test_unknown_option_suggests_the_closest_on_the_commands_usage(
        capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["run", str(SLALOM), "--max-tme", "3"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: marknav run ")
    assert ("marknav run: error: unknown option '--max-tme' (did you mean --max-time?); "
            "unexpected argument '3'") in err


def test_set_without_equals_is_a_usage_error_of_the_command(
        capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["run", str(SLALOM), "--set", "navigation.clearance_mm", "350"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: marknav run ")
    assert ("marknav run: error: argument --set: expected KEY=VALUE in one word, got "
            "'navigation.clearance_mm': write --set navigation.clearance_mm=VALUE") in err


@pytest.mark.parametrize(("setting", "message"), [
    ("navigation.foo=3", "--set navigation.foo=3: no such setting (allowed: approach_aim, "),
    ("navigation.clearence_mm=3",
     "--set navigation.clearence_mm=3: no such setting; did you mean 'clearance_mm'?"),
    # a made-up section is the setting's doing, not the file's first line ('name: slalom')
    ("foo.bar=1", "--set foo.bar=1: foo: no such setting (allowed: camera, "),
])
def test_a_wrong_setting_is_named(setting: str, message: str,
                                  capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["validate", str(SLALOM), "--set", setting]) == 2
    first = capsys.readouterr().err.splitlines()[0]
    assert first.startswith(message)
    assert str(SLALOM) not in first


def _marknav(*args: str, code: str | None = None) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "OPENCV_LOG_LEVEL"}
    argv = ["-c", code] if code is not None else ["-m", "marknav", *args]
    return subprocess.run([sys.executable, *argv], capture_output=True, text=True, env=env,
                          timeout=120, check=False)


def test_opencv_log_lines_stay_off_the_screen(tmp_path: Path) -> None:
    # a camera index with no device: OpenCV itself logs "[ WARN:0@…] global cap_v4l.cpp…"
    missing = next(i for i in range(9, 64) if not Path(f"/dev/video{i}").exists())
    proc = _marknav("serve-camera", "--camera", str(missing), "--port", "0")
    assert proc.returncode == 2
    assert proc.stderr == (f"marknav serve-camera: error: {missing}: cannot open the camera "
                           "or stream\n")


@pytest.mark.parametrize(("verbosity", "shown"), [(0, False), (1, True)])
def test_python_warnings_become_log_lines(verbosity: int, shown: bool) -> None:
    proc = _marknav(code=(
        "import warnings\n"
        "from marknav.cli.main import configure_logging\n"
        f"configure_logging({verbosity})\n"
        "warnings.warn('a library grumbles', RuntimeWarning)\n"))
    assert proc.returncode == 0
    if shown:
        assert proc.stderr.startswith("WARNING py.warnings: ")
        assert "RuntimeWarning: a library grumbles" in proc.stderr
    else:
        assert proc.stderr == ""


def test_ctrl_c_during_a_run_says_interrupted_once(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    import marknav.runs.loop.run as run_module

    def interrupted(req: object) -> object:
        raise KeyboardInterrupt("SIGINT")

    monkeypatch.setattr(run_module, "prepare", lambda simulator: None)
    monkeypatch.setattr(run_module, "execute", interrupted)
    code = main(["run", str(SLALOM), "--tree", "none", "--report", str(tmp_path / "r.json")])
    assert code == 130
    said = [line for line in capsys.readouterr().err.splitlines() if "interrupted" in line]
    assert len(said) == 1, said  # the run's own line, not the CLI's generic one as well
    assert said[0].startswith("marknav run: interrupted while starting; wheels stopped; report: ")
