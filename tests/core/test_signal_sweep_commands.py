"""The signal sweep beyond ``run``: every ending signal (``signals.ENDING_SIGNALS``)
at random moments of ``evaluate --jobs 2`` and of ``calibrate-odometry`` on a pseudo-terminal
robot. Each ends with 130 (or, if it had already ended, its own result), no traceback, no
process of its group left behind and — for the robot — the wheels at 0.

The moments are random (``MARKNAV_SWEEP_SEED`` replays one); the count per command is
``MARKNAV_SWEEP_MOMENTS`` (default 6)."""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
import yaml

from marknav.core.signals import ENDING_SIGNALS
from marknav.sim.pty import PtyServer
from marknav.sim.simulated_create import WheelSpeeds
from tests.faultkit import pty_robot
from tests.tiny_mission import TINY

ROOT = Path(__file__).resolve().parents[2]
SLALOM = ROOT / "missions" / "slalom.yaml"
MOMENTS = int(os.environ.get("MARKNAV_SWEEP_MOMENTS", "6"))
#: Exit codes of a command that ended on its own before the signal: passed or failed.
OWN_RESULTS = (0, 1)

pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(not Path("/proc/self/stat").exists(),
                                 reason="reads process groups from /proc")]


def _group_alive(pgid: int) -> list[int]:
    """The live (not zombie) processes of process group ``pgid``."""
    out = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()
        if fields[0] != "Z" and int(fields[2]) == pgid:
            out.append(int(entry.name))
    return out


def wait_until(cond: Callable[[], bool], timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if cond():
            return True
        time.sleep(0.05)
    return cond()


def _signalled(argv: list[str], cwd: Path, after_s: float, sig: signal.Signals,
               group: bool) -> tuple[int, str, bool]:
    """Run ``marknav ARGV`` in its own process group, send ``sig`` ``after_s`` s after it
    started (to the whole group, as a terminal does, or to the parent only); its exit code,
    stderr and whether it was still running when signalled."""
    env = {**os.environ, "PYTHONUNBUFFERED": "1", "PY_TREES_DISABLE_COLORS": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "marknav", *argv], cwd=cwd, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            process_group=0)
    try:
        time.sleep(after_s)
        running = proc.poll() is None
        if running:
            if group:
                os.killpg(proc.pid, sig)
            else:
                proc.send_signal(sig)
        _, err = proc.communicate(timeout=90)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert wait_until(lambda: not _group_alive(proc.pid), 10), "processes left behind"
    return proc.returncode, err, running


def _check(code: int, err: str, running: bool, where: str) -> str:
    assert "Traceback" not in err and "Exception ignored" not in err, where + err
    if code in OWN_RESULTS:  # it ended on its own, or just before the signal could land
        return "ended on its own"
    assert running and code == 130, where + err
    assert "interrupted" in err, where + err
    return "interrupted"


def _moments(name: str, lo: float, hi: float) -> tuple[int, list[tuple[float, signal.Signals,
                                                                          bool]]]:
    seed = int(os.environ.get("MARKNAV_SWEEP_SEED", random.randrange(10**6)))
    rng = random.Random(f"{name}-{seed}")
    return seed, [(rng.uniform(lo, hi), rng.choice(ENDING_SIGNALS), rng.random() < 0.5)
                  for _ in range(MOMENTS)]


def test_every_ending_signal_at_any_moment_of_an_evaluation(tmp_path: Path) -> None:
    mission = tmp_path / "tiny.yaml"
    mission.write_text(yaml.safe_dump(TINY), encoding="utf-8")
    argv = ["evaluate", str(mission), "--runs", "4", "--jobs", "2", "--max-time", "3"]
    seed, moments = _moments("evaluate", 0.0, 8.0)
    seen = []
    for after_s, sig, group in moments:
        where = f"seed {seed}: {sig.name} {'to the group' if group else ''} at {after_s:.2f} s\n"
        seen.append(_check(*_signalled(argv, tmp_path, after_s, sig, group), where))
    print(f"evaluate sweep, seed {seed}: {len(moments)} moments: {seen}")
    assert "interrupted" in seen


@pytest.fixture
def robot() -> Iterator[PtyServer]:
    with pty_robot() as server:
        yield server


def test_every_ending_signal_at_any_moment_of_an_odometry_calibration(
        tmp_path: Path, robot: PtyServer) -> None:
    data = yaml.safe_load(SLALOM.read_text(encoding="utf-8"))
    data["safety"] = {**data.get("safety", {}), "sensor_timeout_s": 2.0,
                      "command_timeout_s": 2.0}
    data.pop("sim", None)
    mission = tmp_path / "hw.yaml"
    mission.write_text(yaml.safe_dump(data), encoding="utf-8")
    argv = ["calibrate-odometry", str(mission), "--robot", robot.path, "--distance-mm", "400",
            "--speed-mm-s", "200", "--turn-deg", "90", "--measured-mm", "400",
            "--measured-deg", "90"]
    seed, moments = _moments("calibrate-odometry", 0.0, 5.0)
    seen = []
    for after_s, sig, group in moments:
        where = f"seed {seed}: {sig.name} {'to the group' if group else ''} at {after_s:.2f} s\n"
        seen.append(_check(*_signalled(argv, tmp_path, after_s, sig, group), where))
        assert robot.sim.wheel_speeds == WheelSpeeds(left=0.0, right=0.0), where
    print(f"calibrate-odometry sweep, seed {seed}: {len(moments)} moments: {seen}")
    assert "interrupted" in seen
