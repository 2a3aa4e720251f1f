"""The serial line across the network: the real driver on ``rfc2217://`` through pyserial's
RFC 2217 ``PortManager`` (``marknav serve-robot``'s bridge) in front of the simulated Create.

Everything runs on 127.0.0.1 in real time; every wait is bounded.
"""

from __future__ import annotations

import logging
import os
import re
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest
import serial

from marknav.cli import main as cli
from marknav.core.clock import MonotonicClock
from marknav.core.errors import InputError
from marknav.planning.kinematics import WheelSpeeds
from marknav.remote.rfc2217_bridge import OIFramer, Rfc2217Bridge
from marknav.robot import oi
from marknav.robot.driver import CreateDriver
from marknav.robot.oi import Model, OIMode, Opcode
from marknav.robot.transport import SerialPort, open_port
from marknav.sim import protocol_createsim
from marknav.sim.pty import PtyServer
from marknav.sim.simulated_create import SimulatedCreate

#: pyserial's rfc2217 client refuses ``write_timeout`` (NotImplementedError), which
#: ``transport.open_port`` passes by default; see test_open_port_default_on_rfc2217.


def wait_until(predicate: Callable[[], bool], timeout: float = 2.0) -> bool:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.005)
    return True


def drive_for(driver: CreateDriver, seconds: float, *, left: float, right: float) -> None:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        assert driver.drive(left=left, right=right)
        time.sleep(0.02)


class Rig:
    """A real-time simulated Create behind an RFC 2217 bridge on 127.0.0.1:0."""

    def __init__(self, model: Model = Model.CREATE2, *, idle_stop_s: float | None = 1.0) -> None:
        self.sim = SimulatedCreate(model=model, clock=MonotonicClock())
        self.sim_url = protocol_createsim.register(self.sim)
        self.port: Any = open_port(self.sim_url, baudrate=model.default_baudrate, timeout=0.01)
        self.bridge = Rfc2217Bridge(self.port, model=model, tcp_port=0,
                                    idle_stop_s=idle_stop_s).start()

    def driver(self, **kwargs: object) -> CreateDriver:
        return CreateDriver(self.bridge.url, settle_s=0.02,
                            **kwargs)  # type: ignore[arg-type]

    def close(self) -> None:
        self.bridge.close()
        self.port.close()
        protocol_createsim.unregister(self.sim_url.split("//")[1])


@pytest.fixture
def rig() -> Iterator[Rig]:
    r = Rig()
    yield r
    r.close()


def test_driver_drives_the_simulated_create_over_rfc2217(rig: Rig) -> None:
    sim = rig.sim
    assert rig.bridge.url == f"rfc2217://127.0.0.1:{rig.bridge.tcp_port}"
    assert rig.bridge.tcp_port > 0
    with rig.driver() as driver:
        assert rig.bridge.client is not None
        assert sim.mode is OIMode.SAFE and sim.streaming
        assert driver.safety_state == "ready"
        t0 = time.monotonic()
        drive_for(driver, 0.6, left=200, right=200)
        assert sim.wheel_speeds == WheelSpeeds(left=200.0, right=200.0)
        driver.stop()
        wheels_on_s = time.monotonic() - t0  # at most: the machine's load only adds to it
        assert wait_until(lambda: sim.wheel_speeds == WheelSpeeds(left=0.0, right=0.0), 1.0)
        # odometry came back through the stream: two fresh frames after the stop
        driver.wait_for_sensors(1.0, after_frame=driver.frames_received + 2)
        truth, believed = sim.pose, driver.pose()
        # it moved forward, no further than 200 mm/s for as long as the wheels were on (about
        # 0.6 s; how long exactly is the machine's, so no lower bound on the distance)
        assert 0.0 < truth.y <= 200.0 * wheels_on_s + 1.0
        assert abs(believed.y - truth.y) < 5.0
        assert abs(believed.x - truth.x) < 1.0
        assert driver.frames_received >= 30  # a frame every 15 ms
        assert driver.parser.bad_frames == 0
        # backwards: negative speeds put 0xFF bytes (telnet IAC) in the stream; they arrive intact
        drive_for(driver, 0.3, left=-100, right=-100)
        driver.stop()
        driver.wait_for_sensors(1.0, after_frame=driver.frames_received + 2)
        assert driver.parser.bad_frames == 0
        assert abs(driver.pose().y - sim.pose.y) < 5.0
        assert driver.link_error is None
    # close(): zero wheels, pause the stream, back to Passive, through the bridge
    assert wait_until(lambda: sim.mode is OIMode.PASSIVE and not sim.streaming, 1.0)
    assert sim.wheel_speeds == WheelSpeeds(left=0.0, right=0.0)
    assert rig.bridge.bytes_from_robot > 30 * 55
    assert rig.bridge.device_error is None


def test_rfc2217_carries_the_baud_rate_to_the_device() -> None:
    rig = Rig(Model.CREATE1)
    try:
        rig.port.baudrate = 9600  # the bridge's side starts elsewhere
        with rig.driver(model="create1"):
            assert rig.port.baudrate == 57600  # SET-BAUDRATE from the client (RFC 2217 §3)
            assert rig.sim.mode is OIMode.SAFE
    finally:
        rig.close()


def test_a_vanished_client_stops_the_wheels(rig: Rig) -> None:
    sim = rig.sim
    driver = rig.driver()
    driver.connect()
    try:
        drive_for(driver, 0.2, left=150, right=250)
        assert sim.wheel_speeds == WheelSpeeds(left=150.0, right=250.0)
        stops = rig.bridge.stops_sent
        # the network goes away under the driver: no zero, no Start, nothing
        raw = driver._port
        assert isinstance(raw, serial.rfc2217.Serial)
        driver._stop_reader.set()
        raw._socket.shutdown(socket.SHUT_RDWR)
        raw._socket.close()
        assert wait_until(lambda: sim.wheel_speeds == WheelSpeeds(left=0.0, right=0.0), 1.0)
        assert wait_until(lambda: rig.bridge.stops_sent == stops + 1, 1.0)
        assert wait_until(lambda: rig.bridge.client is None, 1.0)
        assert sim.mode is OIMode.SAFE  # only the wheels were stopped
    finally:
        driver._closed = True  # the link is gone: nothing left to close politely
        driver._abandon_port()


def test_a_half_sent_command_is_completed_before_the_stop(rig: Rig) -> None:
    sim = rig.sim
    client = serial.serial_for_url(rig.bridge.url, baudrate=115200, timeout=0.05)
    try:
        client.write(oi.start() + oi.safe() + oi.drive_direct(left=120, right=80))
        assert wait_until(lambda: sim.wheel_speeds == WheelSpeeds(left=120.0, right=80.0), 1.0)
        client.write(oi.drive_direct(left=300, right=300)[:3])  # [145][right hi][right lo]
        time.sleep(0.1)
        # the robot waits for the 2 missing bytes
        assert sim.wheel_speeds == WheelSpeeds(left=120.0, right=80.0)
    finally:
        client.close()
    assert wait_until(lambda: sim.wheel_speeds == WheelSpeeds(left=0.0, right=0.0), 1.0)
    drives = [c for c in sim.commands if c.opcode == Opcode.DRIVE_DIRECT]
    # the half command got its 2 missing bytes as zeros (left 0), then the stop came whole
    assert [c.data for c in drives[-2:]] == [bytes([1, 44, 0, 0]), bytes(4)]


def test_a_silent_client_gets_the_wheels_stopped_but_stays_connected(
        caplog: pytest.LogCaptureFixture) -> None:
    rig = Rig(idle_stop_s=0.3)
    caplog.set_level(logging.INFO, logger="marknav.remote.rfc2217_bridge")
    try:
        sim = rig.sim
        client = serial.serial_for_url(rig.bridge.url, baudrate=115200, timeout=0.05)
        try:
            client.write(oi.start() + oi.safe() + oi.drive_direct(left=100, right=100))
            assert wait_until(lambda: sim.wheel_speeds == WheelSpeeds(left=100.0, right=100.0), 1.0)
            # a client that keeps talking (every 50 ms, well inside the 0.3 s) is never stopped
            for _ in range(12):
                client.write(oi.drive_direct(left=100, right=100))
                time.sleep(0.05)
            assert rig.bridge.stops_sent == 0
            assert sim.wheel_speeds == WheelSpeeds(left=100.0, right=100.0)
            # silent, it is: once, with the reason logged (no wall-clock bound asserted)
            # (the bridge thread writes the stop, then counts it, then logs it: wait for all three)
            def stopped_messages() -> list[str]:
                return [r.getMessage() for r in caplog.records
                        if r.getMessage().startswith("robot stopped")]
            assert wait_until(lambda: sim.wheel_speeds == WheelSpeeds(left=0.0, right=0.0), 5.0)
            assert wait_until(lambda: len(stopped_messages()) >= 1, 5.0)
            assert rig.bridge.stops_sent == 1
            assert stopped_messages() == [
                f"robot stopped: client {rig.bridge.client} silent for 0.3 s"]
            assert [c.data for c in sim.commands if c.opcode == Opcode.DRIVE_DIRECT][-1] == bytes(4)
            time.sleep(0.5)  # one stop per silence, not one every 0.3 s
            assert rig.bridge.stops_sent == 1
            client.write(oi.drive_direct(left=-50, right=50))  # still connected
            assert wait_until(lambda: sim.wheel_speeds == WheelSpeeds(left=-50.0, right=50.0), 1.0)
            client.write(oi.sensors(35, model=Model.CREATE2))  # OI mode, through the bridge
            assert client.read(1) == bytes([OIMode.SAFE])
        finally:
            client.close()
    finally:
        rig.close()


def test_a_new_client_takes_over_and_the_old_one_is_cut_off(rig: Rig) -> None:
    sim = rig.sim
    first = rig.driver()
    first.connect()
    try:
        drive_for(first, 0.1, left=200, right=200)
        with rig.driver() as second:
            assert wait_until(lambda: first.link_error is not None, 2.0)
            assert first.safety_state == "fault"
            drive_for(second, 0.1, left=-80, right=80)
            assert sim.wheel_speeds == WheelSpeeds(left=-80.0, right=80.0)
            assert rig.bridge.clients_served == 2
    finally:
        first.close()
    assert wait_until(lambda: sim.wheel_speeds == WheelSpeeds(left=0.0, right=0.0), 1.0)


@pytest.mark.skipif(not hasattr(os, "openpty"), reason="needs POSIX ptys")
def test_bridge_in_front_of_a_serial_device_without_modem_lines() -> None:
    """A pty (``marknav sim-robot --pty``) has no CTS/DSR/DTR/RTS: the negotiation must not fail
    on it, and the bytes must go through unchanged."""
    sim = SimulatedCreate(clock=MonotonicClock())
    with PtyServer(sim) as pty:
        device = open_port(pty.path, baudrate=115200, timeout=0.01)
        try:
            with Rfc2217Bridge(device, tcp_port=0).start() as bridge:
                driver = CreateDriver(bridge.url, settle_s=0.02)
                with driver:
                    drive_for(driver, 0.3, left=100, right=100)
                    assert sim.wheel_speeds == WheelSpeeds(left=100.0, right=100.0)
                    driver.stop()
                    driver.wait_for_sensors(1.0, after_frame=driver.frames_received + 2)
                    assert driver.parser.bad_frames == 0
                    assert abs(driver.pose().y - sim.pose.y) < 5.0
                assert bridge.device_error is None
        finally:
            device.close()


def test_device_failure_ends_the_bridge(rig: Rig) -> None:
    with rig.driver() as driver:
        rig.sim.unplug()
        assert rig.bridge.wait(2.0)
        assert rig.bridge.device_error is not None
        assert "unplugged" in rig.bridge.device_error
        assert wait_until(lambda: driver.link_error is not None, 2.0)


def test_oi_framer_tracks_command_boundaries() -> None:
    f = OIFramer(Model.CREATE2)
    f.feed(oi.start() + oi.safe())
    assert f.at_boundary
    f.feed(bytes([Opcode.DRIVE_DIRECT, 0, 100]))
    assert not f.at_boundary
    assert f.completion() == bytes(2)
    assert f.at_boundary
    f.feed(bytes([Opcode.STREAM]))  # count not known yet
    assert not f.at_boundary
    assert f.completion() == bytes(1)  # Stream of 0 packets
    f.feed(bytes([Opcode.STREAM, 2, 7]))
    assert f.completion() == bytes(1)
    f.feed(bytes([Opcode.SONG, 0, 2, 60]))  # song 0 with 2 notes, 3 of 4 note bytes missing
    assert f.completion() == bytes(3)
    f.feed(bytes([0, 1, 2]))  # not opcodes: skipped like the robot does
    assert f.at_boundary


def test_busy_port_and_bad_device_are_input_errors(capsys: pytest.CaptureFixture[str]) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen(1)
        busy = taken.getsockname()[1]
        with pytest.raises(InputError, match=rf"--port: cannot listen on 127.0.0.1:{busy}: "
                           "address already in use"):
            Rfc2217Bridge(serial.serial_for_url("loop://"), tcp_port=busy)
    code = cli.main(["serve-robot", "--device", "/dev/does-not-exist-marknav", "--port", "0"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("marknav serve-robot: error: /dev/does-not-exist-marknav: "
                          "cannot open serial port")
    assert "Traceback" not in err


def test_serve_robot_command(tmp_path: object) -> None:
    proc = subprocess.Popen(
        [sys.executable, "-m", "marknav", "serve-robot", "--sim", "--port", "0"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        m = re.fullmatch(r"serving robot a simulated create2 at (rfc2217://127\.0\.0\.1:(\d+))\n",
                         line)
        assert m, line
        with CreateDriver(m.group(1), settle_s=0.02) as driver:
            drive_for(driver, 0.4, left=250, right=250)
            driver.stop()
            driver.wait_for_sensors(1.0, after_frame=driver.frames_received + 2)
            assert 70.0 < driver.pose().y < 140.0
            assert driver.parser.bad_frames == 0
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=5)
    assert proc.returncode == 130
    assert "interrupted" in err
    assert "Traceback" not in err


def test_open_port_default_on_rfc2217(rig: Rig) -> None:
    # open_port drops the write timeout for rfc2217:// (pyserial's client cannot do one).
    # A write timeout asked for anyway is dropped too, instead of pyserial's NotImplementedError.
    port: SerialPort = open_port(rig.bridge.url, baudrate=115200, write_timeout=0.5)
    try:
        assert isinstance(port, serial.rfc2217.Serial)
        assert (port.write_timeout, port.timeout, port.baudrate) == (None, 0.015, 115200)
        assert (port.xonxoff, port.rtscts, port.dsrdtr) == (False, False, False)
        # and it is a working link: Start, then ask for the OI mode (packet 35) through the bridge
        port.write(oi.start() + oi.sensors(35, model=Model.CREATE2))
        reply = b""
        deadline = time.monotonic() + 2.0
        while not reply and time.monotonic() < deadline:
            reply = port.read(1)
        assert reply == bytes([OIMode.PASSIVE])
    finally:
        port.close()
    # other ports keep the write timeout (a stuck link raises instead of hanging)
    other = open_port("createsim://?model=create2", baudrate=115200)
    try:
        assert other.write_timeout == 0.5  # type: ignore[attr-defined]
    finally:
        other.close()
