"""The Create driver: serial port + OI commands + sensor stream + odometry + safety layer.

Lifecycle (no I/O before :meth:`CreateDriver.connect`; ``with`` does connect/close)::

    connect(): open the port (any pyserial URL) -> Start (128) -> Safe (131) or Full (132)
               -> Stream (148) of the packets below -> wait for the first good frame
               -> reader thread running -> safety.connect()
    close():   safety.stop() and a zero Drive Direct -> Pause Stream (150 0)
               -> Start (128, back to Passive) -> reader stopped -> port closed. Idempotent.

The reader thread parses stream frames (:class:`marknav.robot.oi.StreamParser`); for every
good frame it calls ``safety.on_sensors`` *first* (so a bump frame zeroes the wheels on this
thread, within one 15 ms stream period), then updates odometry and the latest reading. It calls
``safety.poll`` after every read, and reads time out after 15 ms, so the watchdogs run even when
no byte arrives. A ``SerialException``/``OSError`` on read or write becomes
``safety.on_link_lost`` and :attr:`CreateDriver.link_error`; it never escapes a thread.

Wheel commands go only through :meth:`CreateDriver.drive` / :meth:`CreateDriver.backoff` →
:class:`marknav.robot.safety.SafetyLayer` → Drive Direct (145). Every command is written whole,
in one ``write``, under a lock.

Stream budget (OI spec "Stream": 15 ms ≈ 86 bytes at 57600 baud, 172 at 115200). Default
packets: Create 2 — 7–12, 14, 19, 20, group 3 (battery 21–26), group 5 (35–42: OI mode,
requested velocities), 43, 44, 45: 55 bytes a frame; Create 1 — the same without 43–45:
47 bytes. A Create 2 on a slower line drops 19, 20 (its odometry reads the encoders) and 45:
46 bytes. Requests over 60 % of the budget are refused.

Create realities (OI spec "Serial Port Settings", "Passive Mode"):

- **Baud rate**: ``baudrate="auto"`` tries 115200, then 57600 (:data:`AUTO_BAUDRATES`): at each,
  Start and a query of the OI mode (packet 35); the first rate that answers is kept. A line
  that answers at neither is an :class:`InputError`: "no answer at 115200 or 57600 baud: check
  power, cable and baud".
- **Sleep and wake**: in Passive mode the robot sleeps after 5 minutes unless its Baud Rate
  Change pin is pulsed low. Where the cable wires BRC to a modem line of the serial adapter
  (``brc_line``: ``"rts"`` by default, ``"dtr"``, or ``None``), asserting the line pulls BRC
  low: ``connect`` pulses it once before Start (waking a sleeping robot), and while the robot
  reports Passive the driver pulses it every :data:`KEEPALIVE_PERIOD_S` (the spec's example:
  low for 1 s every minute). A port without modem lines (a pty, a socket) is noted once in the
  log; the robot may then sleep in Passive, which the sensor watchdog reports as a lost stream.
  Three pulses within 2 s of power-on would switch the robot to 19200 baud: the driver never
  pulses that often.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from types import TracebackType
from typing import Literal

import serial

from marknav.core.clock import Clock, MonotonicClock
from marknav.core.errors import InputError
from marknav.planning.kinematics import Pose
from marknav.robot import oi
from marknav.robot.odometry import Odometry
from marknav.robot.packets import Model, OIMode, SensorState
from marknav.robot.safety import SafetyEvent, SafetyLayer, SafetyState
from marknav.robot.transport import LINK_ERRORS, SerialPort, open_port

__all__ = ["AUTO_BAUDRATES", "KEEPALIVE_PERIOD_S", "CreateDriver", "SensorReading",
           "default_stream_ids", "stream_budget_bytes"]

log = logging.getLogger(__name__)

_COMMON_STREAM = (7, 8, 9, 10, 11, 12, 14, 19, 20, 3, 5)
_DEFAULT_STREAM: dict[Model, tuple[int, ...]] = {
    Model.CREATE1: _COMMON_STREAM,
    Model.CREATE2: (*_COMMON_STREAM, 43, 44, 45),
}
#: A Create 2 on a line slower than 115200: its odometry reads the encoders (43, 44), so
#: distance and angle (19, 20) and the light bumper (45) stay out of the stream.
_SLOW_LINE_CREATE2 = (7, 8, 9, 10, 11, 12, 14, 3, 5, 43, 44)
#: Fraction of the per-period byte budget a stream may use.
STREAM_BUDGET_FRACTION = 0.6
#: The baud rates ``baudrate="auto"`` tries, in order (Create 2 default, Create 1 default).
AUTO_BAUDRATES: tuple[int, ...] = (115200, 57600)
#: How long a baud-rate probe waits for the robot's answer, wall seconds (one byte comes back
#: within a few ms on a live line; a USB adapter may hold it 16 ms).
PROBE_TIMEOUT_S = 0.25
#: BRC keep-alive period in Passive mode, s (spec: a pulse before five minutes pass; its example
#: pulses every minute), and the pulse length, s (its example: 1 s low).
KEEPALIVE_PERIOD_S = 60.0
KEEPALIVE_PULSE_S = 1.0
#: Length of the wake pulse ``connect`` sends, s (a baud change needs three pulses of 50–500 ms).
WAKE_PULSE_S = 0.1
#: How long ``connect`` waits for the first good stream frame by default, s: a robot on the line
#: answers within a few 15 ms stream periods, so 2 s without one means a wrong port, baud rate or
#: model, or the robot off; a slow link's delay (a Bluetooth or Wi-Fi bridge) comes on top.
FIRST_FRAME_TIMEOUT_S = 2.0
#: Without a reader thread, how long ``connect`` lets the link run between reads while it waits
#: for the first frame, s: well under the 15 ms stream period, so the wait ends within one.
FIRST_FRAME_POLL_S = 0.002


def default_stream_ids(model: Model, baudrate: int | None = None) -> tuple[int, ...]:
    """The packets the driver streams by default for ``model`` (on a line of ``baudrate``)."""
    if model is Model.CREATE2 and baudrate is not None and baudrate < 115200:
        return _SLOW_LINE_CREATE2
    return _DEFAULT_STREAM[model]


def stream_budget_bytes(baudrate: int) -> float:
    """Bytes that fit in one 15 ms stream period at ``baudrate`` (10 bits per byte)."""
    return baudrate / 10.0 * oi.STREAM_PERIOD_S


@dataclass(frozen=True)
class SensorReading:
    """One consistent snapshot: latest sensors, their clock time, odometry, frame count."""

    state: SensorState
    t: float
    pose: Pose
    frame: int
    #: ∂pose/∂(right wheel scale) since the odometry's last anchor (see Odometry.sensitivity).
    sensitivity: tuple[float, float, float] = (0.0, 0.0, 0.0)


class _WheelSink:
    """The safety layer's only way to the wheels: raw Drive Direct writes."""

    def __init__(self, driver: CreateDriver) -> None:
        self._driver = driver

    def drive_direct(self, *, left: int, right: int) -> None:
        if self._driver.link_error is not None:
            # The layer already knows (on_link_lost); a dead link cannot carry the zero either.
            log.debug("drive_direct(left=%d, right=%d) not sent: link lost", left, right)
            return
        self._driver._write_raw(oi.drive_direct(left=left, right=right))


class CreateDriver:
    """An iRobot Create 1/2 over any pyserial URL, guarded by a :class:`SafetyLayer`.

    Args:
        port: device path or pyserial URL (``/dev/ttyUSB0``, ``socket://h:p``,
            ``rfc2217://h:p``, ``createsim://…``).
        model: ``"create1"``/``"create2"`` (bad names raise :class:`InputError`).
        baudrate: default 57600 (Create 1) or 115200 (Create 2); ``"auto"``: the first of
            :data:`AUTO_BAUDRATES` at which the robot answers.
        brc_line: the modem line (``"rts"``, ``"dtr"``) the cable wires to the robot's Baud
            Rate Change pin, or ``None``: wake and keep-alive pulses go there.
        wake_pulse_s: length of the BRC pulse ``connect`` sends (wall seconds).
        odometry_scale: ground travel per mm the encoders report (the mission's
            ``robot.odometry_scale``).
        clock: time for the safety watchdogs and sensor timestamps (default monotonic).
        mode: ``OIMode.SAFE`` (default) or ``OIMode.FULL``.
        command_timeout_s, sensor_timeout_s: the safety watchdogs.
        wheel_base_mm: odometry wheel base (default: the model's).
        start_pose: odometry start pose (default (0, 0) facing +y).
        stream_ids: packets to stream (default :func:`default_stream_ids`).
        first_frame_timeout_s: ``connect`` fails if no good frame arrives in this many seconds
            (``None``: do not wait; the sensor watchdog then counts from the stream request).
        wait_input: without a reader thread, what ``connect`` calls with a duration (s) to let
            the link's bytes arrive while it waits for the first frame (default
            ``time.sleep``; a lock-step simulation passes its step, so that its clock moves and
            a slow simulated link delivers the stream). The wait ends after
            ``first_frame_timeout_s`` on the driver's clock, or once the durations asked for add
            up to it.
        settle_s: wall-time pause after Start and after the mode command.
        open_port: the port factory (default :func:`marknav.robot.transport.open_port`).
        reader_thread: read in a background thread (default). With False the owner calls
            :meth:`process_input` (lock-step with a simulator on a manual clock).
    """

    def __init__(
        self,
        port: str,
        *,
        model: Model | str = Model.CREATE2,
        baudrate: int | Literal["auto"] | None = None,
        clock: Clock | None = None,
        mode: OIMode = OIMode.SAFE,
        command_timeout_s: float = 0.3,
        sensor_timeout_s: float = 0.2,
        wheel_base_mm: float | None = None,
        start_pose: Pose | None = None,
        stream_ids: Sequence[int] | None = None,
        first_frame_timeout_s: float | None = FIRST_FRAME_TIMEOUT_S,
        settle_s: float = 0.05,
        open_port: Callable[..., SerialPort] = open_port,
        reader_thread: bool = True,
        brc_line: str | None = "rts",
        wake_pulse_s: float = WAKE_PULSE_S,
        odometry_scale: float = 1.0,
        wait_input: Callable[[float], None] = time.sleep,
    ) -> None:
        try:
            self.model = Model.parse(model)
        except ValueError as exc:
            raise InputError(str(exc), field="model") from None
        if mode not in (OIMode.SAFE, OIMode.FULL):
            raise ValueError(f"mode must be OIMode.SAFE or OIMode.FULL, got {mode!r}")
        if brc_line not in (None, "rts", "dtr"):
            raise ValueError(f"brc_line must be 'rts', 'dtr' or None, got {brc_line!r}")
        self.port_url = port
        self.auto_baud = baudrate == "auto"
        self.baudrate = (self.model.default_baudrate if baudrate in (None, "auto")
                         else int(baudrate))
        self.mode = mode
        self.clock: Clock = clock or MonotonicClock()
        self._given_stream_ids = None if stream_ids is None else tuple(stream_ids)
        self._configure_stream(self.baudrate)
        self.brc_line = brc_line
        self.wake_pulse_s = float(wake_pulse_s)
        self._brc_usable = brc_line is not None
        self._pulse_end: float | None = None  # clock time to release a keep-alive pulse
        self._last_pulse_t: float | None = None
        self.first_frame_timeout_s = first_frame_timeout_s
        self._wait_input = wait_input
        self.settle_s = settle_s
        self._open_port = open_port
        self.reader_thread = reader_thread
        self._start_pose = start_pose
        self.odometry = Odometry(self.model, wheel_base_mm=wheel_base_mm, pose=start_pose,
                                 scale=odometry_scale)
        self.safety = SafetyLayer(_WheelSink(self), clock=self.clock,
                                  command_timeout_s=command_timeout_s,
                                  sensor_timeout_s=sensor_timeout_s)

        self._port: SerialPort | None = None
        self._write_lock = threading.Lock()
        self._state_lock = threading.Condition()
        self._reading: SensorReading | None = None
        self._sensors = SensorState.initial(self.model)
        self._frames = 0
        self._reader: threading.Thread | None = None
        self._stop_reader = threading.Event()
        self._link_error: str | None = None
        self._closed = False
        self._close_lock = threading.Lock()

    def _configure_stream(self, baudrate: int) -> None:
        """Choose and check the stream for a line of ``baudrate``; a new parser for it."""
        ids = (self._given_stream_ids if self._given_stream_ids is not None
               else default_stream_ids(self.model, baudrate))
        oi.stream(ids, model=self.model)  # validates the ids
        frame_bytes = 3 + oi.stream_ids_size(self.model, ids)
        budget = stream_budget_bytes(baudrate)
        if frame_bytes > STREAM_BUDGET_FRACTION * budget:
            raise ValueError(
                f"a stream frame of {frame_bytes} bytes is over {STREAM_BUDGET_FRACTION:.0%} of "
                f"the {budget:.0f} bytes per 15 ms at {baudrate} baud")
        self.stream_ids = ids
        self.stream_frame_bytes = frame_bytes
        self.parser = oi.StreamParser(self.model, expected_ids=ids)

    # --- lifecycle ----------------------------------------------------------------------------

    def connect(self) -> CreateDriver:
        """Open the port, start the OI in the chosen mode, start the stream and the reader.

        Raises :class:`InputError` naming the port if it cannot be opened or no good stream frame
        arrives within ``first_frame_timeout_s`` (wrong port, baud rate or model; robot off).
        Whatever ends it early (an error, Ctrl-C) closes the driver first: the robot is not
        left in Safe mode with its stream on.
        """
        if self._port is not None or self._closed:
            raise RuntimeError("a CreateDriver connects once; make a new one to reconnect")
        try:
            return self._connect()
        except BaseException:
            self.close()
            raise

    def _connect(self) -> CreateDriver:
        if self.auto_baud:
            port = self._detect_baudrate()
        else:
            port = self._open_port(self.port_url, baudrate=self.baudrate)
            self._port = port
            self._pulse_brc(port, self.wake_pulse_s)
        try:
            port.reset_input_buffer()
            self._write_raw(oi.start())
            time.sleep(self.settle_s)
            self._write_raw(oi.set_mode(self.mode))
            time.sleep(self.settle_s)
            self._write_raw(oi.stream(self.stream_ids, model=self.model))
        except LINK_ERRORS as exc:
            self._abandon_port()
            raise InputError(f"cannot talk to the robot: {exc}", file=self.port_url) from exc
        if self.reader_thread:
            self._reader = threading.Thread(target=self._read_loop, name="create-reader",
                                            daemon=True)
            self._reader.start()
        if self.first_frame_timeout_s is not None:
            try:
                self._wait_first_frame(self.first_frame_timeout_s)
            except TimeoutError:
                reason = self._link_error or (
                    f"no sensor stream within {self.first_frame_timeout_s:g} s "
                    f"(wrong port, baud rate {self.baudrate} or model {self.model.value}?)")
                self.close()
                raise InputError(reason, file=self.port_url) from None
        self.safety.connect()
        log.info("connected to %s on %s (%s mode)", self.model.value, self.port_url,
                 self.mode.name)
        return self

    def _detect_baudrate(self) -> SerialPort:
        """Open the port at each of :data:`AUTO_BAUDRATES` until the robot answers a query of
        its OI mode; keep it open at that rate. :class:`InputError` if none answers."""
        for i, baud in enumerate(AUTO_BAUDRATES):
            port = self._open_port(self.port_url, baudrate=baud)
            self._port = port
            if i == 0:
                self._pulse_brc(port, self.wake_pulse_s)  # once: three would change the baud
            try:
                answered = self._probe(port)
            except LINK_ERRORS as exc:
                self._abandon_port()
                raise InputError(f"cannot talk to the robot: {exc}", file=self.port_url) from exc
            if answered:
                log.info("%s: the robot answers at %d baud", self.port_url, baud)
                self.baudrate = baud
                self._configure_stream(baud)
                return port
            log.info("%s: no answer at %d baud", self.port_url, baud)
            self._abandon_port()
        rates = " or ".join(str(b) for b in AUTO_BAUDRATES)
        raise InputError(f"no answer at {rates} baud: check power, cable and baud",
                         file=self.port_url)

    def _probe(self, port: SerialPort) -> bool:
        """Start, pause any stream, then ask for the OI mode (packet 35): True if a mode byte
        (0..3) comes back within :data:`PROBE_TIMEOUT_S`."""
        port.write(oi.start())
        port.write(oi.pause_stream())
        time.sleep(self.settle_s)
        port.reset_input_buffer()
        port.write(oi.sensors(35, model=self.model))
        deadline = time.monotonic() + PROBE_TIMEOUT_S
        while time.monotonic() < deadline:
            data = port.read(1)
            if data:
                return data[0] <= 3
        return False

    def _pulse_brc(self, port: SerialPort, length_s: float) -> None:
        """One Baud Rate Change pulse (the BRC line asserted: the pin low) of ``length_s``."""
        if not self._set_brc(port, True):
            return
        if length_s > 0:
            time.sleep(length_s)
        self._set_brc(port, False)
        self._last_pulse_t = self.clock.now()

    def _set_brc(self, port: SerialPort, asserted: bool) -> bool:
        """Set the BRC line; False (noted once in the log) where the port has no modem lines."""
        if not self._brc_usable or self.brc_line is None:
            return False
        try:
            setattr(port, self.brc_line, asserted)
        except (serial.SerialException, OSError, AttributeError, ValueError,
                NotImplementedError) as exc:
            self._brc_usable = False
            log.info("%s: no %s line to pulse the Baud Rate Change pin (%s): in Passive mode "
                     "the robot sleeps after 5 minutes", self.port_url, self.brc_line.upper(),
                     exc)
            return False
        return True

    def _keep_awake(self, port: SerialPort) -> None:
        """In Passive mode, a BRC pulse every :data:`KEEPALIVE_PERIOD_S` (never blocking: the
        line is released on a later call once the pulse has lasted)."""
        if not self._brc_usable:
            return
        now = self.clock.now()
        if self._pulse_end is not None:
            if now >= self._pulse_end:
                self._set_brc(port, False)
                self._pulse_end = None
            return
        passive = self._sensors.oi_mode == OIMode.PASSIVE
        if not passive or self._reading is None:
            return
        due = self._last_pulse_t is None or now - self._last_pulse_t >= KEEPALIVE_PERIOD_S
        if due and self._set_brc(port, True):
            self._last_pulse_t = now
            self._pulse_end = now + KEEPALIVE_PULSE_S
            log.debug("%s: BRC keep-alive pulse (Passive mode)", self.port_url)

    def _wait_first_frame(self, timeout_s: float) -> None:
        if self.reader_thread:
            self.wait_for_sensors(timeout_s)
            return
        # Time waited: the driver's clock where wait_input moves it (a simulator's step may
        # run to its next stream tick), else the durations asked for (a clock that stands still).
        start, asked = self.clock.now(), 0.0
        while self.process_input() == 0 and self.latest is None:
            if self._link_error is not None or max(self.clock.now() - start, asked) > timeout_s:
                raise TimeoutError(self._link_error or "no sensor frame")
            self._wait_input(FIRST_FRAME_POLL_S)
            asked += FIRST_FRAME_POLL_S

    def close(self) -> None:
        """Stop the wheels, pause the stream, return the OI to Passive, close the port.

        Idempotent and safe after a lost link (writes that fail are logged, not raised).
        """
        with self._close_lock:
            if self._closed:
                return
            self._closed = True
        port = self._port
        if port is None:
            return
        self.safety.stop()  # zero through the layer (its state goes to ready)
        for command in (oi.drive_direct(left=0, right=0), oi.pause_stream(), oi.start()):
            if self._link_error is not None:
                break
            try:
                self._write_raw(command)
            except LINK_ERRORS:
                break
        self._stop_reader.set()
        if self._reader is not None and self._reader is not threading.current_thread():
            self._reader.join(timeout=2.0)
        self._abandon_port()
        log.info("closed %s", self.port_url)

    def _abandon_port(self) -> None:
        port, self._port = self._port, None
        if port is not None:
            try:
                port.close()
            except LINK_ERRORS as exc:
                log.debug("closing %s: %s", self.port_url, exc)

    def __enter__(self) -> CreateDriver:
        return self.connect()

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    # --- commands -----------------------------------------------------------------------------

    def drive(self, *, left: float, right: float) -> bool:
        """Wheel speeds in mm/s through the safety layer; False if it refused them."""
        return self.safety.command(left=left, right=right)

    def backoff(self, *, left: float, right: float) -> bool:
        """Like :meth:`drive`; while bumped it lets through motions with both wheels <= 0."""
        return self.safety.backoff(left=left, right=right)

    def stop(self) -> None:
        """Zero the wheels (always allowed)."""
        self.safety.stop()

    def estop(self, reason: str = "") -> None:
        """Zero the wheels and latch the safety layer until :meth:`reset`."""
        self.safety.estop(reason)

    def reset(self) -> bool:
        """Leave a latched fault/e-stop once its cause is gone (see ``SafetyLayer.reset``)."""
        return self.safety.reset()

    def set_mode(self, mode: OIMode) -> None:
        """Send the mode command (Safe, Full, or Passive via Start). After the robot dropped to
        Passive on a cliff or wheel drop, ``set_mode(OIMode.SAFE)`` then :meth:`reset`."""
        self._write(oi.set_mode(mode))
        if mode in (OIMode.SAFE, OIMode.FULL):
            self.mode = mode

    def leds(self, *, bits: int = 0, power_color: int = 0, power_intensity: int = 0) -> None:
        """LEDs (139); see :func:`marknav.robot.oi.leds`."""
        self._write(oi.leds(bits=bits, power_color=power_color, power_intensity=power_intensity))

    def song(self, number: int, notes: Sequence[tuple[int, int]]) -> None:
        """Store a song (140); see :func:`marknav.robot.oi.song`."""
        self._write(oi.song(number, notes, model=self.model))

    def play(self, number: int) -> None:
        """Play a stored song (141)."""
        self._write(oi.play(number, model=self.model))

    # --- state --------------------------------------------------------------------------------

    @property
    def connected(self) -> bool:
        return self._port is not None and not self._closed and self._link_error is None

    @property
    def link_error(self) -> str | None:
        """Why the serial link failed, or None while it works."""
        return self._link_error

    @property
    def frames_received(self) -> int:
        """Good stream frames handled so far."""
        with self._state_lock:
            return self._frames

    @property
    def latest(self) -> SensorReading | None:
        """The latest reading (None before the first good frame)."""
        with self._state_lock:
            return self._reading

    @property
    def sensors(self) -> SensorState | None:
        r = self.latest
        return None if r is None else r.state

    def pose(self) -> Pose:
        """Odometry pose in the world frame (mm, rad)."""
        r = self.latest
        return self.odometry.pose if r is None else r.pose

    def odometry_snapshot(self) -> tuple[Pose, tuple[float, float, float]]:
        """The pose and its sensitivity to the right wheel's scale, from one reading."""
        with self._state_lock:
            r = self._reading
            if r is None:
                return self.odometry.pose, self.odometry.sensitivity()
            return r.pose, r.sensitivity

    def scale_right_wheel(self, factor: float) -> None:
        """Calibrate odometry: the right wheel's travel counts ``factor`` times more from now on
        (see :mod:`marknav.planning.wheel_ratio`)."""
        with self._state_lock:
            self.odometry.scale_right_wheel(factor)  # re-anchors
            self._reanchored()

    def anchor_odometry(self) -> None:
        """Restart the odometry's sensitivity to the wheel scale from zero at the current pose."""
        with self._state_lock:
            self.odometry.anchor()
            self._reanchored()

    def _reanchored(self) -> None:
        """The latest reading's sensitivity after a re-anchor (call with the state lock)."""
        if self._reading is not None:
            self._reading = replace(self._reading, sensitivity=(0.0, 0.0, 0.0))

    @property
    def right_wheel_scale(self) -> float:
        """The right wheel's odometry scale (1 until calibrated)."""
        return self.odometry.right_scale

    def reset_odometry(self, pose: Pose | None = None) -> None:
        """Restart odometry at ``pose`` (default: the start pose)."""
        with self._state_lock:
            self.odometry.reset(pose or self._start_pose)
            if self._reading is not None:
                self._reading = SensorReading(self._reading.state, self._reading.t,
                                              self.odometry.pose, self._reading.frame)

    def wait_for_sensors(self, timeout_s: float = 1.0, *, after_frame: int = 0) -> SensorReading:
        """Block (wall time) until a reading with frame number > ``after_frame`` exists.

        Raises ``TimeoutError`` after ``timeout_s`` or at once if the link is lost.
        """
        deadline = time.monotonic() + timeout_s
        with self._state_lock:
            while self._reading is None or self._reading.frame <= after_frame:
                if self._link_error is not None:
                    raise TimeoutError(self._link_error)
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise TimeoutError(f"no sensor frame within {timeout_s:g} s")
                self._state_lock.wait(remaining)
            return self._reading

    @property
    def safety_state(self) -> str:
        """The safety layer's state name (``ready``, ``driving``, ``bumped``, ``fault``…)."""
        return self.safety.state.value

    @property
    def safety_events(self) -> list[SafetyEvent]:
        return self.safety.events

    @property
    def fault_reason(self) -> str | None:
        if self.safety.state is SafetyState.FAULT or self.safety.state is SafetyState.ESTOPPED:
            return self.safety.fault_reason or self._link_error
        return None

    # --- I/O ----------------------------------------------------------------------------------

    def _write_raw(self, data: bytes) -> None:
        """One whole command in one write; raises ``SerialException``/``OSError`` on failure
        (after recording the lost link). Used by the safety sink, which handles the error."""
        with self._write_lock:
            port = self._port
            if port is None:
                raise OSError("serial port is not open")
            if self._link_error is not None:
                raise OSError(f"serial link lost: {self._link_error}")
            try:
                port.write(data)
            except LINK_ERRORS as exc:
                self._mark_link_lost(f"serial write failed: {exc}")
                raise

    def _write(self, data: bytes) -> None:
        """A non-wheel command: failures go to the safety layer, never to the caller."""
        if self._port is None:
            raise RuntimeError("CreateDriver is not connected")
        try:
            self._write_raw(data)
        except LINK_ERRORS as exc:
            self.safety.on_link_lost(str(exc))

    def _mark_link_lost(self, message: str) -> bool:
        """Record the first link failure; True if this call recorded it."""
        with self._state_lock:
            if self._link_error is not None:
                return False
            self._link_error = message
            self._state_lock.notify_all()
        log.error("%s: %s", self.port_url, message)
        return True

    def process_input(self) -> int:
        """Handle the bytes already waiting, without blocking; return the good frames handled.

        For ``reader_thread=False`` (a lock-step simulation: step the simulator, then call
        this). Also runs ``safety.poll``. Link failures go to the safety layer, as in the thread.
        """
        if self._reader is not None:
            raise RuntimeError("the reader thread owns the port (reader_thread=True)")
        port = self._port
        if port is None or self._link_error is not None:
            self._poll_safety()
            return 0
        return self._service(port, blocking=False) or 0

    def _read_loop(self) -> None:
        port = self._port
        assert port is not None
        while not self._stop_reader.is_set():
            if self._service(port, blocking=True) is None:
                break

    def _service(self, port: SerialPort, *, blocking: bool) -> int | None:
        """One read and its frames, then ``safety.poll``; None when the link failed."""
        try:
            waiting = port.in_waiting
            if blocking:
                data = port.read(max(1, waiting))  # returns after the port timeout (15 ms)
            else:
                data = port.read(waiting) if waiting else b""
        except Exception as exc:  # SerialException/OSError, or a port closed under us
            if self._stop_reader.is_set() or self._closed:
                return None
            detail = str(exc) if isinstance(exc, LINK_ERRORS) else f"{type(exc).__name__}: {exc}"
            message = f"serial read failed: {detail}"
            if self._mark_link_lost(message):
                self.safety.on_link_lost(message)
            return None
        handled = 0
        if data:
            for frame in self.parser.feed(data):
                self._on_frame(frame)
                handled += 1
        self._poll_safety()
        try:
            self._keep_awake(port)
        except Exception:
            log.exception("BRC keep-alive failed")
        return handled

    def _poll_safety(self) -> None:
        try:
            self.safety.poll()
        except Exception:
            log.exception("safety.poll failed")

    def _on_frame(self, frame: oi.StreamFrame) -> None:
        state = self._sensors.with_packets(frame.values)
        self._sensors = state
        try:
            self.safety.on_sensors(state)  # first: a bump stops the wheels right here
        except Exception:
            log.exception("safety.on_sensors failed")
        t = self.clock.now()
        with self._state_lock:
            pose = self.odometry.update(state)
            self._frames += 1
            self._reading = SensorReading(state, t, pose, self._frames,
                                          self.odometry.sensitivity())
            self._state_lock.notify_all()
