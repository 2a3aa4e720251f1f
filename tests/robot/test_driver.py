"""CreateDriver against the in-process simulated Create (``createsim://``).

Lock-step tests use a ManualClock shared by the simulator and the driver with
``reader_thread=False``: step the simulator one 15 ms tick, then ``process_input``. They are
deterministic. The reader thread's tests step the simulator's clock too and wait for each
frame; the real-time simulator (``createsim://?model=…``) is the one slow test's.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from serial import SerialException

from marknav.core.clock import ManualClock
from marknav.core.errors import InputError
from marknav.planning.kinematics import Pose
from marknav.robot import oi
from marknav.robot.driver import CreateDriver, default_stream_ids
from marknav.robot.oi import Model, OIMode, Opcode
from marknav.robot.transport import SerialPort, open_port
from marknav.sim import protocol_createsim
from marknav.sim.simulated_create import SimulatedCreate

TICK = oi.STREAM_PERIOD_S


class Rig:
    """A simulated Create and a lock-step driver on one ManualClock."""

    def __init__(self, model: Model = Model.CREATE2, **sim_kwargs: object) -> None:
        self.clock = ManualClock()
        self.sim = SimulatedCreate(model=model, clock=self.clock, **sim_kwargs)  # type: ignore[arg-type]
        self.url = protocol_createsim.register(self.sim)
        self.driver = CreateDriver(self.url, model=model, clock=self.clock, settle_s=0.0,
                                   first_frame_timeout_s=None, reader_thread=False)

    def tick(self, n: int = 1) -> None:
        for _ in range(n):
            self.sim.step(TICK)
            self.driver.process_input()

    def run(self, seconds: float, *, left: float, right: float) -> None:
        """Command every tick (a 66 Hz controller) for ``seconds``."""
        for _ in range(round(seconds / TICK)):
            assert self.driver.drive(left=left, right=right)
            self.tick()

    def close(self) -> None:
        self.driver.close()
        protocol_createsim.unregister(self.url.split("//")[1])


@pytest.fixture
def rig() -> Iterator[Rig]:
    r = Rig()
    r.driver.connect()
    r.tick()
    yield r
    r.close()


def test_no_io_before_connect_and_bad_port_is_an_input_error() -> None:
    driver = CreateDriver("/dev/does-not-exist-marknav")  # constructing touches nothing
    with pytest.raises(InputError) as exc:
        driver.connect()
    assert str(exc.value).startswith("/dev/does-not-exist-marknav: cannot open serial port")
    with pytest.raises(InputError, match="protocol 'nope' not known"):
        CreateDriver("nope://x").connect()


def test_bad_model_and_stream_budget() -> None:
    with pytest.raises(InputError, match="unknown robot model 'roomba'"):
        CreateDriver("/dev/null", model="roomba")
    with pytest.raises(ValueError, match="109 bytes is over 60% of the 86 bytes per 15 ms"):
        CreateDriver("/dev/null", model="create1", stream_ids=[6, 6])
    with pytest.raises(ValueError, match="does not exist on the create1"):
        CreateDriver("/dev/null", model="create1", stream_ids=[43])


def test_default_streams_fit_well_inside_the_budget() -> None:
    c1 = CreateDriver("/dev/null", model="create1")
    c2 = CreateDriver("/dev/null", model="create2")
    assert (c1.stream_frame_bytes, c2.stream_frame_bytes) == (47, 55)
    assert 43 in default_stream_ids(Model.CREATE2) and 43 not in default_stream_ids(Model.CREATE1)


def test_connect_sends_start_safe_and_the_stream(rig: Rig) -> None:
    sent = [(c.opcode, c.data) for c in rig.sim.commands]
    assert sent[:2] == [(Opcode.START, b""), (Opcode.SAFE, b"")]
    ids = default_stream_ids(Model.CREATE2)
    assert sent[2] == (Opcode.STREAM, bytes([len(ids), *ids]))
    assert rig.sim.mode is OIMode.SAFE and rig.sim.streaming
    assert rig.driver.safety_state == "ready"
    assert rig.driver.sensors is not None and rig.driver.sensors.oi_mode is OIMode.SAFE


def test_drive_goes_through_safety_and_odometry_follows_the_ground_truth(rig: Rig) -> None:
    rig.run(1.0, left=200, right=200)
    assert rig.driver.safety_state == "driving"
    assert (rig.sim.wheel_speeds.left, rig.sim.wheel_speeds.right) == (200.0, 200.0)
    rig.run(2.0, left=100, right=250)  # an arc
    rig.driver.stop()
    rig.tick(2)
    truth, odo = rig.sim.pose, rig.driver.pose()
    assert math.hypot(truth.x - odo.x, truth.y - odo.y) < 2.0
    assert abs(truth.theta - odo.theta) < 0.01
    assert rig.driver.safety_state == "ready" and rig.sim.wheel_speeds.left == 0.0


def test_over_limit_commands_keep_the_curve(rig: Rig) -> None:
    assert rig.driver.drive(left=1000, right=600)
    assert (rig.sim.wheel_speeds.left, rig.sim.wheel_speeds.right) == (500.0, 300.0)


def test_a_bump_frame_stops_the_wheels_within_one_stream_period(rig: Rig) -> None:
    rig.run(0.3, left=200, right=200)
    rig.sim.set_bump(left=True, right=False)
    rig.sim.step(TICK)  # the robot emits the bump frame
    assert rig.sim.wheel_speeds.left == 200.0  # the robot itself does not stop on bumps
    rig.driver.process_input()
    assert rig.sim.wheel_speeds.left == 0.0 and rig.sim.wheel_speeds.right == 0.0
    assert rig.driver.safety_state == "bumped"
    assert not rig.driver.drive(left=100, right=100)
    assert rig.driver.backoff(left=-100, right=-100)
    assert rig.sim.wheel_speeds.left == -100.0


def test_command_watchdog_stops_a_robot_left_driving(rig: Rig) -> None:
    assert rig.driver.drive(left=150, right=150)
    rig.tick(10)  # 150 ms: still driving
    assert rig.sim.wheel_speeds.left == 150.0
    rig.tick(15)  # past command_timeout_s = 0.3 s
    assert rig.sim.wheel_speeds.left == 0.0 and rig.driver.safety_state == "ready"


def test_sensor_watchdog_trips_when_frames_stop(rig: Rig) -> None:
    assert rig.driver.drive(left=150, right=150)
    rig.sim.write(oi.pause_stream())  # as if the stream died
    for _ in range(20):
        rig.tick()
        rig.driver.drive(left=150, right=150)
    assert rig.driver.safety_state == "fault"
    assert "no sensor frame" in (rig.driver.fault_reason or "")
    assert rig.sim.wheel_speeds.left == 0.0


def test_close_stops_pauses_returns_to_passive_and_is_idempotent(rig: Rig) -> None:
    rig.run(0.1, left=100, right=100)
    n = len(rig.sim.commands)
    rig.driver.close()
    tail = [(c.opcode, c.data) for c in list(rig.sim.commands)[n:]]
    assert tail[-3:] == [(Opcode.DRIVE_DIRECT, bytes(4)), (Opcode.PAUSE_RESUME_STREAM, b"\x00"),
                         (Opcode.START, b"")]
    assert rig.sim.mode is OIMode.PASSIVE and not rig.sim.streaming
    assert rig.sim.wheel_speeds.left == 0.0
    rig.driver.close()
    assert len(rig.sim.commands) == n + len(tail)
    with pytest.raises(RuntimeError, match="connects once"):
        rig.driver.connect()


def test_unplugged_link_is_reported_not_raised(rig: Rig) -> None:
    rig.run(0.1, left=100, right=100)
    rig.sim.unplug()
    assert rig.driver.process_input() == 0
    assert rig.driver.link_error is not None and "unplugged" in rig.driver.link_error
    assert rig.driver.safety_state == "fault"
    assert "serial link lost" in (rig.driver.fault_reason or "")
    assert not rig.driver.drive(left=100, right=100)
    rig.driver.leds(bits=1)  # a non-wheel write on a dead link: no exception
    rig.driver.close()


def test_create1_odometry_from_distance_and_angle() -> None:
    r = Rig(Model.CREATE1)
    r.driver.connect()
    r.tick()
    try:
        assert r.driver.baudrate == 57600
        r.run(1.5, left=-120, right=120)  # spin
        r.run(1.0, left=200, right=200)
        r.driver.stop()
        r.tick(2)
        truth, odo = r.sim.pose, r.driver.pose()
        assert abs(truth.theta - odo.theta) < math.radians(1.0)
        assert math.hypot(truth.x - odo.x, truth.y - odo.y) < 4.0
    finally:
        r.close()


def test_mode_commands_and_recovery_after_a_cliff(rig: Rig) -> None:
    rig.run(0.1, left=100, right=100)
    rig.sim.set_cliff(front_right=True)  # Safe mode: the robot stops and drops to Passive
    rig.tick(2)
    assert rig.sim.mode is OIMode.PASSIVE and rig.driver.safety_state == "fault"
    rig.sim.set_cliff()
    rig.driver.set_mode(OIMode.SAFE)
    rig.tick(2)
    assert rig.driver.reset() and rig.driver.safety_state == "ready"
    rig.driver.song(1, [(60, 16)])
    rig.driver.play(1)
    assert rig.sim.played and rig.sim.played[-1][1] == 1


def test_reset_odometry(rig: Rig) -> None:
    rig.run(0.5, left=200, right=200)
    rig.driver.reset_odometry(Pose(10.0, 20.0, 0.0))
    assert rig.driver.pose() == Pose(10.0, 20.0, 0.0)
    y0 = rig.sim.pose.y
    rig.run(0.5, left=200, right=200)
    rig.driver.stop()
    rig.tick()
    assert rig.driver.pose().x == pytest.approx(10.0 + rig.sim.pose.y - y0, abs=0.5)


def test_a_calibrated_right_wheel_makes_odometry_follow_a_mismatched_robot() -> None:
    """The simulated right wheel moves the ground 4 % less than its encoder counts: raw odometry
    veers off; once the driver is told the ratio (what Perception learns from marks), it follows
    the truth. The snapshot's sensitivity counts from the last anchor."""
    r = Rig(right_scale=0.96)
    try:
        r.driver.connect()
        r.tick()
        r.run(1.0, left=200, right=200)
        pose, sens = r.driver.odometry_snapshot()
        assert pose == r.driver.pose()
        assert sens[2] > 0.0  # more right-wheel travel turns the robot left
        drift = abs(r.sim.pose.theta - pose.theta)
        assert drift > 0.02  # ~0.03 rad after 200 mm per wheel
        r.driver.scale_right_wheel(0.96)
        assert r.driver.right_wheel_scale == pytest.approx(0.96)
        assert r.driver.odometry_snapshot()[1] == (0.0, 0.0, 0.0)
        theta0, true0 = r.driver.pose().theta, r.sim.pose.theta
        r.run(1.0, left=200, right=200)
        turned_odo = r.driver.pose().theta - theta0
        turned_true = r.sim.pose.theta - true0
        assert turned_odo == pytest.approx(turned_true, abs=0.002)
        r.driver.anchor_odometry()
        assert r.driver.odometry_snapshot()[1] == (0.0, 0.0, 0.0)
    finally:
        r.close()


# --- the reader thread ------------------------------------------------------------------------

def test_reader_thread_against_a_simulator_on_the_tests_clock() -> None:
    """The real reader thread, with the simulator and the safety layer on the test's
    ManualClock: each step advances the clock one stream period and waits for that frame, so
    the travel and the command timeout are exact, whatever the machine's load."""
    clock = ManualClock()
    sim = SimulatedCreate(clock=clock)
    url = protocol_createsim.register(sim)
    driver = CreateDriver(url, clock=clock, settle_s=0.0, first_frame_timeout_s=None)

    def step(n: int = 1) -> None:
        for _ in range(n):
            frame = driver.frames_received
            clock.advance(TICK)
            driver.wait_for_sensors(5.0, after_frame=frame)  # a bound, not a measurement

    try:
        driver.connect()
        step()
        assert driver.wait_for_sensors(1.0).state.oi_mode is OIMode.SAFE
        assert driver.safety_state == "ready"
        ticks = round(0.25 / TICK)
        for _ in range(ticks):  # a 66 Hz controller for 0.25 s
            assert driver.drive(left=200, right=200)
            step()
        assert sim.pose.y == pytest.approx(200.0 * ticks * TICK)  # 51 mm
        assert driver.pose().y == pytest.approx(sim.pose.y, abs=0.5)  # encoder counts
        step(round(0.5 / TICK))  # no command for longer than command_timeout_s
        assert driver.safety_state == "ready"
        assert sim.wheel_speeds.left == sim.wheel_speeds.right == 0.0
        assert driver.safety_events[-1].event == "command_timeout"
        still = driver.pose().y
        assert still == pytest.approx(sim.pose.y, abs=0.5)
        step(round(0.1 / TICK))
        assert driver.pose().y == still
        assert driver.parser.bad_frames == 0
        assert driver.frames_received == 1 + ticks + round(0.5 / TICK) + round(0.1 / TICK)
    finally:
        driver.close()
        protocol_createsim.unregister(url.split("//")[1])


@pytest.mark.slow  # real time: the reader thread against createsim's wall-clock simulator
def test_reader_thread_against_a_real_time_simulator() -> None:
    with CreateDriver("createsim://?model=create2", settle_s=0.0) as driver:
        first = driver.wait_for_sensors(1.0)
        assert first.state.oi_mode is OIMode.SAFE and driver.safety_state == "ready"
        deadline = time.monotonic() + 0.25
        while time.monotonic() < deadline:
            assert driver.drive(left=200, right=200)
            time.sleep(0.02)
        moved = driver.pose().y
        assert 30.0 < moved < 80.0  # about 200 mm/s x 0.25 s
        time.sleep(0.5)  # no command for longer than command_timeout_s
        assert driver.safety_state == "ready"
        still = driver.wait_for_sensors(1.0, after_frame=driver.frames_received).pose.y
        time.sleep(0.1)
        assert driver.pose().y == pytest.approx(still, abs=1e-9)
        assert driver.parser.bad_frames == 0 and driver.frames_received > 40


class ObservedPort:
    """A real port (the simulated Create's) that records, for every write, what ``observe()``
    returned at that moment: the driver's state as the bytes go out, on whichever thread wrote
    them. It makes the order of "wheels zeroed" and "reading published" visible without timing."""

    def __init__(self, port: SerialPort) -> None:
        self._port = port
        self.observe: Callable[[], object] = lambda: None
        self.writes: list[tuple[bytes, object]] = []

    @property
    def in_waiting(self) -> int:
        return self._port.in_waiting

    def read(self, size: int = 1) -> bytes:
        return self._port.read(size)

    def write(self, data: bytes, /) -> int | None:
        self.writes.append((bytes(data), self.observe()))
        return self._port.write(data)

    def reset_input_buffer(self) -> None:
        self._port.reset_input_buffer()

    def close(self) -> None:
        self._port.close()


@pytest.mark.parametrize("reader_thread", [False, True])
def test_bump_is_handled_before_the_reading_is_published(reader_thread: bool) -> None:
    """The bump frame's zero Drive Direct is written before that frame's reading is published:
    whoever sees the bumped reading (a behaviour, the controller thread) knows the wheels are
    already stopped. Checked at the write itself, so it holds on the reader thread too."""
    clock = ManualClock()
    sim = SimulatedCreate(clock=clock)
    url = protocol_createsim.register(sim)
    ports: list[ObservedPort] = []

    def observed_port(url: str, **kwargs: Any) -> ObservedPort:
        ports.append(ObservedPort(open_port(url, **kwargs)))
        return ports[-1]

    driver = CreateDriver(url, clock=clock, settle_s=0.0, first_frame_timeout_s=None,
                          open_port=observed_port, reader_thread=reader_thread)

    def step() -> None:
        before = driver.frames_received
        sim.step(TICK)
        if reader_thread:
            driver.wait_for_sensors(1.0, after_frame=before)
        else:
            assert driver.process_input() == 1

    try:
        driver.connect()
        (port,) = ports
        port.observe = lambda: (driver.frames_received, driver.safety_state)
        step()
        assert driver.drive(left=100, right=100)
        step()
        sim.set_bump(left=False, right=True)
        before = driver.frames_received
        del port.writes[:]
        step()
        reading = driver.latest
        assert reading is not None and reading.state.bump_right and reading.frame == before + 1
        # exactly one write, the zero, made while the bump frame was not yet published (and by a
        # safety layer that had already left "driving")
        assert port.writes == [(oi.drive_direct(left=0, right=0), (before, "bumped"))]
        assert sim.wheel_speeds.left == 0.0 and driver.safety_state == "bumped"
    finally:
        driver.close()
        protocol_createsim.unregister(url.split("//")[1])


def test_connect_fails_cleanly_when_no_stream_arrives() -> None:
    sim = SimulatedCreate(clock=ManualClock())  # never stepped: no frame ever comes
    url = protocol_createsim.register(sim)
    try:
        driver = CreateDriver(url, settle_s=0.0, first_frame_timeout_s=0.1)
        with pytest.raises(InputError, match=r"no sensor stream within 0\.1 s"):
            driver.connect()
        assert sim.mode is OIMode.PASSIVE  # close() still returned it to Passive
    finally:
        protocol_createsim.unregister(url.split("//")[1])


# --- transport ---------------------------------------------------------------------------------

def test_open_port_uses_serial_for_url_without_flow_control() -> None:
    port = open_port("createsim://?model=create1&left_scale=0.97&seed=2", baudrate=57600)
    try:
        assert isinstance(port, protocol_createsim.Serial) and port.sim is not None
        assert port.sim.model is Model.CREATE1 and port.sim.body.left_scale == 0.97
        assert (port.xonxoff, port.rtscts, port.dsrdtr, port.baudrate) == (False, False, False,
                                                                             57600)
        port.write(oi.start() + oi.sensors(35, model=Model.CREATE1))
        assert port.read(1) == bytes([1])
    finally:
        port.close()


@pytest.mark.parametrize(("url", "message"), [
    ("createsim://?colour=red", "unknown option 'colour'"),
    ("createsim://?model=roomba", "unknown robot model 'roomba'"),
    ("createsim://nobody", "no simulated Create registered as 'nobody'"),
])
def test_open_port_errors_name_the_port(url: str, message: str) -> None:
    with pytest.raises(InputError) as exc:
        open_port(url, baudrate=115200)
    text = str(exc.value)
    assert text.startswith(f"{url}: cannot open serial port") and message in text


# --- edges found by mutation testing (docs/mutation.md) ------------------------------------------

class FaultyPort(ObservedPort):
    """An observed port whose next read raises ``fail_read`` (a pulled cable, a port closed under
    the driver)."""

    fail_read: BaseException | None = None
    reads = 0

    def read(self, size: int = 1) -> bytes:
        self.reads += 1
        if self.fail_read is not None:
            raise self.fail_read
        return super().read(size)


def faulty_rig() -> tuple[Rig, FaultyPort]:
    r = Rig()
    ports: list[FaultyPort] = []

    def faulty(url: str, **kwargs: Any) -> FaultyPort:
        ports.append(FaultyPort(open_port(url, **kwargs)))
        return ports[-1]

    r.driver = CreateDriver(r.url, clock=r.clock, settle_s=0.0, first_frame_timeout_s=None,
                            reader_thread=False, open_port=faulty)
    r.driver.connect()
    r.tick()
    return r, ports[0]


def test_each_reading_carries_its_clock_time_and_frame_number(rig: Rig) -> None:
    first = rig.driver.latest
    assert first is not None
    for k in range(1, 4):
        rig.tick()
        reading = rig.driver.latest
        assert reading is not None
        assert reading.frame == first.frame + k == rig.driver.frames_received
        assert reading.t == rig.clock.now()
    # two frames waiting: both handled by one call
    rig.sim.step(TICK)
    rig.sim.step(TICK)
    assert rig.driver.process_input() == 2
    # nothing waiting: nothing read, nothing handled, nothing fed to the parser
    skipped = rig.driver.parser.skipped_bytes
    assert rig.driver.process_input() == 0 and rig.driver.process_input() == 0
    assert rig.driver.parser.skipped_bytes == skipped and rig.driver.parser.bad_frames == 0


def test_leds_and_modes_reach_the_robot_as_sent(rig: Rig) -> None:
    rig.driver.leds()
    rig.tick()
    assert (rig.sim.commands[-1].opcode, rig.sim.commands[-1].data) == (Opcode.LEDS, bytes(3))
    rig.driver.leds(bits=0b1010, power_color=200, power_intensity=128)
    rig.tick()
    assert (rig.sim.commands[-1].opcode, rig.sim.commands[-1].data) == (
        Opcode.LEDS, bytes([0b1010, 200, 128]))
    rig.driver.set_mode(OIMode.FULL)
    rig.tick()
    assert rig.driver.mode is OIMode.FULL and rig.sim.mode is OIMode.FULL
    rig.driver.set_mode(OIMode.PASSIVE)  # sent, but not the mode the driver drives in
    rig.tick()
    assert rig.driver.mode is OIMode.FULL and rig.sim.mode is OIMode.PASSIVE


def test_odometry_changes_keep_the_latest_reading(rig: Rig) -> None:
    rig.run(0.3, left=200, right=200)
    before = rig.driver.latest
    assert before is not None
    rig.driver.reset_odometry(Pose(10.0, 20.0, 0.5))
    after = rig.driver.latest
    assert after is not None and after.pose == Pose(10.0, 20.0, 0.5)
    assert (after.state, after.t, after.frame) == (before.state, before.t, before.frame)
    rig.driver.scale_right_wheel(0.97)
    anchored = rig.driver.latest
    assert anchored is not None and anchored.frame == before.frame
    assert anchored.sensitivity == (0.0, 0.0, 0.0)


@pytest.mark.parametrize(("error", "reason"), [
    (SerialException("device reports readiness to read but returned no data"),
     "serial read failed: device reports readiness to read but returned no data"),
    (TypeError("'NoneType' object is not callable"),  # a port closed under the driver
     "serial read failed: TypeError: 'NoneType' object is not callable"),
])
def test_a_failed_read_is_a_lost_link_with_its_reason(error: BaseException, reason: str) -> None:
    r, port = faulty_rig()
    try:
        assert r.driver.drive(left=100, right=100)
        port.fail_read = error
        r.sim.step(TICK)
        assert r.driver.process_input() == 0
        assert r.driver.link_error == reason
        assert r.driver.safety_state == "fault"
        assert r.driver.fault_reason == f"serial link lost: {reason}"
        # after that the port is left alone: no more reads, nothing handled
        reads = port.reads
        assert r.driver.process_input() == 0
        assert port.reads == reads
        with pytest.raises(TimeoutError, match=f"^{reason}$"):
            r.driver.wait_for_sensors(0.5, after_frame=r.driver.frames_received)
    finally:
        r.close()


def test_a_failed_non_wheel_write_faults_the_safety_layer_with_its_reason() -> None:
    r, port = faulty_rig()
    try:
        def broken(data: bytes, /) -> int | None:
            raise SerialException("write failed: [Errno 5] Input/output error")

        port.write = broken  # type: ignore[method-assign]
        r.driver.leds(bits=1)  # reported, not raised
        assert r.driver.safety_state == "fault"
        assert r.driver.fault_reason == ("serial link lost: "
                                         "write failed: [Errno 5] Input/output error")
    finally:
        r.close()


def test_commands_before_connect_and_sensor_timeouts_say_what_is_wrong(rig: Rig) -> None:
    unconnected = CreateDriver(rig.url, settle_s=0.0, first_frame_timeout_s=None,
                               reader_thread=False)
    with pytest.raises(RuntimeError, match=r"^CreateDriver is not connected$"):
        unconnected.leds(bits=1)
    with pytest.raises(TimeoutError, match=r"^no sensor frame within 0 s$"):
        rig.driver.wait_for_sensors(0.0, after_frame=rig.driver.frames_received)
    sim = SimulatedCreate(clock=ManualClock())
    url = protocol_createsim.register(sim)
    try:
        owned = r"^the reader thread owns the port \(reader_thread=True\)$"
        with (CreateDriver(url, settle_s=0.0, first_frame_timeout_s=None) as threaded,
              pytest.raises(RuntimeError, match=owned)):
            threaded.process_input()
    finally:
        protocol_createsim.unregister(url.split("//")[1])


def test_constructor_defaults_and_what_it_passes_on() -> None:
    d = CreateDriver("/dev/null")
    assert (d.first_frame_timeout_s, d.settle_s, d.reader_thread, d.mode) == (2.0, 0.05, True,
                                                                           OIMode.SAFE)
    assert d.frames_received == 0 and d.latest is None
    start = Pose(100.0, -50.0, 0.25)
    d = CreateDriver("/dev/null", model="create1", wheel_base_mm=250.0, start_pose=start)
    assert d.odometry.wheel_base_mm == 250.0
    assert d.pose() == start  # before any frame: the start pose
    with pytest.raises(InputError) as exc:
        CreateDriver("/dev/null", model="roomba")
    assert exc.value.field == "model"
    with pytest.raises(ValueError, match=r"^mode must be OIMode\.SAFE or OIMode\.FULL, got "):
        CreateDriver("/dev/null", mode=OIMode.PASSIVE)


def test_the_command_watchdog_setting_and_start_pose_reach_safety_and_odometry(rig: Rig) -> None:
    start = Pose(-40.0, 25.0, 1.0)
    d = CreateDriver(rig.url, clock=rig.clock, settle_s=0.0, first_frame_timeout_s=None,
                     reader_thread=False, command_timeout_s=0.1,
                     start_pose=start)
    rig.driver.close()  # the simulated Create takes one driver at a time
    rig.driver = d
    d.connect()
    rig.tick()
    assert d.drive(left=150, right=150)
    rig.tick(5)  # 75 ms without a new command: still driving
    assert d.safety_state == "driving"
    rig.tick(3)  # 120 ms: the 0.1 s command watchdog stopped it (the default is 0.3 s)
    assert d.safety_state == "ready" and rig.sim.wheel_speeds.left == 0.0
    d.reset_odometry()  # back to the start pose, not the origin
    assert d.pose() == start
