"""Fault injection: each fault of issue #15 (items 1–8, 10–15), reproduced against the real thing.

Real processes (``python -m marknav``), a simulated Create on a real pseudo-terminal
(:class:`~marknav.sim.pty.PtyServer`: the bytes the robot got, its OI mode and wheels after the
run), loopback sockets (an RFC 2217 client, an HTTP server that never answers, ``marknav
serve-camera`` frozen with SIGSTOP), real signals. Every wait is bounded; no assertion is about
speed ("a read never waits" is shown by making the wait itself fail).
"""

from __future__ import annotations

import json
import math
import os
import random
import re
import resource
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
import zlib
from collections import Counter
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml

from marknav.cli.main import main
from marknav.core.clock import MonotonicClock
from marknav.core.errors import InputError
from marknav.remote import rfc2217_bridge
from marknav.remote.rfc2217_bridge import Rfc2217Bridge
from marknav.robot import oi
from marknav.robot.driver import CreateDriver
from marknav.robot.packets import OIMode
from marknav.robot.transport import open_port
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


def mission_named(tmp_path: Path, name: str, file: str = "m.yaml") -> Path:
    text = SLALOM.read_text(encoding="utf-8")
    lines = [f"name: {json.dumps(name)}" if ln.startswith("name:") else ln
             for ln in text.splitlines()]
    text = "\n".join(lines).replace("world: worlds/", f"world: {SLALOM.parent}/worlds/")
    path = tmp_path / file
    path.write_text(text + "\n", encoding="utf-8")
    return path


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


@pytest.fixture
def robot() -> Iterator[PtyServer]:
    """A simulated Create 2 on a real pseudo-terminal."""
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


# --- 1, 15: serve-robot ---

@pytest.fixture
def bridge(robot: PtyServer) -> Iterator[Rfc2217Bridge]:
    port = open_port(robot.path, baudrate=115200, timeout=0.01)
    b = Rfc2217Bridge(port, tcp_port=0, idle_stop_s=0.3, name=robot.path).start()
    try:
        yield b
    finally:
        b.close()
        port.close()


def connect(bridge: Rfc2217Bridge) -> socket.socket:
    s = socket.create_connection(("127.0.0.1", bridge.tcp_port), timeout=3)
    s.settimeout(0.2)
    return s


def closed_by_peer(s: socket.socket, timeout: float = 5.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            if s.recv(4096) == b"":
                return True
        except TimeoutError:
            continue
        except OSError:
            return True
    return False


def test_1_idle_stop_fires_after_half_a_command(bridge: Rfc2217Bridge, robot: PtyServer,
                                                caplog: pytest.LogCaptureFixture) -> None:
    sim = robot.sim
    with connect(bridge) as client:
        client.sendall(oi.start() + oi.safe() + oi.drive_direct(left=100, right=100))
        assert wait_until(lambda: sim.wheel_speeds == WheelSpeeds(left=100.0, right=100.0), 3)
        client.sendall(bytes([145, 0]))  # half a Drive Direct, then silence, connection open
        assert wait_until(lambda: sim.wheel_speeds == WheelSpeeds(left=0.0, right=0.0), 3)
        assert bridge.client is not None  # still connected: only the wheels were stopped
    assert any("silent" in r.getMessage() for r in caplog.records)


@pytest.mark.parametrize(("args", "field"), [
    (["--idle-stop", "nan"], "--idle-stop"), (["--idle-stop", "-1"], "--idle-stop"),
    (["--baud", "7"], "--baud"), (["--port", "70000"], "--port"),
])
def test_1_serve_robot_argument_ranges(args: list[str], field: str,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["serve-robot", "--sim", *args]) == 2
    assert field in capsys.readouterr().err


def test_15_unclosed_telnet_suboption_closes_the_client(bridge: Rfc2217Bridge) -> None:
    with connect(bridge) as client:
        client.sendall(b"\xff\xfa" + b"x" * 100_000)  # IAC SB, never IAC SE
        assert closed_by_peer(client)
    assert wait_until(lambda: bridge.client is None, 3)


def test_15_random_bytes_cannot_take_over_an_oi_start_can(bridge: Rfc2217Bridge,
                                                          robot: PtyServer,
                                                          monkeypatch: pytest.MonkeyPatch
                                                          ) -> None:
    monkeypatch.setattr(rfc2217_bridge, "TAKEOVER_WAIT_S", 0.5)
    bridge.idle_stop_s = None  # only the takeover policy may stop the wheels here
    sim = robot.sim
    with connect(bridge) as first:
        first.sendall(oi.start() + oi.safe() + oi.drive_direct(left=80, right=80))
        assert wait_until(lambda: sim.wheel_speeds == WheelSpeeds(left=80.0, right=80.0), 3)
        owner = bridge.client
        noise = bytearray(random.Random(15).randbytes(64))
        noise[0] = 7  # not Start (128), not IAC
        with connect(bridge) as intruder:
            intruder.sendall(bytes(noise))
            assert closed_by_peer(intruder)
        with connect(bridge) as silent:  # says nothing: refused after TAKEOVER_WAIT_S
            assert closed_by_peer(silent)
        first.sendall(oi.drive_direct(left=80, right=80))  # keep the idle stop away
        assert bridge.client == owner
        assert sim.wheel_speeds == WheelSpeeds(left=80.0, right=80.0)  # mission not aborted
        with connect(bridge) as second:
            # (raw telnet: a 0xFF byte would need escaping, so no negative speeds here)
            second.sendall(oi.start() + oi.safe() + oi.drive_direct(left=40, right=60))
            assert closed_by_peer(first)  # the old client is cut off
            assert wait_until(lambda: sim.wheel_speeds == WheelSpeeds(left=40.0, right=60.0),
                              3)
            assert bridge.client not in (None, owner)


# --- 2, 3, 8: the serial robot: closed on every way out, exclusive, start-up reports ---

def test_2_unwritable_events_with_a_serial_robot_exit_2_before_touching_it(
        robot: PtyServer, tmp_path: Path) -> None:
    proc = marknav("run", str(SLALOM), "--robot", robot.path, "--camera", str(IMAGE),
                   "--events", "/proc/nope/e.jsonl", cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    assert "/proc/nope" in proc.stderr and "does not exist" in proc.stderr
    assert robot.bytes_in == 0  # never opened: not left in Safe mode with its stream on


@pytest.mark.slow
def test_2_12_events_on_a_full_disk_the_robot_is_still_left_safe(robot: PtyServer,
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


def test_2_a_driver_interrupted_while_connecting_closes_itself(robot: PtyServer) -> None:
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


def test_3_the_serial_port_is_exclusive(robot: PtyServer) -> None:
    first = open_port(robot.path, baudrate=115200)
    try:
        with pytest.raises(InputError, match="port busy"):
            open_port(robot.path, baudrate=115200)
    finally:
        first.close()
    open_port(robot.path, baudrate=115200).close()  # free again once closed


def test_8_a_start_up_failure_leaves_a_report_and_an_event_log(
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


# --- 4, 5: a camera server that freezes ---

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


def test_4_reads_of_a_frozen_stream_never_wait(
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
def test_5_a_run_whose_camera_freezes_aborts_cleanly(
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


# --- 6, 7: signals ---

@pytest.mark.slow
@pytest.mark.parametrize("second", [signal.SIGINT, signal.SIGTERM])
def test_6_a_second_signal_cannot_lose_the_report(robot: PtyServer, tmp_path: Path,
                                                  second: int) -> None:
    report = tmp_path / "r.json"
    proc = spawn("run", str(hardware_mission(tmp_path)), "--robot", robot.path, "--camera",
                 str(IMAGE),
                 "--report", str(report), "--tree", "none", cwd=tmp_path)
    wait_for_status(tmp_path / "r.events.jsonl", proc)
    proc.send_signal(signal.SIGINT)
    time.sleep(0.1)
    proc.send_signal(second)
    code, _out, err = finish(proc)
    assert code == 130, err
    assert "Traceback" not in err
    assert f"report: {report}" in err
    data = json.loads(report.read_text())
    assert data["outcome"] == "aborted" and data["reason"] == "interrupted (SIGINT)"
    assert_left_safe(robot)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_7_a_signal_while_importing_exits_130_without_a_traceback(tmp_path: Path,
                                                                  sig: int) -> None:
    proc = subprocess.Popen([sys.executable, "-X", "importtime", "-m", "marknav", "validate",
                             str(SLALOM)], cwd=tmp_path, env=ENV, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    assert proc.stderr is not None
    seen = []
    for line in proc.stderr:  # -X importtime: one line per finished import
        seen.append(line)
        if line.rstrip().endswith("marknav.core.outputs"):  # main() imports it after install()
            proc.send_signal(sig)
            break
    code, _out, err = finish(proc, 30)
    assert code == 130, "".join(seen[-5:]) + err
    assert "Traceback" not in err
    assert "interrupted" in err


def _run_with_injected_signal(monkeypatch: pytest.MonkeyPatch, target: str, sig: int,
                              after: bool = False) -> None:
    """Wrap ``marknav.runs.loop.run.<target>`` so that it sends ``sig`` to this process."""
    import marknav.runs.loop.run as runmod

    original = getattr(runmod, target)

    def wrapped(*args: Any, **kwargs: Any) -> Any:
        if not after:
            os.kill(os.getpid(), sig)
        result = original(*args, **kwargs)
        if after:
            os.kill(os.getpid(), sig)
        return result

    monkeypatch.setattr(runmod, target, wrapped)


@pytest.mark.parametrize(("target", "after", "reason"), [
    ("run_tree", False, "interrupted (SIGTERM)"),  # before the loop
    ("_fill_ground_truth", False, "time limit: 1 s"),  # after it (the clean-up runs whole)
    ("_plot", False, "time limit: 1 s"),  # while plotting
])
def test_7_sigterm_outside_the_loop_still_writes_everything(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture[str],
        target: str, after: bool, reason: str) -> None:
    _run_with_injected_signal(monkeypatch, target, signal.SIGTERM, after)
    report, plot = tmp_path / "r.json", tmp_path / "p.png"
    plotting = ["--plot", str(plot)] if target == "_plot" else []
    code = main(["run", str(SLALOM), "--max-time", "1", "--tree", "none", "--report",
                 str(report), *plotting])
    err = capsys.readouterr().err
    assert code == 130, err
    assert f"report: {report}" in err
    data = json.loads(report.read_text())
    assert data["reason"] == reason
    assert data["sim_final"]["wheels_mm_s"] == [0, 0]
    assert (tmp_path / "r.events.jsonl").exists()
    if plotting:
        assert plot.stat().st_size > 0


def test_7_sigint_while_loading_names_no_report(monkeypatch: pytest.MonkeyPatch,
                                                tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    import marknav.runs.loop.checks as checks

    original = checks.load_mission

    def load(path: Any, *args: Any, **kwargs: Any) -> Any:
        os.kill(os.getpid(), signal.SIGINT)
        return original(path, *args, **kwargs)

    monkeypatch.setattr(checks, "load_mission", load)  # what 'run' loads the mission with
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(SLALOM)]) == 130
    err = capsys.readouterr().err
    assert "interrupted" in err and "report:" not in err
    assert not (tmp_path / "runs").exists()


@pytest.mark.slow
def test_7_ctrl_c_while_opening_a_camera_that_never_answers(tmp_path: Path) -> None:
    with socket.socket() as listener:
        listener.bind(("127.0.0.1", 0))
        listener.listen(1)
        listener.settimeout(60)
        url = f"http://127.0.0.1:{listener.getsockname()[1]}/stream.mjpg"
        report = tmp_path / "r.json"
        proc = spawn("run", str(SLALOM), "--robot", "socket://127.0.0.1:9", "--camera", url,
                     "--report", str(report), cwd=tmp_path)
        conn, _ = listener.accept()  # it asked; it gets no answer
        with conn:
            proc.send_signal(signal.SIGINT)
            # honoured: an ignored Ctrl-C ends as exit 2 when the 5 s connect timeout fires, one
            # honoured only when OpenCV's open returns (the old way) after ~30 s
            code, _out, err = finish(proc, 15)
    assert code == 130, err
    assert "Traceback" not in err
    assert json.loads(report.read_text())["reason"] == "interrupted (SIGINT) while starting"


# --- 10: YAML and every other input file ---

def _alias_bomb() -> str:
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x]"]
    for i in range(1, 9):
        lines.append(f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 9) + "]")
    return "\n".join(lines) + "\n"


@pytest.mark.slow
def test_10_hostile_yaml_files_exit_2_naming_file_and_line(tmp_path: Path) -> None:
    files = {
        "deep.yaml": "name: " + "[" * 2000 + "]" * 2000 + "\n",
        "deepmap.yaml": "".join("  " * i + f"k{i}:\n" for i in range(600)) + "  " * 600 + "x\n",
        "recursive.yaml": "name: &a [*a]\n",
        "control.yaml": "name: a\x1bb\nroute: [red]\n",
        "bomb.yaml": _alias_bomb(),
        "big.yaml": "name: x\n" + "# padding\n" * 100_000,
    }
    for name, text in files.items():
        (tmp_path / name).write_text(text, encoding="utf-8")
    os.mkfifo(tmp_path / "fifo.yaml")
    names = [*files, "fifo.yaml", "/dev/zero", "/dev/urandom", str(tmp_path)]
    proc = marknav("validate", *names, cwd=tmp_path, timeout=60, mem_bytes=2 << 30)
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr and "MemoryError" not in proc.stderr
    err = proc.stderr
    assert "deep.yaml:1:" in err and "nested deeper than" in err
    assert "deepmap.yaml:" in err
    assert "recursive.yaml:1:" in err
    assert "control.yaml:1:8: control character U+001B" in err
    assert "bomb.yaml:" in err and "expands to more than" in err
    assert "big.yaml: too large" in err
    assert "fifo.yaml: is a pipe (FIFO)" in err
    assert "/dev/zero: is a character device" in err and "/dev/urandom: is a character" in err
    assert "is a directory" in err
    assert "\x1b" not in err


def test_10_dev_zero_as_world_and_table(tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    proc = marknav("run", str(SLALOM), "--world", "/dev/zero", cwd=tmp_path, timeout=60,
                   mem_bytes=2 << 30)
    assert proc.returncode == 2, proc.stderr
    assert "/dev/zero: is a character device" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert main(["calibrate", "/dev/urandom"]) == 2  # refused before a byte is read
    assert "/dev/urandom: is a character device" in capsys.readouterr().err


# --- 11, 12: output paths ---

@pytest.mark.parametrize("name", ["../../../tmp/i15-escape", "/tmp/i15-absolute", "a/b/c",
                                  "x" * 199 + "/"])
def test_11_the_mission_name_never_becomes_a_path(tmp_path: Path, name: str,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    mission = mission_named(tmp_path, name)
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    before = set(Path("/tmp").glob("i15-*"))
    assert main(["run", str(mission), "--max-time", "0.2", "--tree", "none"]) == 1
    assert set(Path("/tmp").glob("i15-*")) == before
    assert [p.parent for p in work.rglob("report.json")] == list((work / "runs").iterdir())
    (folder,) = (work / "runs").iterdir()
    assert folder.parent == work / "runs" and len(folder.name) <= 64 + 20


@pytest.mark.parametrize("name", ["a\u0000b", "a\nb", "a\u001b[2Jb"])
def test_11_control_characters_in_names_are_refused_and_never_printed(
        tmp_path: Path, name: str, capsys: pytest.CaptureFixture[str]) -> None:
    mission = mission_named(tmp_path, name)
    assert main(["validate", str(mission)]) == 2
    err = capsys.readouterr().err
    assert re.search(re.escape(str(mission)) + r":\d+:7: name: .*control character U\+00",
                     err), err
    assert not any(c in err for c in "\x00\x1b")


@pytest.mark.parametrize(("option", "value", "message"), [
    ("--report", "{tmp}", "is a directory"),
    ("--report", "{tmp}/missing/r.json", "does not exist"),
    ("--events", "{tmp}/missing/e.jsonl", "does not exist"),
    ("--plot", "{tmp}/missing/p.png", "does not exist"),
])
def test_12_bad_output_paths_exit_2_before_the_run(tmp_path: Path, option: str, value: str,
                                                   message: str,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    monkey_runs = tmp_path / "runs"
    assert main(["run", str(SLALOM), option, value.format(tmp=tmp_path), "--tree", "none"]) == 2
    err = capsys.readouterr().err
    assert message in err and option in err
    assert "waypoints" not in err and not monkey_runs.exists()
    assert not (tmp_path / "missing").exists()  # no folder created silently


def test_12_dot_into_a_missing_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["tree", str(SLALOM), "--dot", str(tmp_path / "no" / "t.dot")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert not (tmp_path / "no").exists()


# --- 13: an image whose header lies ---

def _png_claiming(width: int, height: int) -> bytes:
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(
            ">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(
        b"\0" * 300)) + chunk(b"IEND", b""))


@pytest.mark.parametrize("claim", [(100_000, 100_000), (30_000, 30_000)])
def test_13_an_image_claiming_a_huge_size_is_refused_before_decoding(
        tmp_path: Path, claim: tuple[int, int], capsys: pytest.CaptureFixture[str]) -> None:
    bomb = tmp_path / "bomb.png"
    bomb.write_bytes(_png_claiming(*claim))
    assert bomb.stat().st_size < 400
    for argv in (["detect", str(bomb)],
                 ["run", str(SLALOM), "--robot", "socket://127.0.0.1:9", "--camera", str(bomb),
                  "--report", str(tmp_path / "r.json")],
                 ["serve-camera", "--camera", str(bomb), "--port", "0"]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert f"{bomb}: PNG header claims {claim[0]} × {claim[1]} pixels" in err, argv


# --- 14: calibration tables ---

@pytest.mark.parametrize(("rows", "message"), [
    ("1," + "9" * 140_000 + "\n", ":2: line too long"),
    ("10,100\n20,200\n40,400\n", "grows with the radius"),
    ("10,1e200\n11,1e100\n12,1\n", ":2: distance_mm: out of range"),
    ("1,100\n1.0000000000000002,200\n1,300\n", "differ by less than 1 %"),
    ('"10,100\n', ":2: expected 2 values, got 1"),
])
def test_14_bad_calibration_tables(tmp_path: Path, rows: str, message: str,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    table = tmp_path / "t.csv"
    table.write_text("radius_px,distance_mm\n" + rows, encoding="utf-8")
    assert main(["calibrate", str(table)]) == 2
    err = capsys.readouterr().err
    assert f"{table}" in err and message in err, err


def test_14_a_spreadsheet_bom_is_accepted(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    table = tmp_path / "t.csv"
    text = (ROOT / "tests" / "data" / "paper_table1.csv").read_text(encoding="utf-8")
    table.write_bytes("\ufeff".encode() + text.replace("\n", "\r\n").encode())
    assert main(["calibrate", str(table)]) == 0
    assert "range: {model: power, a: 58957.7, b: -0.943419}" in capsys.readouterr().out


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_7_a_signal_between_a_tick_and_its_record_keeps_the_count_whole(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture[str],
        sig: int) -> None:
    """A signal that lands after the tree ticked but before the tick is logged (CI caught one:
    the report said 22 ticks, the log's last tick was n=20) is raised once the tick is written."""
    from marknav.runs.records.runlog import Recorder

    original = Recorder.panel
    calls = {"n": 0}

    def panel(self: Recorder, now: float, overruns: int) -> dict[str, Any]:
        calls["n"] += 1
        if calls["n"] == 7:  # inside the seventh tick's bookkeeping, before its record
            os.kill(os.getpid(), sig)
        return original(self, now, overruns)

    monkeypatch.setattr(Recorder, "panel", panel)
    report_path = tmp_path / "r.json"
    code = main(["run", str(SLALOM), "--max-time", "30", "--tree", "none",
                 "--report", str(report_path)])
    err = capsys.readouterr().err
    assert code == 130, err
    report = json.loads(report_path.read_text())
    assert report["reason"].startswith("interrupted")
    records = [json.loads(line) for line in
               (tmp_path / "r.events.jsonl").read_text().splitlines()]
    ticks = [r for r in records if r["kind"] == "tick"]
    assert [r["n"] for r in ticks] == list(range(7))
    assert records[-1]["ticks"] == report["ticks"] == 7
    assert report["sim_final"]["wheels_mm_s"] == [0, 0]


def test_7_a_view_that_blocks_cannot_keep_a_signal_from_stopping_the_wheels(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture[str],
) -> None:
    """The live view draws outside the runner's signal hold: a terminal that blocks (a paused
    pager, a stalled SSH session) must not keep Ctrl-C or SIGTERM from stopping the run."""
    import marknav.runs.views.display as display

    class StuckView:
        def __init__(self) -> None:
            self.updates = 0

        def update(self, state: Any, panel: Any) -> None:
            self.updates += 1
            if self.updates == 5:
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(30)  # a write that does not return

        def close(self) -> None:
            pass

    monkeypatch.setattr(display, "make_view", lambda *a, **k: StuckView())
    report_path = tmp_path / "r.json"
    t0 = time.monotonic()
    code = main(["run", str(SLALOM), "--max-time", "30", "--tree", "ascii",
                 "--report", str(report_path)])
    assert time.monotonic() - t0 < 15
    assert code == 130, capsys.readouterr().err
    report = json.loads(report_path.read_text())
    assert report["reason"] == "interrupted (SIGTERM)" and report["ticks"] == 5
    assert report["sim_final"]["wheels_mm_s"] == [0, 0]


def test_7_a_verdict_reached_in_the_tick_a_signal_lands_in_stands(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture[str],
) -> None:
    """The run's time limit is reached in the same tick as a SIGTERM: the report keeps the
    verdict (failed, time limit), the exit code says the run was interrupted."""
    from marknav.runs.records.runlog import Recorder

    original = Recorder.panel

    def panel(self: Recorder, now: float, overruns: int) -> dict[str, Any]:
        if now >= 1.0:
            os.kill(os.getpid(), signal.SIGTERM)
        return original(self, now, overruns)

    monkeypatch.setattr(Recorder, "panel", panel)
    report_path = tmp_path / "r.json"
    code = main(["run", str(SLALOM), "--max-time", "1", "--tree", "none",
                 "--report", str(report_path)])
    assert code == 130, capsys.readouterr().err
    report = json.loads(report_path.read_text())
    assert (report["outcome"], report["reason"]) == ("failed", "time limit: 1 s")
    records = [json.loads(line) for line in
               (tmp_path / "r.events.jsonl").read_text().splitlines()]
    assert records[-1]["kind"] == "end" and records[-1]["outcome"] == "failed"
    assert records[-1]["ticks"] == report["ticks"] == max(
        r["n"] for r in records if r["kind"] == "tick") + 1


# --- issue 31: what a fault sweep broke (B1-B8, serve-robot under junk, whole log records) ---

LONG_NAME = "w" * 300 + ".yaml"  # longer than any one file name the OS takes (255 bytes)


def _slalom_with(tmp_path: Path, old: str, new: str, file: str = "m.yaml") -> Path:
    text = SLALOM.read_text(encoding="utf-8").replace(
        "world: worlds/", f"world: {SLALOM.parent}/worlds/")
    assert old in text
    path = tmp_path / file
    path.write_text(text.replace(old, new), encoding="utf-8")
    return path


def _run_main(argv: list[str], cwd: Path) -> tuple[int, str]:
    """``main(argv)`` in ``cwd``: the exit code (argparse's too) and stderr."""
    import contextlib
    import io

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


@pytest.mark.parametrize("command", [
    ["validate"], ["tree"], ["run", "--tree", "none", "--max-time", "1"],
])
def test_b1_a_missions_world_name_too_long_is_exit_2_at_its_line(tmp_path: Path,
                                                                 command: list[str]) -> None:
    mission = _slalom_with(tmp_path, "world: " + str(SLALOM.parent) + "/worlds/slalom-world.yaml",
                           "world: " + LONG_NAME)
    code, err = _run_main([command[0], str(mission), *command[1:]], tmp_path)
    assert code == 2, err
    assert "Traceback" not in err and "OSError" not in err
    line = next(i for i, ln in enumerate(mission.read_text().splitlines(), 1)
                if ln.startswith("  world:"))
    assert f"{mission}:{line}:" in err and "sim.world" in err, err
    assert "name too long" in err.lower()


@pytest.mark.parametrize("argv", [
    ["run", str(SLALOM), "--world", LONG_NAME, "--tree", "none"],
    ["validate", str(SLALOM), "--world", LONG_NAME],
    ["replay", LONG_NAME, "--at", "0"],
    ["view", LONG_NAME + ".rrd", "--save", "x.rrd"],
    ["validate", LONG_NAME],
    ["detect", LONG_NAME],
    ["calibrate", LONG_NAME],
    ["calibrate-camera", LONG_NAME, LONG_NAME + "1", LONG_NAME + "2", "--board", "9x6",
     "--square-mm", "25"],
    ["serve-camera", "--camera", LONG_NAME, "--port", "0"],
])
def test_b2_any_path_too_long_is_exit_2_naming_it(tmp_path: Path, argv: list[str]) -> None:
    code, err = _run_main(argv, tmp_path)
    assert code == 2, err
    assert "Traceback" not in err and "OSError" not in err
    assert LONG_NAME[:40] in err and "name too long" in err.lower(), err


def test_b3_a_list_where_a_name_belongs_is_exit_2_at_its_line(tmp_path: Path) -> None:
    """``robot: {model: [create2]}`` without ``wheel_base_mm``: the model was used as a dict key
    before its type was checked (TypeError: unhashable type: 'list')."""
    mission = _slalom_with(tmp_path, "  model: create2\n  wheel_base_mm: 235\n",
                           "  model: [create2]\n")
    for command in (["validate"], ["tree"], ["run", "--tree", "none", "--max-time", "1"],
                    ["evaluate", "--runs", "1", "--jobs", "1"]):
        code, err = _run_main([command[0], str(mission), *command[1:]], tmp_path)
        assert code == 2, (command, err)
        assert "Traceback" not in err and "TypeError" not in err
        assert f"{mission}:21:" in err and "robot.model" in err, err


def _fifo(tmp_path: Path, name: str) -> Path:
    path = tmp_path / name
    os.mkfifo(path)
    return path


def test_b4_a_fifo_as_the_camera_is_refused_at_once(robot: PtyServer, tmp_path: Path) -> None:
    """A FIFO with no writer blocked ``run`` in OpenCV's open() (signals could not end it)."""
    fifo = _fifo(tmp_path, "fifo.avi")
    t0 = time.monotonic()
    proc = marknav("run", str(hardware_mission(tmp_path)), "--robot", robot.path,
                   "--camera", str(fifo), "--report", str(tmp_path / "r.json"), "--tree", "none",
                   cwd=tmp_path, timeout=60)
    assert time.monotonic() - t0 < 30
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    assert f"{fifo}: is a pipe (FIFO)" in proc.stderr
    assert robot.bytes_in == 0  # refused before the robot was opened


def test_b4_serve_camera_refuses_a_fifo(tmp_path: Path) -> None:
    fifo = _fifo(tmp_path, "fifo.avi")
    proc = marknav("serve-camera", "--camera", str(fifo), "--port", "0", cwd=tmp_path,
                   timeout=60)
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    assert f"{fifo}: is a pipe (FIFO)" in proc.stderr


@pytest.mark.parametrize("what", ["world", "replay", "images", "table"])
def test_b4_no_path_opens_a_fifo(tmp_path: Path, what: str) -> None:
    """Every file marknav reads goes through one reader that refuses FIFOs before opening."""
    if what == "world":
        argv = ["run", str(SLALOM), "--world", str(_fifo(tmp_path, "w.yaml")), "--tree", "none"]
    elif what == "replay":
        argv = ["replay", str(_fifo(tmp_path, "r.events.jsonl")), "--at", "0"]
    elif what == "images":
        argv = ["calibrate-camera", *(str(_fifo(tmp_path, f"board{i}.png")) for i in range(3)),
                "--board", "9x6", "--square-mm", "25"]
    else:
        argv = ["calibrate", str(_fifo(tmp_path, "t.csv"))]
    proc = marknav(*argv, cwd=tmp_path, timeout=60)
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    assert "is a pipe (FIFO)" in proc.stderr


@pytest.mark.parametrize(("sig", "delay"), [
    (signal.SIGINT, 0.0), (signal.SIGINT, 0.002), (signal.SIGINT, 0.01), (signal.SIGINT, 0.03),
    (signal.SIGINT, 0.1), (signal.SIGTERM, 0.0), (signal.SIGTERM, 0.05),
])
def test_b6_a_signal_in_the_first_tenth_of_a_second_exits_130(tmp_path: Path, sig: int,
                                                              delay: float) -> None:
    """From marknav's first imports on (here: argparse, which only the command line needs), a
    signal exits 130 without a traceback. Before, the command line's own imports (argparse,
    logging: ≈ 10 ms) ran before any handler: a KeyboardInterrupt traceback, exit 1 or -2, and
    SIGTERM killed the process. (The interpreter's own start-up before the first marknav line,
    ≈ 15 ms here, is out of marknav's reach.)"""
    proc = subprocess.Popen([sys.executable, "-X", "importtime", "-m", "marknav", "run",
                             str(SLALOM), "--tree", "none", "--max-time", "1",
                             "--report", str(tmp_path / "r.json")], cwd=tmp_path, env=ENV,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stderr is not None
    seen = []
    for line in proc.stderr:  # -X importtime: one line per finished import
        seen.append(line)
        if line.rstrip().endswith(" argparse"):
            time.sleep(delay)
            proc.send_signal(sig)
            break
    code, _out, err = finish(proc, 60)
    assert code == 130, "".join(seen[-5:]) + err
    assert "Traceback" not in err and "Exception" not in err, err
    assert "interrupted" in err


@pytest.mark.parametrize(("target", "when"), [
    ("check_build", "while checking the mission"),  # building the tree
    ("check_world", "while checking the mission"),  # loading the world
    ("_request", "while checking the mission"),  # choosing the run folder
    ("prepare", "while preparing the detector"),  # loading the compiled loops
    ("execute", "while starting"),  # the run's first step, before its own files
])
def test_b7_a_signal_once_the_mission_was_read_leaves_a_report_and_a_log(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path, target: str, when: str) -> None:
    """The mission file is read; a SIGINT lands while it is being checked (1.9–2.3 s into a
    real run): exit 130, and the report and the event log say aborted, interrupted."""
    import marknav.cli.run as cmd_run
    import marknav.runs.loop.checks as checks
    import marknav.runs.loop.run as runmod

    module = {"check_build": checks, "check_world": checks, "_request": cmd_run,
              "prepare": runmod, "execute": runmod}[target]
    original = getattr(module, target)

    def interrupted(*args: Any, **kwargs: Any) -> Any:
        os.kill(os.getpid(), signal.SIGINT)
        return original(*args, **kwargs)

    monkeypatch.setattr(module, target, interrupted)
    if module is runmod:
        monkeypatch.setattr(cmd_run, target, interrupted, raising=False)
    monkeypatch.chdir(tmp_path)
    code, err = _run_main(["run", str(SLALOM), "--tree", "none"], tmp_path)
    assert code == 130, err
    assert "Traceback" not in err
    folders = list((tmp_path / "runs").iterdir())
    assert len(folders) == 1, folders
    report = json.loads((folders[0] / "report.json").read_text())
    assert report["outcome"] == "aborted", report
    assert report["reason"] == f"interrupted (SIGINT) {when}"
    records = [json.loads(line) for line in
               (folders[0] / "report.events.jsonl").read_text().splitlines()]
    assert records[-1]["kind"] == "end" and records[-1]["reason"] == report["reason"]
    assert f"interrupted {when}" in err
    assert f"report: runs/{folders[0].name}/report.json" in err


def test_b8_a_signal_during_the_final_write_keeps_the_outcome_and_exits_130(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """The run ended (time limit); a SIGTERM lands while the report is being written: the
    report is written whole with the run's outcome, the log ends with it, exit 130."""
    from marknav.runs.records.report import RunReport

    original = RunReport.write

    def write(self: RunReport, path: Any) -> Any:
        os.kill(os.getpid(), signal.SIGTERM)
        return original(self, path)

    monkeypatch.setattr(RunReport, "write", write)
    report_path = tmp_path / "r.json"
    code, err = _run_main(["run", str(SLALOM), "--max-time", "1", "--tree", "none",
                           "--report", str(report_path)], tmp_path)
    assert code == 130, err
    assert "Traceback" not in err
    report = json.loads(report_path.read_text())
    assert (report["outcome"], report["reason"]) == ("failed", "time limit: 1 s")
    assert report["sim_final"]["wheels_mm_s"] == [0, 0]
    last = json.loads((tmp_path / "r.events.jsonl").read_text().splitlines()[-1])
    assert last["kind"] == "end" and last["outcome"] == "failed"


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_b8_a_signal_after_the_command_returned_exits_130(tmp_path: Path, sig: int) -> None:
    """The signal lands while the process exits, after the files were written (an atexit
    handler sends it: the same moment every time). It used to be ignored (exit 0 or 1)."""
    report = tmp_path / "r.json"
    code = (f"import atexit, os, sys\n"
            f"atexit.register(lambda: os.kill(os.getpid(), {int(sig)}))\n"
            f"sys.argv = ['marknav', 'run', {str(SLALOM)!r}, '--max-time', '1', '--tree',"
            f" 'none', '--report', {str(report)!r}]\n"
            "from marknav.__main__ import entry\n"
            "entry()\n")
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=ENV,
                          capture_output=True, text=True, timeout=90)
    assert proc.returncode == 130, proc.stderr
    assert "Traceback" not in proc.stderr
    assert json.loads(report.read_text())["reason"] == "time limit: 1 s"  # the run's verdict
    assert json.loads((tmp_path / "r.events.jsonl").read_text().splitlines()[-1])["kind"] == "end"


def test_b5_a_dask_address_that_never_answers_is_exit_2_within_seconds(tmp_path: Path) -> None:
    """A peer that accepts the connection and says nothing (a wrong port, a stuck scheduler):
    the connect used to wait for ever; a failed client printed a clean-up traceback after the
    exit-2 message."""
    pytest.importorskip("distributed")
    with socket.socket() as listener:
        listener.bind(("127.0.0.1", 0))
        listener.listen(8)
        address = f"tcp://127.0.0.1:{listener.getsockname()[1]}"
        t0 = time.monotonic()
        proc = marknav("evaluate", str(SLALOM), "--runs", "1", "--dask", address, cwd=tmp_path,
                       timeout=60)
        took = time.monotonic() - t0
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr and "Exception" not in proc.stderr, proc.stderr
    assert f"--dask: cannot connect to the Dask scheduler at {address}" in proc.stderr
    lines = proc.stderr.splitlines()
    assert lines[-1].startswith("marknav evaluate: error: --dask")  # the one message, last
    assert all(line.startswith("evaluate slalom: 0/1 runs done") for line in lines[:-1]), lines
    assert took < 30  # 3 s for the scheduler to answer, plus start-up on a loaded machine


def test_the_event_log_never_keeps_half_a_record_when_the_disk_fills(tmp_path: Path) -> None:
    """A file that stops taking bytes in the middle of a record (a full disk; here the file
    size limit, RLIMIT_FSIZE: the write takes what fits, then EFBIG): the log ends with the last
    whole record, and says why it stopped."""
    path = tmp_path / "e.jsonl"
    code = ("import resource, sys\n"
            "resource.setrlimit(resource.RLIMIT_FSIZE, (1000, 1000))\n"
            "from marknav.runs.records.report import EventLog\n"
            f"log = EventLog({str(path)!r})\n"
            "for i in range(100):\n"
            "    log.write(i * 0.05, 'tick', n=i, pad='x' * 37)\n"
            "log.close()\n"
            "print(log.error)\n")
    proc = subprocess.run([sys.executable, "-c", code], env=ENV, capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert "File too large" in proc.stdout
    data = path.read_text()
    assert 0 < len(data) <= 1000 and data.endswith("\n"), data[-80:]
    records = [json.loads(line) for line in data.splitlines()]
    assert [r["n"] for r in records] == list(range(len(records)))


# --- serve-robot under a crowd of junk clients ---

JUNK_CLIENTS = 200


def _junk_client(port: int, k: int, stop: threading.Event) -> None:
    """Connect again and again; half say nothing, half send random bytes (never OI Start
    or a telnet command first): each kept open until the server closes it."""
    rng = random.Random(k)
    while not stop.is_set():
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=2) as s:
                if k % 2:
                    noise = bytearray(rng.randbytes(48))
                    noise[0] = rng.choice([b for b in range(256) if b not in (128, 255)])
                    s.sendall(bytes(noise))
                s.settimeout(0.2)
                while not stop.is_set():
                    try:
                        if s.recv(4096) == b"":
                            break
                    except TimeoutError:
                        continue
        except OSError:
            time.sleep(0.05)


def heard_among_junk(url: str, port: int, junk: int = JUNK_CLIENTS) -> float:
    """Seconds from a real client's connect to the robot's first answer, while ``junk`` junk
    clients keep connecting to the same bridge."""
    import serial

    stop = threading.Event()
    threads = [threading.Thread(target=_junk_client, args=(port, k, stop), daemon=True)
               for k in range(junk)]
    for t in threads:
        t.start()
    try:
        time.sleep(1.0)  # the crowd is there first
        t0 = time.monotonic()
        port_ = serial.serial_for_url(url, baudrate=115200, timeout=0.1)
        try:
            port_.write(oi.start() + oi.safe() + oi.sensors(7, model=oi.Model.CREATE2))
            got = b""
            while not got and time.monotonic() - t0 < 90:
                got = port_.read(1)
            return time.monotonic() - t0 if got else math.inf
        finally:
            port_.close()
    finally:
        stop.set()
        for t in threads:
            t.join(timeout=5)


def test_serve_robot_hears_a_real_client_among_200_junk_clients(tmp_path: Path) -> None:
    """The sweep measured up to 62 s (a listen backlog of 2 overflowed: the real client's
    connection attempts were dropped and retried after 1, 3, 7 … s; the first junk connection
    held the robot). Junk is now dropped fast and the real client answered at once."""
    proc = spawn("serve-robot", "--sim", "--port", "0", cwd=tmp_path)
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        url = line.split(" at ")[-1].strip()
        assert url.startswith("rfc2217://"), line
        heard = heard_among_junk(url, int(url.rsplit(":", 1)[1]))
        print(f"serve-robot: a real client heard after {heard:.3f} s among {JUNK_CLIENTS} "
              "junk clients")
        # ≈ 0.4 s (pyserial's RFC 2217 negotiation alone: ≈ 0.35 s); the issue asks for 2 s,
        # this allows for a loaded CI machine
        assert heard < 5.0, heard
    finally:
        proc.send_signal(signal.SIGINT)
        code, _out, err = finish(proc, 30)
    assert code == 130, err
    assert "Traceback" not in err


# --- the signal sweep: every ending signal at random moments of a whole `run` ---

SWEEP_MOMENTS = int(os.environ.get("MARKNAV_SWEEP_MOMENTS", "14"))


def _log_has(events: Path, kind: str) -> bool:
    """The event log's last few records include one of ``kind``."""
    try:
        with open(events, "rb") as fh:
            fh.seek(max(0, os.path.getsize(events) - 2000))
            return f'"kind": "{kind}"'.encode() in fh.read()
    except OSError:
        return False


def _sweep_run(tmp_path: Path, k: int, anchor: str, offset: float, sig: int
               ) -> tuple[int, str, bool, float]:
    """``run`` the slalom and signal it ``offset`` s after ``anchor``: "start" (marknav's first
    line ran: its entry point imported :mod:`marknav.core.signals`), "events" (the event log
    appeared: the run is starting), "tick" (the loop runs), "end" (the log's end record: the
    final write is under
    way), "report" (the report is written: the command is returning), "never". Exit code,
    stderr, whether it was still running when signalled, and how soon it ended after that."""
    report = tmp_path / f"r{k}.json"
    events = tmp_path / f"r{k}.events.jsonl"
    proc = subprocess.Popen([sys.executable, "-X", "importtime", "-m", "marknav", "run",
                             str(SLALOM), "--tree", "none", "--report", str(report),
                             "--max-time", "1"], cwd=tmp_path, env=ENV, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    lines: list[str] = []
    started = threading.Event()

    def read_stderr() -> None:  # -X importtime: one line per import, as it finishes
        assert proc.stderr is not None
        for line in proc.stderr:
            lines.append(line)
            if line.rstrip().endswith(" marknav.core.signals"):
                started.set()

    reader = threading.Thread(target=read_stderr, daemon=True)
    reader.start()
    seen = {"start": started.is_set, "events": events.exists,
            "tick": lambda: _log_has(events, "tick"), "end": lambda: _log_has(events, "end"),
            "report": report.exists,
            "never": lambda: False}[anchor]
    running = False
    exited_within = math.inf  # seconds from the signal to the process's end
    if anchor != "never":
        deadline = time.monotonic() + 60
        while not seen() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.002)
        time.sleep(offset)
        running = proc.poll() is None and not _zombie(proc.pid)
        if running:
            proc.send_signal(sig)
            sent = time.monotonic()
            while proc.poll() is None and not _zombie(proc.pid) and time.monotonic() < sent + 1:
                time.sleep(0.001)
            exited_within = time.monotonic() - sent
    try:
        proc.wait(90)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    reader.join(10)
    err = "".join(ln for ln in lines if not ln.startswith("import time:"))
    return proc.returncode, err, running, exited_within


def _zombie(pid: int) -> bool:
    """The process has ended (its exit code is set) but was not collected yet (Linux)."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] == "Z"
    except (OSError, IndexError):
        return False


def test_signal_sweep_over_the_whole_life_of_a_run(tmp_path: Path) -> None:
    """A signal at any moment of ``run`` — start-up, reading and checking the mission, the run,
    the final write, the exit — ends it with 130 and no traceback; once the mission was read,
    the report and the log exist, the log ends with its ``end`` record and, where the simulated
    robot had been started, its wheels were left at 0. The moments are random within each
    part of the run's life (found by what the run has written so far), from marknav's first
    line on: the interpreter's own start-up before it (≈ 15 ms idle, over 100 ms on a loaded
    machine) is Python's, not marknav's (docs/architecture.md, Signals)."""
    from concurrent.futures import ThreadPoolExecutor

    seed = int(os.environ.get("MARKNAV_SWEEP_SEED", random.randrange(10**6)))
    rng = random.Random(seed)
    code, err, _, _ = _sweep_run(tmp_path, 0, "never", 0.0, signal.SIGINT)
    assert code == 1 and "time limit" in err, err  # undisturbed, the run fails its time limit
    parts = [("start", 0.0, 0.3)] * 3 + [("start", 0.3, 1.5)] * 2 + [("events", 0.0, 0.3)] * 2
    parts += [("tick", 0.0, 0.15)] * 3 + [("end", 0.0, 0.01)] * 2 + [("report", 0.0, 0.005)] * 2
    while len(parts) < SWEEP_MOMENTS:
        parts.append(rng.choice(parts))
    moments = [(anchor, rng.uniform(lo, hi)) for anchor, lo, hi in parts[:SWEEP_MOMENTS]]
    from marknav.core.signals import ENDING_SIGNALS  # every ending signal, in turn

    sigs = [ENDING_SIGNALS[k % len(ENDING_SIGNALS)] for k in range(len(moments))]
    with ThreadPoolExecutor(2) as pool:
        results = list(pool.map(lambda k: _sweep_run(tmp_path, k + 1, *moments[k], sigs[k]),
                                range(len(moments))))
    phases: Counter[str] = Counter()
    for k, ((anchor, offset), (code, err, running, exited_within)) in enumerate(
            zip(moments, results, strict=True), start=1):
        where = f"seed {seed}, moment {k}: {offset:.3f} s after {anchor}, {sigs[k - 1]!r}\n{err}"
        assert "Traceback" not in err and "Exception" not in err, where
        report = tmp_path / f"r{k}.json"
        events = tmp_path / f"r{k}.events.jsonl"
        if not running or (code == 1 and exited_within < 0.05 and report.exists()
                           and "interrupted" not in err):
            # It had ended, or was ending: os._exit called, the kernel freeing it (≈ 10 ms;
            # a signal is not delivered then and the exit code is set): the run's own result.
            assert code == 1 and "time limit" in err, where
            phases["after the process ended"] += 1
            continue
        assert code == 130, where
        if not report.exists():  # signalled before the mission was read: nothing written
            assert not events.exists() and "report:" not in err, where
            phases["start-up or reading the mission"] += 1
            continue
        data = json.loads(report.read_text())
        last = json.loads(events.read_text().splitlines()[-1])
        assert last["kind"] == "end" and last["reason"] == data["reason"], where
        if data.get("sim_final") is not None:
            assert data["sim_final"]["wheels_mm_s"] == [0, 0], where
        if data["reason"].startswith("interrupted") and data["reason"].endswith(
                ("while checking the mission", "while preparing the detector",
                 "while starting")):
            phases["checks and start"] += 1
        elif data["reason"].startswith("interrupted"):
            phases["the run"] += 1
        else:  # the verdict was reached: it stands, the exit code says "signalled"
            assert (data["outcome"], data["reason"]) == ("failed", "time limit: 1 s"), where
            phases["final write or exit"] += 1
    print(f"signal sweep, seed {seed}: {len(moments)} moments: {dict(phases)}")
    assert sum(phases.values()) == len(moments)
