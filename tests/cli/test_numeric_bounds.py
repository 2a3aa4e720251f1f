"""Numeric options out of their range are exit 2 naming the option (issue 41, R13), before any
camera is opened or any frame kept."""

from __future__ import annotations

from pathlib import Path

import pytest

from marknav.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
IMAGE = ROOT / "tests" / "data" / "smarties.png"


@pytest.mark.parametrize(("argv", "message"), [
    (["palette", "--camera", str(IMAGE), "--colours", "red", "--interval", "1e300"],
     "--interval: must be from 0 to 600 seconds, got 1e+300"),
    (["palette", "--camera", str(IMAGE), "--colours", "red", "--interval", "nan"],
     "--interval: must be from 0 to 600 seconds"),
    (["palette", "--camera", str(IMAGE), "--colours", "red", "--frames", "100000"],
     "--frames: must be from 1 to 200, got 100000"),
    (["serve-camera", "--camera", str(IMAGE), "--fps", "1e-300"],
     "--fps: at 1e-300 fps a frame comes every"),
    (["serve-camera", "--camera", str(IMAGE), "--fps", "0.1"],
     "longer than --stall-timeout 5 s: give at least 0.2 fps"),
    (["serve-camera", "--camera", str(IMAGE), "--fps", "1e9"], "--fps: must be in (0, 1000]"),
])
def test_out_of_range_is_exit_2(argv: list[str], message: str,
                                capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
