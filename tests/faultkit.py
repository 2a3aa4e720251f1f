"""Helpers of the fault-injection tests (``tests/*/test_*_faults.py``, the signal sweep): real
processes (``python -m marknav``), a simulated Create on a real pseudo-terminal
(:class:`~marknav.sim.pty.PtyServer`), bounded waits. No assertion in them is about speed."""

from __future__ import annotations

import contextlib
import io
import os
import resource
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import yaml

from marknav.cli.main import main
from marknav.core.clock import MonotonicClock
from marknav.robot.packets import OIMode
from marknav.sim.pty import PtyServer
from marknav.sim.simulated_create import SimulatedCreate, WheelSpeeds

ROOT = Path(__file__).resolve().parents[1]
SLALOM = ROOT / "missions" / "slalom.yaml"
IMAGE = ROOT / "tests" / "data" / "smarties.png"
ENV = {**os.environ, "PYTHONUNBUFFERED": "1", "PY_TREES_DISABLE_COLORS": "1"}


def wait_until(cond: Callable[[], bool], timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if cond():
            return True
        time.sleep(0.01)
    return cond()


def marknav(*args: str, cwd: Path, timeout: float = 90, mem_bytes: int | None = None
            ) -> subprocess.CompletedProcess[str]:
    def limit() -> None:
        if mem_bytes is not None:
            resource.setrlimit(resource.RLIMIT_AS, (mem_bytes, mem_bytes))

    return subprocess.run([sys.executable, "-m", "marknav", *args], cwd=cwd, env=ENV,
                          capture_output=True, text=True, timeout=timeout, preexec_fn=limit)


def spawn(*args: str, cwd: Path, **kw: Any) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-m", "marknav", *args], cwd=cwd, env=ENV,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


def finish(proc: subprocess.Popen[str], timeout: float = 60) -> tuple[int, str, str]:
    try:
        out, err = proc.communicate(timeout=timeout)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return proc.returncode, out, err


def hardware_mission(tmp_path: Path) -> Path:
    """The slalom with watchdogs loose enough for a loaded CI machine (these tests are about
    files and signals; the watchdogs have their own tests)."""
    data = yaml.safe_load(SLALOM.read_text(encoding="utf-8"))
    data["safety"] = {**data.get("safety", {}), "sensor_timeout_s": 2.0,
                      "command_timeout_s": 2.0}
    data.pop("sim", None)
    path = tmp_path / "hw.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return path


@contextlib.contextmanager
def pty_robot() -> Iterator[PtyServer]:
    """A simulated Create 2 on a real pseudo-terminal (each test file's ``robot`` fixture)."""
    server = PtyServer(SimulatedCreate(clock=MonotonicClock()))
    server.start()
    try:
        yield server
    finally:
        server.close()


def assert_left_safe(server: PtyServer) -> None:
    sim = server.sim
    assert sim.wheel_speeds == WheelSpeeds(left=0.0, right=0.0)
    assert sim.mode == OIMode.PASSIVE
    assert not sim.streaming


def wait_for_status(events: Path, proc: subprocess.Popen[str], timeout: float = 60) -> None:
    assert wait_until(lambda: proc.poll() is not None or (
        events.exists() and '"kind": "status"' in events.read_text()), timeout)
    assert proc.poll() is None, proc.communicate()


def slalom_with(tmp_path: Path, old: str, new: str, file: str = "m.yaml") -> Path:
    text = SLALOM.read_text(encoding="utf-8").replace(
        "world: worlds/", f"world: {SLALOM.parent}/worlds/")
    assert old in text
    path = tmp_path / file
    path.write_text(text.replace(old, new), encoding="utf-8")
    return path


def run_main(argv: list[str], cwd: Path) -> tuple[int, str]:
    """``main(argv)`` in ``cwd``: the exit code (argparse's too) and stderr."""
    err = io.StringIO()
    old = os.getcwd()
    os.chdir(cwd)
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            try:
                code = main(argv)
            except SystemExit as exc:
                code = int(exc.code or 0)
    finally:
        os.chdir(old)
    return code, err.getvalue()
