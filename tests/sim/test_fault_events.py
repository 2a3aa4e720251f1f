"""Timed fault events in a world, end to end: the byte-level simulated Create sets the fault in
its stream packets at the event's time, the real driver reads it and its safety layer stops the
wheels; the run aborts with exit 1 and a report that names the fault."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import yaml

from marknav.cli.main import main
from marknav.robot.oi import Opcode
from marknav.runs.loop import run as runmod

ROOT = Path(__file__).resolve().parents[2]
SLALOM = ROOT / "missions" / "slalom.yaml"
EVENT_T = 3.0
#: One sensor stream period (OI spec "Stream": a frame every 15 ms).
SENSOR_PERIOD_S = 0.015


def _world(tmp_path: Path, event: dict[str, Any]) -> Path:
    doc = yaml.safe_load((ROOT / "missions" / "worlds" / "slalom-world.yaml").read_text())
    doc["events"] = [event]
    path = tmp_path / "world.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def _run(tmp_path: Path, world: Path, monkeypatch: pytest.MonkeyPatch,
         max_time: str = "20") -> tuple[int, dict[str, Any], Any]:
    made: list[Any] = []
    real = runmod.make_environment

    def keep(*args: Any, **kwargs: Any) -> Any:
        env = real(*args, **kwargs)
        made.append(env)
        return env

    monkeypatch.setattr(runmod, "make_environment", keep)
    report_path = tmp_path / "r.json"
    code = main(["run", str(SLALOM), "--world", str(world), "--tree", "none",
                 "--max-time", max_time, "--report", str(report_path)])
    return code, json.loads(report_path.read_text()), made[0]


def _first_stop_after(env: Any, t: float) -> float:
    """When the first zero Drive Direct written at or after ``t`` reached the robot."""
    for rec in env.create.commands:
        if rec.t >= t - 1e-9 and rec.opcode == Opcode.DRIVE_DIRECT and rec.data == bytes(4):
            return float(rec.t)
    raise AssertionError("no zero Drive Direct after the event")


@pytest.mark.parametrize(("event", "named"), [
    ({"fault": "cliff", "side": "front_left"}, "cliff front left"),
    ({"fault": "wheel_drop", "side": "right"}, "wheel drop right"),
    ({"fault": "overcurrent", "side": "left"}, "overcurrent left wheel"),
    ({"fault": "low_battery"}, "low battery"),
    ({"fault": "bump", "side": "both"}, "bump"),
])
def test_a_fault_mid_run_stops_the_wheels_within_one_sensor_period_and_aborts(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, event: dict[str, Any], named: str
) -> None:
    world = _world(tmp_path, {"t_s": EVENT_T, **event})
    code, report, env = _run(tmp_path, world, monkeypatch)
    assert code == 1, report["reason"]
    assert report["outcome"] in ("aborted", "failed")
    # Moving when the fault came: the mission was under way, then the wheels stopped.
    moving = [r for r in env.create.commands
              if r.opcode == Opcode.DRIVE_DIRECT and r.t < EVENT_T and r.data != bytes(4)]
    assert moving, "the robot was not driving before the fault"
    stopped = _first_stop_after(env, EVENT_T)
    assert stopped - EVENT_T <= SENSOR_PERIOD_S + 1e-6, stopped
    details = " ".join(str(e.get("detail", "")) for e in report["safety_events"])
    assert named in details, report["safety_events"]
    assert named in report["reason"] or named.split()[0] in report["reason"], report["reason"]


def test_a_short_bump_is_recovered_and_the_mission_goes_on(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    world = _world(tmp_path, {"t_s": EVENT_T, "fault": "bump", "side": "left",
                              "duration_s": 0.1})
    code, report, env = _run(tmp_path, world, monkeypatch, max_time="80")
    assert [e["event"] for e in report["safety_events"]].count("bump") == 1
    assert _first_stop_after(env, EVENT_T) - EVENT_T <= SENSOR_PERIOD_S + 1e-6
    assert code == 0, report["reason"]
    assert report["collisions"] == 0  # a sensor event, not a contact with anything
