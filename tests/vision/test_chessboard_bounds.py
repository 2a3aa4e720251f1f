"""``calibrate-camera`` bounds (issue 41, R10): boards OpenCV cannot search and squares no print
has are exit 2 naming the option, before any image is read; an OpenCV file that cannot be
written (a full disk) is exit 2 with no file left, never "written" over a 0-byte file."""

from __future__ import annotations

import builtins
import errno
from pathlib import Path
from typing import Any

import pytest

from marknav.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
LEFT = sorted(str(p) for p in (ROOT / "tests" / "data" / "opencv-left").glob("*.jpg"))


@pytest.mark.parametrize(("argv", "message"), [
    (["--board", "2x2", "--square-mm", "25"], "--board: a board has 3 to 50 inner corners"),
    (["--board", "2x3", "--square-mm", "25"], "--board: a board has 3 to 50 inner corners"),
    (["--board", "3x2", "--square-mm", "25"], "--board: a board has 3 to 50 inner corners"),
    (["--board", "1x1", "--square-mm", "25"], "--board: a board has 3 to 50 inner corners"),
    (["--board", f"{10**19}x6", "--square-mm", "25"], "--board: a board has 3 to 50"),
    (["--board", "9x6", "--square-mm", "1e300"], "--square-mm: must be from 0.5 to 1000 mm"),
    (["--board", "9x6", "--square-mm", "1e-300"], "--square-mm: must be from 0.5 to 1000 mm"),
])
def test_out_of_range_boards_and_squares_are_exit_2(
        argv: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["calibrate-camera", *LEFT[:3], *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_a_full_disk_leaves_no_calibration_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "cam.yml"
    real_open = builtins.open

    class FullDisk:
        def __init__(self, fh: Any) -> None:
            self.fh = fh

        def __enter__(self) -> FullDisk:
            return self

        def __exit__(self, *exc: object) -> None:
            self.fh.close()

        def write(self, text: str) -> int:
            self.fh.write(text[:10])
            raise OSError(errno.ENOSPC, "No space left on device")

    def opening(file: Any, mode: str = "r", *args: Any, **kw: Any) -> Any:
        fh = real_open(file, mode, *args, **kw)
        return FullDisk(fh) if str(file) == str(out) and "w" in mode else fh

    monkeypatch.setattr(builtins, "open", opening)
    assert main(["calibrate-camera", *LEFT[:5], "--board", "9x6", "--square-mm", "25",
                 "--opencv-yml", str(out)]) == 2
    captured = capsys.readouterr()
    assert f"{out}: cannot write: No space left on device" in captured.err
    assert "written" not in captured.out
    assert not out.exists()
