"""``calibrate-odometry`` goes through the fault → stop → message path of a run (issue 41, R2):
every safety fault the simulated Create reports mid-manoeuvre stops the wheels and ends the
command with exit 1 and a message naming the fault, never a traceback; options that would make
a leg last for ever (or crash the random source) are exit 2."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import yaml

from marknav.cli import calibrate_odometry
from marknav.cli.main import main
from marknav.sim.simulated_create import WheelSpeeds

ROOT = Path(__file__).resolve().parents[2]
SLALOM = ROOT / "missions" / "slalom.yaml"


@pytest.mark.parametrize(("event", "named"), [
    ({"fault": "cliff", "side": "front_left"}, "cliff front left"),
    ({"fault": "wheel_drop", "side": "right"}, "wheel drop right"),
    ({"fault": "overcurrent", "side": "left"}, "overcurrent left wheel"),
    ({"fault": "low_battery"}, "low battery"),
    ({"fault": "bump", "side": "both"}, "bump"),
])
@pytest.mark.parametrize("t_s", [0.5, 4.0])  # while driving straight; while turning
def test_a_fault_stops_the_calibration_with_exit_1_naming_it(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
        event: dict[str, Any], named: str, t_s: float) -> None:
    world = tmp_path / "w.yaml"
    world.write_text(yaml.safe_dump({"events": [{"t_s": t_s, **event}]}), encoding="utf-8")
    made: list[Any] = []
    real = calibrate_odometry._environment

    def keep(*args: Any) -> Any:
        env, truth = real(*args)
        made.append(env)
        return env, truth

    monkeypatch.setattr(calibrate_odometry, "_environment", keep)
    code = main(["calibrate-odometry", str(SLALOM), "--world", str(world), "--distance-mm",
                 "500", "--speed-mm-s", "200", "--turn-deg", "360"])
    err = capsys.readouterr().err
    assert code == 1, err
    assert "Traceback" not in err
    assert "marknav calibrate-odometry: aborted: the safety layer refused to" in err
    assert named in err
    assert made[0].create.wheel_speeds == WheelSpeeds(left=0.0, right=0.0)


@pytest.mark.parametrize(("argv", "message"), [
    (["--seed", "-1"], "--seed: must be from 0 to"),
    (["--seed", str(2**64)], "--seed: must be from 0 to"),
    (["--speed-mm-s", "1e-300"], "--speed-mm-s: must be from 20 to 500 mm/s"),
    (["--speed-mm-s", "5"], "--speed-mm-s: must be from 20 to 500 mm/s"),
    (["--distance-mm", "1e300"], "--distance-mm: must be from 10 to 10000 mm"),
    (["--turn-deg", "1e9"], "--turn-deg: must be from 0 to 3600 degrees"),
])
def test_unbounded_options_are_exit_2(argv: list[str], message: str,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["calibrate-odometry", str(SLALOM), *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
