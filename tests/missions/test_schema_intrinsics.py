"""camera.intrinsics and camera.learn_range in the mission file."""

from __future__ import annotations

from pathlib import Path

import pytest

from marknav.cli.main import main
from marknav.missions.schema import load_mission

MISSION = """\
name: t
route: [red]
marks: {radius_mm: 100, colours: {red: {hue: [170, 10], side: left}}}
camera:
  intrinsics: {fx: 536.07, fy: 536.02, cx: CX, cy: 235.54, dist: DIST}
"""


def _write(tmp_path: Path, cx: str = "342.37", dist: str = "[-0.265, -0.0467, 0.0018, -0.0003]"
           ) -> Path:
    p = tmp_path / "m.yaml"
    p.write_text(MISSION.replace("CX", cx).replace("DIST", dist))
    return p


def test_intrinsics_load_and_give_the_focal_length(tmp_path: Path) -> None:
    m = load_mission(_write(tmp_path))
    i = m.camera.intrinsics
    assert i is not None and (i.fx, i.cy, len(i.dist)) == (536.07, 235.54, 4)
    assert m.camera.focal_px == pytest.approx(536.045)  # not written: from the intrinsics
    assert m.camera.learn_range is True  # on by default (issue 13)


@pytest.mark.parametrize(("cx", "dist", "message"), [
    ("342.37", "[-0.265, -0.0467, 0.0018]", "5:70: camera.intrinsics.dist: needs 4, 5 or 8"),
    ("742.37", "[]", "5:44: camera.intrinsics.cx: cx 742.37 lies outside the image (0..640)"),
    ("-3", "[]", "camera.intrinsics.cx:"),
])
def test_bad_intrinsics_name_the_line_and_field(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                cx: str, dist: str, message: str) -> None:
    path = _write(tmp_path, cx, dist)
    assert main(["validate", str(path)]) == 2
    assert message in capsys.readouterr().err
