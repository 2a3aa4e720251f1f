"""A wheel slip no course can be driven with (and MuJoCo cannot model) is refused by
``validate``: exit 2 naming the world file and the key, no traceback."""

from __future__ import annotations

from pathlib import Path

import pytest

from marknav.cli.main import main
from marknav.sim.world.schema import WHEEL_SLIP_LIMIT


@pytest.mark.parametrize(("slip", "code"), [(WHEEL_SLIP_LIMIT, 0), (0.999999, 2)])
def test_validate_bounds_wheel_slip(slip: float, code: int, tmp_path: Path,
                                    capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["examples", str(tmp_path / "ex")]) == 0
    world = tmp_path / "ex" / "worlds" / "slalom-world.yaml"
    text = world.read_text(encoding="utf-8")
    assert "wheel_slip: 0.0" in text
    world.write_text(text.replace("wheel_slip: 0.0", f"wheel_slip: {slip}"), encoding="utf-8")
    capsys.readouterr()
    assert main(["validate", str(tmp_path / "ex" / "slalom.yaml")]) == code
    err = capsys.readouterr().err
    if code:
        assert "slalom-world.yaml" in err and "wheel_slip" in err, err
        assert "Traceback" not in err
