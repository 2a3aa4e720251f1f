"""The one signal policy (:mod:`marknav.core.signals`) for every signal that would end marknav.

A real ``marknav run`` against a simulated Create on a real pseudo-terminal: whatever ending
signal arrives — a dropped SSH session's SIGHUP, a Ctrl-\\ SIGQUIT, a stray ``kill -USR1`` — the
wheels are stopped at once, the report and the event log are written and name the signal, and
the exit code is the CLI's "interrupted", 130.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
import yaml

from marknav.robot.packets import OIMode
from marknav.sim.pty import PtyServer
from marknav.sim.simulated_create import WheelSpeeds
from tests.faultkit import pty_robot

ROOT = Path(__file__).resolve().parents[2]
SLALOM = ROOT / "missions" / "slalom.yaml"
IMAGE = ROOT / "tests" / "data" / "smarties.png"
ENV = {**os.environ, "PYTHONUNBUFFERED": "1", "PY_TREES_DISABLE_COLORS": "1"}
#: How soon the wheels must be at 0 after the signal (s): a few control ticks and one write.
STOP_WITHIN_S = 0.2
STOPPED = WheelSpeeds(left=0.0, right=0.0)


def wait_until(cond: Callable[[], bool], timeout: float, step: float = 0.002) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if cond():
            return True
        time.sleep(step)
    return cond()


@pytest.fixture
def robot() -> Iterator[PtyServer]:
    with pty_robot() as server:
        yield server


def hardware_mission(tmp_path: Path) -> Path:
    """The slalom with watchdogs loose enough for a loaded machine (this is about signals)."""
    data = yaml.safe_load(SLALOM.read_text(encoding="utf-8"))
    data["safety"] = {**data.get("safety", {}), "sensor_timeout_s": 2.0,
                      "command_timeout_s": 2.0}
    data.pop("sim", None)
    path = tmp_path / "hw.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return path


def test_every_catchable_ending_signal_is_routed() -> None:
    from marknav.core.signals import ENDING_SIGNALS

    names = {s.name for s in ENDING_SIGNALS}
    assert {"SIGHUP", "SIGINT", "SIGQUIT", "SIGTERM", "SIGUSR1", "SIGUSR2", "SIGALRM"} <= names
    # A closed pipe is an OSError where it happens, not an end of the run.
    assert "SIGPIPE" not in names


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGHUP, signal.SIGQUIT, signal.SIGUSR1, signal.SIGALRM])
def test_a_signal_stops_the_driving_robot_and_names_itself_in_the_report(
        robot: PtyServer, tmp_path: Path, sig: signal.Signals) -> None:
    report = tmp_path / "r.json"
    mission = hardware_mission(tmp_path)
    proc = subprocess.Popen([sys.executable, "-m", "marknav", "run", str(mission),
                             "--robot", robot.path, "--camera", str(IMAGE), "--tree", "none",
                             "--report", str(report)], cwd=tmp_path, env=ENV,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert wait_until(lambda: proc.poll() is not None or robot.sim.wheel_speeds != STOPPED,
                          60), "the robot never drove"
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.3)  # well into the run
        assert robot.sim.wheel_speeds != STOPPED
        proc.send_signal(sig)
        sent = time.monotonic()
        assert wait_until(lambda: robot.sim.wheel_speeds == STOPPED, 5, 0.001)
        stopped_after = time.monotonic() - sent
        _out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    print(f"{sig.name}: wheels at 0 {1000 * stopped_after:.0f} ms after the signal")
    assert stopped_after <= STOP_WITHIN_S, f"wheels at 0 only {stopped_after:.3f} s after {sig!r}"
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    assert f"report: {report}" in err
    data = json.loads(report.read_text())
    assert (data["outcome"], data["reason"]) == ("aborted", f"interrupted ({sig.name})")
    last = json.loads((tmp_path / "r.events.jsonl").read_text().splitlines()[-1])
    assert last["kind"] == "end" and last["reason"] == f"interrupted ({sig.name})"
    assert robot.sim.wheel_speeds == STOPPED and robot.sim.mode == OIMode.PASSIVE
