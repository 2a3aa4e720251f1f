"""The simulated Create over a real OS pseudo-terminal: our driver, a third-party style poller,
raw-mode bytes, link loss, and the ``marknav sim-robot --pty`` command."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator

import pytest
import serial

from marknav.core.clock import MonotonicClock
from marknav.planning.kinematics import WheelSpeeds
from marknav.robot import oi
from marknav.robot.driver import CreateDriver
from marknav.robot.oi import Model, OIMode
from marknav.robot.packets import SensorState, decode_packet
from marknav.sim.pty import PtyServer
from marknav.sim.simulated_create import LedState, SimulatedCreate

pytestmark = pytest.mark.skipif(not hasattr(os, "openpty"), reason="needs POSIX ptys")


@pytest.fixture
def server() -> Iterator[PtyServer]:
    with PtyServer(SimulatedCreate(clock=MonotonicClock())) as srv:
        yield srv


def drive_for(driver: CreateDriver, seconds: float, *, left: float, right: float) -> None:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        assert driver.drive(left=left, right=right)
        time.sleep(0.02)


def wait_until(predicate: Callable[[], bool], timeout: float = 2.0) -> bool:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.005)
    return True


def settle(driver: CreateDriver) -> None:
    """Wait until two fresh frames arrived (the robot has reported its last motion)."""
    driver.wait_for_sensors(1.0, after_frame=driver.frames_received + 1)


def test_driver_over_the_pty(server: PtyServer) -> None:
    sim = server.sim
    with CreateDriver(server.path, settle_s=0.0) as driver:
        assert sim.mode is OIMode.SAFE and sim.streaming
        assert driver.safety_state == "ready"
        drive_for(driver, 0.4, left=150, right=250)
        driver.stop()
        settle(driver)
        truth, odo = sim.pose, driver.pose()
        assert math.hypot(truth.x, truth.y) > 50.0  # it really moved
        assert math.hypot(truth.x - odo.x, truth.y - odo.y) < 3.0
        assert abs(truth.theta - odo.theta) < 0.01
        # a bump set on the simulated robot stops the wheels through the safety layer
        assert driver.drive(left=200, right=200)
        sim.set_bump(left=True, right=False)
        reading = driver.wait_for_sensors(1.0)
        deadline = time.monotonic() + 1.0
        while not reading.state.bump_left and time.monotonic() < deadline:
            reading = driver.wait_for_sensors(1.0, after_frame=reading.frame)
        assert reading.state.bump_left
        # the zero Drive Direct was written before the reading was published; it crosses the pty
        assert wait_until(lambda: sim.wheel_speeds == WheelSpeeds(left=0.0, right=0.0))
        assert driver.safety_state == "bumped"
        assert driver.parser.bad_frames == 0
    assert wait_until(lambda: sim.mode is OIMode.PASSIVE and not sim.streaming)  # handed back


def test_closing_the_master_is_a_lost_link_not_a_crash(server: PtyServer) -> None:
    driver = CreateDriver(server.path, settle_s=0.0)
    driver.connect()
    try:
        assert driver.drive(left=100, right=100)
        server.close()  # like pulling the USB cable
        # The reader thread records the error, logs it, then latches the fault: wait for both.
        assert wait_until(lambda: driver.link_error is not None
                          and driver.safety_state == "fault")
        assert driver.link_error is not None and "read failed" in driver.link_error
        assert "serial link lost" in (driver.fault_reason or "")
        assert not driver.drive(left=100, right=100)
    finally:
        driver.close()
        driver.close()


def test_third_party_style_polling_create2(server: PtyServer) -> None:
    # What pycreate2 and similar libraries do: plain serial.Serial, Start, Safe, Sensors 142 100
    port = serial.Serial(server.path, 115200, timeout=1.0)
    try:
        port.write(bytes([128]))
        port.write(bytes([131]))
        port.write(bytes([145, 0, 100, 0, 100]))  # drive direct 100/100
        time.sleep(0.3)
        port.write(bytes([142, 100]))
        data = port.read(80)
        assert len(data) == 80
        state = SensorState().with_packets(decode_packet(Model.CREATE2, 100, data))
        assert state.oi_mode is OIMode.SAFE
        assert state.requested_left_velocity == state.requested_right_velocity == 100
        assert state.encoder_left > 0 and state.encoder_left == state.encoder_right
        port.write(bytes([145, 0, 0, 0, 0, 173]))  # stop wheels, Stop OI
        assert wait_until(lambda: server.sim.mode is OIMode.OFF)
    finally:
        port.close()


def test_third_party_style_polling_create1() -> None:
    with PtyServer(SimulatedCreate(model="create1", clock=MonotonicClock())) as srv:
        port = serial.Serial(srv.path, 57600, timeout=1.0)
        try:
            port.write(bytes([128, 132, 142, 6]))
            data = port.read(52)
            assert len(data) == 52
            state = SensorState(model=Model.CREATE1).with_packets(
                decode_packet(Model.CREATE1, 6, data))
            assert state.oi_mode is OIMode.FULL and state.ir_omni is None
        finally:
            port.close()


def test_the_pty_is_raw_both_ways(server: PtyServer) -> None:
    port = serial.Serial(server.path, 115200, timeout=1.0)
    try:
        # 0x11/0x13 are XON/XOFF and 0x0D a carriage return to a cooked tty
        port.write(oi.start() + oi.safe() + bytes([145, 0, 17, 1, 19]))
        port.write(bytes([139, 13, 19, 17]))
        server.sim.voltage_mv = 0x130D
        assert wait_until(lambda: server.sim.leds == LedState(13, 19, 17))
        assert (server.sim.wheel_speeds.left, server.sim.wheel_speeds.right) == (275.0, 17.0)
        port.write(bytes([142, 22]))
        assert port.read(2) == bytes([0x13, 0x0D])
    finally:
        port.close()


@pytest.mark.parametrize(("sig", "model"), [(signal.SIGINT, "create1"),
                                            (signal.SIGTERM, "create2")])
def test_sim_robot_command_serves_until_interrupted(sig: signal.Signals, model: str) -> None:
    proc = subprocess.Popen(
        [sys.executable, "-m", "marknav", "sim-robot", "--pty", "--model", model],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        path = proc.stdout.readline().strip()
        assert path.startswith("/dev/")
        # the simulated robot answers only at its own baud rate, as a real one does
        port = serial.Serial(path, 57600 if model == "create1" else 115200, timeout=1.0)
        try:
            port.write(bytes([128, 142, 35]))
            assert port.read(1) == bytes([1])  # Passive after Start
            port.write(bytes([142, 7]) + bytes([142, 100]))
            expected = 1 + (80 if model == "create2" else 0)  # no group 100 on a Create 1
            port.timeout = 0.3
            assert len(port.read(expected + 1)) == expected
        finally:
            port.close()
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=10)
        assert proc.returncode == 130
        assert "interrupted" in err and "Traceback" not in err
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_sim_robot_bad_input_exits_2(capsys: pytest.CaptureFixture[str]) -> None:
    from marknav.cli.main import main

    assert main(["sim-robot", "--pty", "--right-scale", "0"]) == 2
    assert "--right-scale: must be in (0, 2], got 0.0" in capsys.readouterr().err


def test_reset_answered_in_off_mode_over_the_pty(server: PtyServer) -> None:
    # A freshly powered Create 2 is Off; Reset (7) is always available and prints the banner.
    assert server.sim.mode is OIMode.OFF
    with serial.Serial(server.path, 115200, timeout=0.2) as port:
        port.write(bytes([7]))
        data = b""
        deadline = time.monotonic() + 2.0
        while b"Create 2)\r\n" not in data and time.monotonic() < deadline:
            data += port.read(256)
    assert data.startswith(b"\r\nmarknav simulated Roomba 600 (Create 2)\r\n")
    assert server.sim.mode is OIMode.OFF
