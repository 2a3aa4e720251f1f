"""The serial robot under faults (issue 15, items 2, 3 and 8): closed on every way out,
exclusive, and a start-up failure still leaves a report and an event log. A simulated Create on
a real pseudo-terminal (the bytes it got, its OI mode and wheels after the run).
"""

from __future__ import annotations

import json
import socket
from collections.abc import Iterator
from pathlib import Path

import pytest

from marknav.cli.main import main
from marknav.core.errors import InputError
from marknav.robot.driver import CreateDriver
from marknav.robot.packets import OIMode
from marknav.robot.transport import open_port
from marknav.sim.pty import PtyServer
from tests.faultkit import (
    IMAGE,
    SLALOM,
    assert_left_safe,
    hardware_mission,
    marknav,
    pty_robot,
    wait_until,
)


@pytest.fixture
def robot() -> Iterator[PtyServer]:
    """A simulated Create 2 on a real pseudo-terminal."""
    with pty_robot() as server:
        yield server


def test_unwritable_events_with_a_serial_robot_exit_2_before_touching_it(
        robot: PtyServer, tmp_path: Path) -> None:
    proc = marknav("run", str(SLALOM), "--robot", robot.path, "--camera", str(IMAGE),
                   "--events", "/proc/nope/e.jsonl", cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    assert "/proc/nope" in proc.stderr and "does not exist" in proc.stderr
    assert robot.bytes_in == 0  # never opened: not left in Safe mode with its stream on


@pytest.mark.slow
def test_events_on_a_full_disk_the_robot_is_still_left_safe(robot: PtyServer,
                                                            tmp_path: Path) -> None:
    report = tmp_path / "r.json"
    proc = marknav("run", str(hardware_mission(tmp_path)), "--robot", robot.path, "--camera",
                   str(IMAGE),
                   "--events", "/dev/full", "--report", str(report), "--max-time", "1",
                   "--tree", "none", cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    assert "No space left on device" in proc.stderr
    assert json.loads(report.read_text())["reason"].startswith("time limit")
    assert_left_safe(robot)


def test_a_driver_interrupted_while_connecting_closes_itself(robot: PtyServer) -> None:
    driver = CreateDriver(robot.path, settle_s=0.01)
    original = driver._wait_first_frame

    def interrupted(timeout_s: float) -> None:
        original(timeout_s)
        raise KeyboardInterrupt

    driver._wait_first_frame = interrupted  # type: ignore[method-assign]
    with pytest.raises(KeyboardInterrupt):
        driver.connect()
    assert not driver.connected
    assert wait_until(lambda: robot.sim.mode == OIMode.PASSIVE and not robot.sim.streaming, 2)


def test_the_serial_port_is_exclusive(robot: PtyServer) -> None:
    first = open_port(robot.path, baudrate=115200)
    try:
        with pytest.raises(InputError, match="port busy"):
            open_port(robot.path, baudrate=115200)
    finally:
        first.close()
    open_port(robot.path, baudrate=115200).close()  # free again once closed


def test_a_start_up_failure_leaves_a_report_and_an_event_log(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        dead = s.getsockname()[1]  # nobody listens once closed
    report = tmp_path / "r.json"
    assert main(["run", str(SLALOM), "--robot", f"socket://127.0.0.1:{dead}", "--camera",
                 str(IMAGE), "--report", str(report)]) == 2
    err = capsys.readouterr().err
    assert "report: " in err
    data = json.loads(report.read_text())
    assert data["outcome"] == "aborted" and data["reason"].startswith("did not start: ")
    last = json.loads((tmp_path / "r.events.jsonl").read_text().splitlines()[-1])
    assert last["kind"] == "end" and last["reason"] == data["reason"]
