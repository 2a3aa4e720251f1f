"""``marknav calibrate-odometry`` against the simulated Create: it recovers an encoder scale
error set as a world condition, takes a tape measurement on a (simulated) serial robot, and
refuses bad input with exit 2."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from marknav.cli.main import main
from marknav.robot.odometry_calibration import effective_wheel_base, odometry_scale

ROOT = Path(__file__).resolve().parents[2]
SLALOM = ROOT / "missions" / "slalom.yaml"


def test_the_simulator_encoder_scale_is_recovered(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    world = tmp_path / "w.yaml"
    world.write_text("conditions: {encoder_scale: 1.03, top_speed_mm_s: 400}\n")
    code = main(["calibrate-odometry", str(SLALOM), "--world", str(world), "--json",
                 "--distance-mm", "600", "--turn-deg", "180"])
    out = json.loads(capsys.readouterr().out)
    assert code == 0
    # the encoders count 3 % too much: odometry drives 3 % short; the scale undoes it
    assert out["odometry_scale"] == pytest.approx(1 / 1.03, abs=0.002)
    assert out["measured_mm"] == pytest.approx(out["odometry_mm"] / 1.03, rel=0.002)
    # a turn is 3 % short too; with the scale applied, the wheel base stays the mission's
    assert out["measured_deg"] == pytest.approx(out["odometry_deg"] / 1.03, rel=0.005)
    assert out["wheel_base_mm"] == pytest.approx(235.0, abs=1.0)


def test_a_serial_robot_takes_the_tape_measurement(capsys: pytest.CaptureFixture[str]) -> None:
    # a simulated Create on wall-clock time behind a serial URL: the real driver's path
    code = main(["calibrate-odometry", str(SLALOM), "--robot",
                 "createsim://?model=create2&encoder_scale=1.05", "--distance-mm", "60",
                 "--speed-mm-s", "200", "--turn-deg", "0", "--measured-mm", "57", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 0
    assert out["odometry_mm"] >= 60.0
    assert out["odometry_scale"] == pytest.approx(57.0 / out["odometry_mm"], abs=1e-3)
    assert "odometry_deg" not in out


@pytest.mark.parametrize(("argv", "message"), [
    (["--distance-mm", "-5"], "--distance-mm: must be a positive number"),
    (["--speed-mm-s", "900"], "reach 500 mm/s at most"),
    (["--robot", "createsim://?model=create2"], "give the measurement with --measured-mm"),
])
def test_bad_input_exits_2(argv: list[str], message: str,
                           capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["calibrate-odometry", str(SLALOM), *argv]) == 2
    assert message in capsys.readouterr().err


def test_the_scale_and_wheel_base_formulas() -> None:
    assert odometry_scale(measured_mm=970.0, odometry_mm=1000.0, current=1.02) == \
        pytest.approx(0.9894)
    # odometry turned 370° where the robot turned 360°: the wheels act 370/360 farther apart
    assert effective_wheel_base(wheel_base_mm=235.0, odometry_deg=370.0, measured_deg=360.0) \
        == pytest.approx(235.0 * 370.0 / 360.0)
    with pytest.raises(ValueError):
        odometry_scale(measured_mm=0.0, odometry_mm=10.0)
