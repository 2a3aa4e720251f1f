"""An MJPEG camera server that freezes (issue 15, items 4 and 5): reads of the frozen stream
never wait, the stream is read again when the server comes back, and a run whose camera freezes
aborts cleanly with the robot left safe. ``marknav serve-camera`` frozen with SIGSTOP.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from marknav.sim.pty import PtyServer
from tests.faultkit import (
    IMAGE,
    assert_left_safe,
    finish,
    hardware_mission,
    pty_robot,
    spawn,
    wait_for_status,
    wait_until,
)


@pytest.fixture
def robot() -> Iterator[PtyServer]:
    """A simulated Create 2 on a real pseudo-terminal."""
    with pty_robot() as server:
        yield server


@pytest.fixture
def camera_server(tmp_path: Path) -> Iterator[tuple[subprocess.Popen[str], str]]:
    proc = spawn("serve-camera", "--camera", str(IMAGE), "--port", "0", "--fps", "20",
                 cwd=tmp_path)
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        url = line.split(" at ")[-1].strip()
        assert url.startswith("http://"), line
        yield proc, url
    finally:
        os.kill(proc.pid, signal.SIGCONT)
        proc.terminate()
        finish(proc, 10)


def test_reads_of_a_frozen_stream_never_wait(
        camera_server: tuple[subprocess.Popen[str], str]) -> None:
    from marknav.vision.sources import open_source

    server, url = camera_server
    src = open_source(url, timeout_s=0.0)  # as the run opens it
    try:
        assert wait_until(lambda: src.read() is not None, 5)
        os.kill(server.pid, signal.SIGSTOP)
        time.sleep(0.3)
        cond = src._cond  # type: ignore[attr-defined]

        def no_waiting(*args: object, **kwargs: object) -> bool:
            raise AssertionError("a control-cycle read waited for a frame")

        cond.wait_for = no_waiting  # the grabber thread only notifies; reads must not wait
        frames = [src.read() for _ in range(20)]
        assert sum(f is not None for f in frames) <= 1  # at most one already in hand
        del cond.wait_for
        assert src._thread.is_alive()  # type: ignore[attr-defined]  # still trying
        os.kill(server.pid, signal.SIGCONT)
        assert wait_until(lambda: src.read() is not None, 10)  # reconnects when it comes back
    finally:
        os.kill(server.pid, signal.SIGCONT)
        src.close()


@pytest.mark.slow
def test_a_run_whose_camera_freezes_aborts_cleanly(
        camera_server: tuple[subprocess.Popen[str], str], robot: PtyServer,
        tmp_path: Path) -> None:
    server, url = camera_server
    report = tmp_path / "r.json"
    proc = spawn("run", str(hardware_mission(tmp_path)), "--robot", robot.path, "--camera", url,
                 "--report",
                 str(report), "--tree", "none", cwd=tmp_path)
    wait_for_status(tmp_path / "r.events.jsonl", proc)
    os.kill(server.pid, signal.SIGSTOP)
    code, _out, err = finish(proc, 60)
    assert code == 1, err  # not 139: no segfault
    assert "Traceback" not in err
    assert "camera lost" in json.loads(report.read_text())["reason"]
    assert_left_safe(robot)
