"""CreateDriver's connect and close at the edges mutation testing found unasserted
(docs/mutation.md, drivers/driver.py, after issue 15's "closed on every exit path"): connecting
twice, a port that cannot be written, the first frame in lock-step, the reader thread's name and
lifetime, and close() releasing the port whatever failed before it.

Ports are the simulated Create's real ones (``createsim://``), wrapped to count, fail or step the
simulator from inside the driver's own calls — no timing windows."""

from __future__ import annotations

import threading
from typing import Any

import pytest
from serial import SerialException

from marknav.core.clock import ManualClock
from marknav.core.errors import InputError
from marknav.robot import oi
from marknav.robot.driver import CreateDriver
from marknav.robot.oi import OIMode, Opcode
from marknav.robot.transport import SerialPort, open_port
from marknav.sim import protocol_createsim
from marknav.sim.simulated_create import SimulatedCreate

RUNTIME = "a CreateDriver connects once; make a new one to reconnect"


class Port:
    """The simulated Create's port, seen from the driver: counts polls and closes, can make
    writes fail, and can step the simulator on the n-th poll for input (a robot that answers
    late)."""

    def __init__(self, port: SerialPort, sim: SimulatedCreate | None = None) -> None:
        self._port = port
        self.sim = sim
        self.polls = 0
        self.closed = 0
        self.fail_writes: BaseException | None = None
        self.writes = 0
        #: the writes after this many fail (a port that dies in the middle of close())
        self.fail_after_writes: int | None = None
        self.step_on_read: int | None = None

    @property
    def in_waiting(self) -> int:
        self.polls += 1
        if self.sim is not None and self.polls == self.step_on_read:
            self.sim.step(oi.STREAM_PERIOD_S)
        return self._port.in_waiting

    def read(self, size: int = 1) -> bytes:
        return self._port.read(size)

    def write(self, data: bytes, /) -> int | None:
        if self.fail_writes is not None:
            raise self.fail_writes
        if self.fail_after_writes is not None and self.writes >= self.fail_after_writes:
            raise SerialException("device disconnected")
        self.writes += 1
        return self._port.write(data)

    def reset_input_buffer(self) -> None:
        self._port.reset_input_buffer()

    def close(self) -> None:
        self.closed += 1
        self._port.close()


class Robot:
    """A registered simulated Create on a manual clock and the ports opened to it."""

    def __init__(self) -> None:
        self.clock = ManualClock()
        self.sim = SimulatedCreate(clock=self.clock)
        self.url = protocol_createsim.register(self.sim)
        self.ports: list[Port] = []
        self.fail_writes: BaseException | None = None
        self.step_on_read: int | None = None

    def open(self, url: str, **kwargs: Any) -> Port:
        port = Port(open_port(url, **kwargs), self.sim)
        port.fail_writes, port.step_on_read = self.fail_writes, self.step_on_read
        self.ports.append(port)
        return port

    def driver(self, **kwargs: Any) -> CreateDriver:
        kwargs = {"clock": self.clock, "settle_s": 0.0, "first_frame_timeout_s": None,
                  "reader_thread": False, "open_port": self.open, **kwargs}
        return CreateDriver(self.url, **kwargs)

    def unregister(self) -> None:
        protocol_createsim.unregister(self.url.split("//")[1])


@pytest.fixture
def robot() -> Any:
    r = Robot()
    yield r
    r.unregister()


def readers() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name == "create-reader" and t.is_alive()]


def test_a_driver_connects_once(robot: Robot) -> None:
    driver = robot.driver()
    driver.connect()
    with pytest.raises(RuntimeError) as exc:
        driver.connect()  # connected
    assert str(exc.value) == RUNTIME
    driver.close()
    never = robot.driver()
    never.close()
    with pytest.raises(RuntimeError) as exc:
        never.connect()  # closed before it ever connected
    assert str(exc.value) == RUNTIME
    assert len(robot.ports) == 1


def test_a_port_that_cannot_be_written_is_an_input_error_naming_it(robot: Robot) -> None:
    robot.fail_writes = SerialException("write failed")
    driver = robot.driver()
    with pytest.raises(InputError) as exc:
        driver.connect()
    assert exc.value.file == robot.url
    assert str(exc.value) == f"{robot.url}: cannot talk to the robot: write failed"
    assert robot.ports[0].closed == 1 and not driver.connected


@pytest.mark.parametrize("reader_thread", [False, True])
def test_no_first_frame_is_an_input_error_that_says_what_to_check(robot: Robot,
                                                                  reader_thread: bool) -> None:
    driver = robot.driver(first_frame_timeout_s=0.05, reader_thread=reader_thread)
    with pytest.raises(InputError) as exc:
        driver.connect()  # the simulator is never stepped: no frame comes
    assert exc.value.file == robot.url
    assert str(exc.value) == (f"{robot.url}: no sensor stream within 0.05 s (wrong port, baud "
                              "rate 115200 or model create2?)")
    assert robot.sim.mode is OIMode.PASSIVE and robot.ports[0].closed == 1
    assert readers() == []


def test_in_lock_step_connect_waits_for_a_first_frame_that_comes_late(robot: Robot) -> None:
    # the robot's first frame is there only when the driver asks the port for the third time
    robot.step_on_read = 3
    driver = robot.driver(first_frame_timeout_s=1.0)
    driver.connect()
    try:
        assert robot.ports[0].polls >= 3
        assert driver.latest is not None and driver.frames_received == 1
        assert driver.safety_state == "ready"
    finally:
        driver.close()


def test_the_reader_thread_is_a_named_daemon_and_is_gone_after_close() -> None:
    driver = CreateDriver("createsim://?model=create2", settle_s=0.0)
    driver.connect()
    try:
        (reader,) = readers()
        assert reader.daemon  # a crash elsewhere never waits on the serial port
        assert driver.wait_for_sensors(1.0) is not None
    finally:
        driver.close()
    assert readers() == []  # close() returns once the reader has stopped


def test_close_releases_the_port_after_a_lost_link(robot: Robot) -> None:
    driver = robot.driver()
    driver.connect()
    robot.sim.unplug()
    assert driver.process_input() == 0 and driver.link_error is not None
    driver.close()
    assert robot.ports[0].closed == 1 and not driver.connected


def test_close_releases_the_port_when_its_writes_fail(robot: Robot) -> None:
    driver = robot.driver()
    driver.connect()
    robot.sim.step(oi.STREAM_PERIOD_S)
    driver.process_input()
    n = len(robot.sim.commands)
    robot.ports[0].fail_writes = SerialException("gone")
    driver.close()
    assert robot.ports[0].closed == 1
    assert len(robot.sim.commands) == n  # nothing got through, and nothing was retried
    driver.close()
    assert robot.ports[0].closed == 1


def test_close_sends_its_three_commands_then_closes_the_port(robot: Robot) -> None:
    driver = robot.driver()
    driver.connect()
    n = len(robot.sim.commands)
    driver.close()
    tail = [(c.opcode, c.data) for c in list(robot.sim.commands)[n:]]
    assert tail[-3:] == [(Opcode.DRIVE_DIRECT, bytes(4)), (Opcode.PAUSE_RESUME_STREAM, b"\x00"),
                         (Opcode.START, b"")]
    assert robot.ports[0].closed == 1


def test_close_releases_the_port_when_it_dies_between_two_of_closes_writes(robot: Robot) -> None:
    driver = robot.driver()
    driver.connect()
    port = robot.ports[0]
    n = len(robot.sim.commands)
    port.fail_after_writes = port.writes + 2  # the two zero Drive Directs go out, then nothing
    driver.close()
    sent = [c.opcode for c in list(robot.sim.commands)[n:]]
    assert sent == [Opcode.DRIVE_DIRECT, Opcode.DRIVE_DIRECT]
    assert port.closed == 1 and driver.link_error is not None and not driver.connected


@pytest.mark.parametrize(("delay_s", "timeout_s", "connects"), [(0.5, 1.0, True),
                                                                (1.5, 1.0, False)])
def test_in_lock_step_the_first_frame_wait_runs_on_the_clock_wait_input_moves(
        robot: Robot, delay_s: float, timeout_s: float, connects: bool) -> None:
    # a slow link: the stream request acts delay_s after it was written; wait_input steps the
    # simulator, so the wait is measured in simulated seconds, not the wall's
    robot.sim.command_delay_s = delay_s
    driver = robot.driver(first_frame_timeout_s=timeout_s, wait_input=robot.sim.step)
    if not connects:
        with pytest.raises(InputError, match="no sensor stream within 1 s"):
            driver.connect()
        assert timeout_s < robot.clock.now() < timeout_s + 0.1
        return
    driver.connect()
    try:
        assert driver.latest is not None and driver.safety_state == "ready"
        assert delay_s < robot.clock.now() < delay_s + 0.03  # within two 15 ms ticks
    finally:
        driver.close()
