"""A byte-level simulated iRobot Create 1 / Create 2 that speaks the Open Interface.

Bytes from the host go in with :meth:`SimulatedCreate.write`; bytes the robot sends come out of
:meth:`SimulatedCreate.read`. In between, the robot behaves as the OI specifications describe:

- OI modes (spec "Open Interface Modes"): Off until Start (128) — Reset (7, Create 2) is
  answered in Off mode too ("always available"); Start → Passive; Safe (131,
  also Control 130) and Full (132). Drive, LEDs and Play are ignored outside Safe/Full; in Safe
  mode a wheel drop, or a cliff while driving forward (or spinning / backing on a radius under
  one robot radius), stops the wheels and drops to Passive. Bumps stop nothing.
- Commands are framed with :func:`marknav.robot.oi.command_length`: a partial command waits for
  its remaining data bytes, as on the robot. Unknown opcodes are skipped one byte at a time.
- Sensors (142), Query List (149) and Stream (148, a frame every 15 ms of simulated time, at
  absolute 15 ms ticks) answer every single and group packet of the model. Distance (19) and
  angle (20) are the motion since they were last sent (the fraction not yet reported is kept,
  so nothing is lost); encoder counts (43/44, Create 2) are cumulative signed 16-bit and wrap.
- Motion belongs to a :class:`Body`: the OI side hands it the commanded wheel speeds for each
  stretch of time and it answers how far each wheel turned (what the encoders, distance and angle
  report) and where the robot is. The default :class:`KinematicBody` turns the wheels at the
  commanded speed and moves the ground by it times ``left_scale``/``right_scale`` (wheel
  mismatch) and an optional random slip, integrated with
  :func:`marknav.planning.kinematics.integrate_pose`. Odometry therefore cannot see slip, as on
  the real robot. Another engine (:mod:`marknav.sim.mujoco`) supplies a body stepped by its own
  physics; the byte handling here stays the same.
- Realities of a real Create (all off by default; :class:`marknav.sim.world.Conditions` sets
  them in simulated runs): the wheels reach a new speed at most at ``accel_mm_s2``; no wheel
  turns faster than ``top_speed_mm_s`` (a sagging battery: Create 2 users report 330 mm/s for
  500 commanded), clipped per wheel as a motor at full duty is; the encoders count
  ``encoder_scale`` times the nominal wheel's counts for the ground travelled (tyre wear, a
  wheel diameter off the spec's 72 mm) plus Gaussian noise of ``encoder_noise_counts`` per
  15 ms tick; bytes from the host take effect ``command_delay_s`` after they were written
  (USB adapter or Bluetooth link); ``ground_fn(pose)`` scales each wheel's ground travel by
  where it stands (friction patches; the built-in body only: another engine's floor has its
  own friction). The wheel speeds (ramps, top speed) go to the body, and the encoder scale
  and noise apply to what it reports: the motors and the encoders are the robot's, not the
  engine's.
- Power saving (spec "Passive Mode"): in Passive mode the robot sleeps after ``sleep_after_s``
  (300 s) without a Baud Rate Change pulse; asleep it ignores every byte and sends nothing. A BRC
  pulse (the pin pulled low: :meth:`set_modem_line` on the line the cable wires to BRC,
  ``brc_line``) resets the counter and wakes a sleeping robot with its OI off (Start needed).
- Line speed: a serial port that tells the robot its baud rate (:meth:`set_line_baudrate`; the
  ``createsim://`` port does) gets nothing through unless it matches the robot's
  :attr:`baudrate` (Create 2: 115200, Create 1: 57600, or what Baud (129) set): a wrong baud
  rate looks like a dead robot, as on the wire.

Time is the simulator's own: :meth:`advance_to`, :meth:`step` (an injected
:class:`~marknav.core.clock.ManualClock`) or :meth:`sync` (catch up to the injected clock, e.g. a
:class:`~marknav.core.clock.MonotonicClock` for real time), so runs are deterministic and can go
faster than real time. All public methods are thread-safe.
"""

from __future__ import annotations

import functools
import logging
import math
import random
import struct
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from threading import Condition, RLock
from typing import Protocol, runtime_checkable

from marknav.core.clock import Clock, ManualClock
from marknav.planning.kinematics import Pose, WheelSpeeds, integrate_pose
from marknav.robot import oi
from marknav.robot.odometry import MM_PER_COUNT
from marknav.robot.oi import Opcode
from marknav.robot.packets import (
    BumpsAndWheelDrops,
    Model,
    OIMode,
    Overcurrents,
    encode_packet,
    is_packet_id,
    member_ids,
    packet_layout,
)

__all__ = ["PASSIVE_SLEEP_S", "Body", "CommandRecord", "KinematicBody", "LedState",
           "SimulatedCreate"]

log = logging.getLogger(__name__)

_ROBOT_RADIUS_MM = 170.0
#: Passive mode sleeps after this long without a BRC pulse (spec "Passive Mode": five minutes).
PASSIVE_SLEEP_S = 300.0
#: Longest piece of time over which an accelerating wheel's speed is taken as constant, s.
_RAMP_STEP_S = 0.005
_BANNER = (b"\r\nmarknav simulated Roomba 600 (Create 2)\r\n"
           b"r3_robot/tags/release-3.4.1 (simulated)\r\nbattery-current-zero 0\r\n")


@dataclass(frozen=True)
class LedState:
    """The last LEDs (139) command: LED bits, power LED colour and intensity."""

    bits: int
    power_color: int
    power_intensity: int


@dataclass(frozen=True)
class CommandRecord:
    """One command the simulated robot executed (or ignored, ``accepted=False``)."""

    t: float
    opcode: int
    data: bytes
    accepted: bool


@runtime_checkable
class Body(Protocol):
    """The robot's body as the simulated Create moves it: the seam between the Open Interface
    (this module) and an engine's motion, contacts and wheel encoders.

    ``drive`` applies the commanded wheel speeds (mm/s, what the robot's wheel controller aims
    for) for ``dt`` seconds and returns how far each wheel turned, as its encoder measures it
    (mm of nominal tyre circumference): the Create reports distance, angle and encoder counts
    from that, never from the ground. ``pose`` is the true pose; ``set_pose`` places the robot
    (a test, the world resolving an overlap); ``odometer_mm`` is the true path length of the
    centre.
    """

    @property
    def pose(self) -> Pose: ...

    def set_pose(self, pose: Pose) -> None: ...

    def drive(self, *, left: float, right: float, dt: float) -> tuple[float, float]: ...

    @property
    def odometer_mm(self) -> float: ...


class KinematicBody:
    """The built-in body: wheels turn at exactly the commanded speed; the ground moves by it
    times ``left_scale``/``right_scale`` and a random relative slip per wheel (σ ``slip_std``
    per call, from ``seed``), integrated with :func:`marknav.planning.kinematics.integrate_pose`
    over ``wheel_base_mm``, each wheel's ground travel scaled by ``ground_fn(pose)`` where it
    stands (friction patches). No inertia of its own: the simulated Create ramps the speeds."""

    def __init__(self, pose: Pose, *, wheel_base_mm: float, left_scale: float = 1.0,
                 right_scale: float = 1.0, slip_std: float = 0.0,
                 seed: int | None = None,
                 ground_fn: Callable[[Pose], tuple[float, float]] | None = None) -> None:
        if not wheel_base_mm > 0:
            raise ValueError(f"wheel_base_mm must be positive, got {wheel_base_mm}")
        if slip_std < 0:
            raise ValueError(f"slip_std must be >= 0, got {slip_std}")
        self.wheel_base_mm = float(wheel_base_mm)
        self.left_scale = float(left_scale)
        self.right_scale = float(right_scale)
        self.slip_std = float(slip_std)
        self._rng = random.Random(seed)
        self.ground_fn = ground_fn
        self._pose = pose
        self._odometer_mm = 0.0

    @property
    def pose(self) -> Pose:
        return self._pose

    def set_pose(self, pose: Pose) -> None:
        self._pose = pose

    @property
    def odometer_mm(self) -> float:
        return self._odometer_mm

    def drive(self, *, left: float, right: float, dt: float) -> tuple[float, float]:
        if dt <= 0 or (left == 0.0 and right == 0.0):
            return 0.0, 0.0
        gl, gr = left * self.left_scale, right * self.right_scale
        if self.slip_std > 0.0:
            gl *= 1.0 + self._rng.gauss(0.0, self.slip_std)
            gr *= 1.0 + self._rng.gauss(0.0, self.slip_std)
        if self.ground_fn is not None:  # friction patches: each wheel slips where it stands
            fl, fr = self.ground_fn(self._pose)
            gl, gr = gl * fl, gr * fr
        self._pose = integrate_pose(self._pose, left=gl, right=gr, dt=dt,
                                    wheel_base_mm=self.wheel_base_mm)
        self._odometer_mm += abs(0.5 * (gl + gr)) * dt
        return left * dt, right * dt


class SimulatedCreate:
    """A simulated Create speaking the OI byte by byte (see the module docstring).

    Args:
        model: ``Model.CREATE1`` or ``Model.CREATE2`` (or its name).
        clock: the clock :meth:`sync` catches up to, and :meth:`step` advances when it is a
            ``ManualClock``. Default: a new ``ManualClock`` at 0.
        pose: the true start pose (default (0, 0) facing +y).
        wheel_base_mm: default: the model's (258 Create 1, 235 Create 2).
        left_scale, right_scale: ground speed / commanded speed per wheel (wheel mismatch).
        slip_std: standard deviation of an extra random relative slip per wheel and 15 ms tick.
        seed: seed of the slip and encoder noise.
        body: what moves (default a :class:`KinematicBody` from ``pose``, ``wheel_base_mm``,
            the scales, ``slip_std``, ``ground_fn`` and ``seed``, which are then ignored).
        max_output_bytes: bytes kept for the host before the oldest are dropped (a UART overrun).
        accel_mm_s2: largest wheel acceleration, mm/s² (``None``: speeds change at once).
        top_speed_mm_s: fastest a wheel turns, mm/s (battery sag; 500 is the OI's limit).
        encoder_scale: encoder counts per nominal count of ground travel (odometry scale error).
        encoder_noise_counts: σ of Gaussian noise added to each encoder per 15 ms tick, counts.
        command_delay_s: time from a host write to the robot acting on it, s.
        ground_fn: ``ground_fn(pose) -> (left, right)`` factors of each wheel's ground travel
            where the robot stands (friction patches); ``None``: 1 everywhere.
        sleep_after_s: Passive mode sleeps after this long without a BRC pulse (spec: 300 s).
        brc_line: the serial modem line (``"rts"``, ``"dtr"``) the cable wires to the Baud Rate
            Change pin, or ``None``: no cable line reaches it.
    """

    def __init__(
        self,
        *,
        model: Model | str = Model.CREATE2,
        clock: Clock | None = None,
        pose: Pose | None = None,
        wheel_base_mm: float | None = None,
        left_scale: float = 1.0,
        right_scale: float = 1.0,
        slip_std: float = 0.0,
        seed: int | None = None,
        max_output_bytes: int = 1 << 16,
        accel_mm_s2: float | None = None,
        top_speed_mm_s: float = 500.0,
        encoder_scale: float = 1.0,
        encoder_noise_counts: float = 0.0,
        command_delay_s: float = 0.0,
        ground_fn: Callable[[Pose], tuple[float, float]] | None = None,
        sleep_after_s: float = PASSIVE_SLEEP_S,
        brc_line: str | None = "rts",
        body: Body | None = None,
    ) -> None:
        self.model = Model.parse(model)
        if accel_mm_s2 is not None and not accel_mm_s2 > 0:
            raise ValueError(f"accel_mm_s2 must be positive or None, got {accel_mm_s2}")
        if not 0 < top_speed_mm_s <= 500:
            raise ValueError(f"top_speed_mm_s must be in (0, 500], got {top_speed_mm_s}")
        if not encoder_scale > 0 or encoder_noise_counts < 0 or command_delay_s < 0:
            raise ValueError("encoder_scale must be positive, encoder_noise_counts and "
                             "command_delay_s not negative")
        if brc_line not in (None, "rts", "dtr"):
            raise ValueError(f"brc_line must be 'rts', 'dtr' or None, got {brc_line!r}")
        self.accel_mm_s2 = accel_mm_s2
        self.top_speed_mm_s = float(top_speed_mm_s)
        self.encoder_scale = float(encoder_scale)
        self.encoder_noise_counts = float(encoder_noise_counts)
        self.command_delay_s = float(command_delay_s)
        self.ground_fn = ground_fn
        self.sleep_after_s = float(sleep_after_s)
        self.brc_line = brc_line
        self.clock: Clock = clock if clock is not None else ManualClock()
        self.wheel_base_mm = float(wheel_base_mm or self.model.wheel_base_mm)
        if not self.wheel_base_mm > 0:
            raise ValueError(f"wheel_base_mm must be positive, got {wheel_base_mm}")
        self.body: Body = body if body is not None else KinematicBody(
            pose or Pose(0.0, 0.0, math.pi / 2), wheel_base_mm=self.wheel_base_mm,
            left_scale=left_scale, right_scale=right_scale, slip_std=slip_std, seed=seed,
            ground_fn=ground_fn)
        # encoder noise: its own stream (the body's slip has the seed's)
        self._rng = random.Random(None if seed is None else f"encoders-{seed}")
        self._lock = RLock()
        self._output_ready = Condition(self._lock)
        self._max_output = int(max_output_bytes)

        self._t0 = self.clock.now()
        self._time = self._t0
        self._tick = 1  # index of the next 15 ms tick after _t0
        self._mode = OIMode.OFF
        self._in = bytearray()
        self._out = bytearray()
        self.dropped_output_bytes = 0
        self._unplugged = False
        self._delayed: deque[tuple[float, bytes]] = deque()  # (due time, bytes) in flight
        self._line_baudrate: int | None = None  # what the host's port is set to, if it says
        self._asleep = False
        self._passive_since = self._time  # last entry into Passive or BRC pulse
        self._brc_low = False
        self.brc_pulses = 0
        self.ignored_bytes = 0  # bytes lost to sleep or a wrong baud rate

        # actuators
        self._cmd_left = 0.0  # commanded wheel speeds, mm/s
        self._cmd_right = 0.0
        self._wheel_left = 0.0  # speeds the wheels turn at (acceleration, top speed), mm/s
        self._wheel_right = 0.0
        self._req_velocity = 0
        self._req_radius = 0
        self._req_left = 0
        self._req_right = 0
        self.leds: LedState | None = None
        self.songs: dict[int, tuple[tuple[int, int], ...]] = {}
        self.played: list[tuple[float, int]] = []
        self._song_number = 0
        self._song_end = -math.inf
        self.baudrate = self.model.default_baudrate
        self._stream_ids: tuple[int, ...] = ()
        self._stream_active = False
        self.frames_sent = 0
        self.commands: deque[CommandRecord] = deque(maxlen=4096)

        # sensors set by the world
        self._bumps = BumpsAndWheelDrops()
        self._cliffs = (False, False, False, False)
        self._wall = False
        self._virtual_wall = False
        self._light_bumper = 0
        self._overcurrents = Overcurrents()
        self.voltage_mv = 15200 if self.model is Model.CREATE2 else 14800
        self.battery_temp_c = 24
        self.capacity_mah = 2696 if self.model is Model.CREATE2 else 3000
        self._charge_mah = 2500.0

        # accumulators (wheel travel as the encoders see it)
        self._dist_acc = 0.0
        self._angle_acc = 0.0
        self._enc_left = 0.0
        self._enc_right = 0.0

    # --- time ---------------------------------------------------------------------------------

    @property
    def time(self) -> float:
        """The simulator's current time (seconds, the clock's scale)."""
        with self._lock:
            return self._time

    def now(self) -> float:
        """Same as :attr:`time`, so the simulator can serve as a
        :class:`~marknav.core.clock.Clock`."""
        return self.time

    def advance_to(self, t: float) -> None:
        """Simulate up to time ``t``: integrate motion and emit the stream frames due."""
        with self._lock:
            if t < self._time:
                return  # a clock read slightly earlier by another thread: nothing to do
            emitted = False
            while True:
                tick_t = self._t0 + self._tick * oi.STREAM_PERIOD_S
                if self._delayed and self._delayed[0][0] <= min(tick_t, t):
                    due, data = self._delayed.popleft()
                    self._integrate(due - self._time)
                    self._time = max(self._time, due)
                    self._receive(data)
                    emitted |= bool(self._out)
                    continue
                if tick_t > t:
                    self._integrate(t - self._time)
                    self._time = t
                    break
                self._integrate(tick_t - self._time)
                self._time = tick_t
                self._tick += 1
                emitted |= self._on_tick()
            if emitted:
                self._output_ready.notify_all()

    def step(self, dt: float) -> None:
        """Advance the injected ``ManualClock`` by ``dt`` and simulate up to it."""
        advance = getattr(self.clock, "advance", None)
        if advance is None:
            raise TypeError("step() needs a ManualClock-like clock with advance(dt); "
                            "use advance_to(t) or sync()")
        advance(dt)
        self.sync()

    def sync(self) -> None:
        """Catch up to the injected clock's ``now()``."""
        self.advance_to(self.clock.now())

    def next_tick_time(self) -> float:
        """Time of the next 15 ms sensor update (and stream frame, if streaming)."""
        with self._lock:
            return self._t0 + self._tick * oi.STREAM_PERIOD_S

    # --- byte interface -----------------------------------------------------------------------

    def write(self, data: bytes | bytearray) -> int:
        """Bytes from the host, executed at the current simulated time (or ``command_delay_s``
        later). Returns ``len(data)``."""
        with self._lock:
            if self._line_mismatch():
                self.ignored_bytes += len(data)  # framing errors: nothing the OI can read
                return len(data)
            if self.command_delay_s > 0:
                self._delayed.append((self._time + self.command_delay_s, bytes(data)))
                return len(data)
            self._receive(bytes(data))
            if self._out:
                self._output_ready.notify_all()
            return len(data)

    def _receive(self, data: bytes) -> None:
        if self._asleep:
            self.ignored_bytes += len(data)
            return
        self._in += data
        self._process_input()

    # --- modem lines, baud rate, sleep --------------------------------------------------------

    def set_modem_line(self, name: str, asserted: bool) -> None:
        """The host set its port's RTS or DTR line. Asserting the line the cable wires to BRC
        (``brc_line``) pulls the pin low; its release ends the pulse. A pulse resets the Passive
        sleep counter and wakes a sleeping robot (OI off)."""
        with self._lock:
            if name != self.brc_line:
                return
            low = bool(asserted)
            if low and not self._brc_low:
                self.brc_pulses += 1
                self._passive_since = self._time
                if self._asleep:
                    log.info("simulated %s: woken by a BRC pulse", self.model.value)
                    self._asleep = False
                    self._mode = OIMode.OFF
                    self._in.clear()
            self._brc_low = low

    def set_line_baudrate(self, baudrate: int | None) -> None:
        """The baud rate of the host's port (``None``: unknown, as for a pty or socket)."""
        with self._lock:
            self._line_baudrate = None if baudrate is None else int(baudrate)

    def _line_mismatch(self) -> bool:
        return self._line_baudrate is not None and self._line_baudrate != self.baudrate

    @property
    def asleep(self) -> bool:
        """True while the robot sleeps (Passive too long without a BRC pulse)."""
        with self._lock:
            return self._asleep

    def read(self, size: int | None = None) -> bytes:
        """Up to ``size`` (default all) bytes the robot has sent and nobody has read yet."""
        with self._lock:
            n = len(self._out) if size is None else min(size, len(self._out))
            data = bytes(self._out[:n])
            del self._out[:n]
            return data

    @property
    def in_waiting(self) -> int:
        """Bytes waiting in :meth:`read`."""
        with self._lock:
            return len(self._out)

    def clear_output(self) -> None:
        """Discard unread output (the host flushed its input buffer)."""
        with self._lock:
            self._out.clear()

    def wait_output(self, timeout: float) -> bool:
        """Block up to ``timeout`` wall seconds until output is available; True if there is."""
        with self._lock:
            if not self._out:
                self._output_ready.wait(timeout)
            return bool(self._out)

    def unplug(self) -> None:
        """Simulate a pulled cable: the pyserial adapters raise ``SerialException`` from now on."""
        with self._lock:
            self._unplugged = True
            self._output_ready.notify_all()

    @property
    def unplugged(self) -> bool:
        return self._unplugged

    # --- world interface ----------------------------------------------------------------------

    def set_bump(self, left: bool, right: bool) -> None:
        """Bumper contact (packet 7 bits 1 and 0). Stops nothing, as on the robot."""
        with self._lock:
            self._bumps = BumpsAndWheelDrops(
                bool(right), bool(left), self._bumps.wheel_drop_right,
                self._bumps.wheel_drop_left, self._bumps.caster_drop)

    def set_wheel_drop(self, *, left: bool = False, right: bool = False,
                       caster: bool = False) -> None:
        """Wheel drops (packet 7 bits 3, 2, and 4 = caster on Create 1; ignored on Create 2)."""
        with self._lock:
            self._bumps = BumpsAndWheelDrops(
                self._bumps.bump_right, self._bumps.bump_left, bool(right), bool(left),
                bool(caster) and self.model is Model.CREATE1)
            self._safety_check()

    def set_cliff(self, *, left: bool = False, front_left: bool = False,
                  front_right: bool = False, right: bool = False) -> None:
        """Cliff sensors (packets 9–12)."""
        with self._lock:
            self._cliffs = (bool(left), bool(front_left), bool(front_right), bool(right))
            self._safety_check()

    def set_light_bumper(self, bits: int) -> None:
        """Light bumper bits (packet 45, Create 2): bit0 left … bit5 right."""
        if not 0 <= bits <= 63:
            raise ValueError(f"light bumper bits must be in 0..63, got {bits}")
        with self._lock:
            self._light_bumper = bits

    def set_overcurrent(self, *, left_wheel: bool = False, right_wheel: bool = False) -> None:
        """Wheel overcurrent flags (packet 14)."""
        with self._lock:
            self._overcurrents = Overcurrents(left_wheel=bool(left_wheel),
                                              right_wheel=bool(right_wheel))

    def set_low_battery(self, low: bool) -> None:
        """A nearly empty battery: charge (packet 25) down to 2 % of capacity (26), voltage (22)
        12.0 V; ``False`` restores a charged battery."""
        with self._lock:
            if low:
                self._charge_mah = 0.02 * self.capacity_mah
                self.voltage_mv = 12000
            elif self.voltage_mv == 12000:
                self._charge_mah = 2500.0
                self.voltage_mv = 15200 if self.model is Model.CREATE2 else 14800

    def set_pose(self, pose: Pose) -> None:
        """Move the robot (the world resolving a collision, a test placing it)."""
        with self._lock:
            self.body.set_pose(pose)

    # --- state for the world and tests --------------------------------------------------------

    @property
    def pose(self) -> Pose:
        """The true pose (ground truth, including mismatch and slip)."""
        with self._lock:
            return self.body.pose

    @property
    def odometer_mm(self) -> float:
        """The true path length of the robot's centre, mm."""
        with self._lock:
            return self.body.odometer_mm

    @property
    def mode(self) -> OIMode:
        with self._lock:
            return self._mode

    @property
    def wheel_speeds(self) -> WheelSpeeds:
        """The wheel speeds the robot is applying (zero outside Safe/Full), mm/s."""
        with self._lock:
            return WheelSpeeds(left=self._cmd_left, right=self._cmd_right)

    @property
    def stream_ids(self) -> tuple[int, ...]:
        with self._lock:
            return self._stream_ids

    @property
    def streaming(self) -> bool:
        with self._lock:
            return self._stream_active and bool(self._stream_ids)

    @property
    def encoder_counts(self) -> tuple[int, int]:
        """(left, right) encoder counts as packets 43/44 report them."""
        with self._lock:
            return (_wrap16(self._enc_left), _wrap16(self._enc_right))

    @property
    def song_playing(self) -> bool:
        with self._lock:
            return self._time < self._song_end

    # --- internals: motion --------------------------------------------------------------------

    def _integrate(self, dt: float) -> None:
        if dt <= 0:
            return
        if self.accel_mm_s2 is None:
            self._integrate_at(dt, *self._target_speeds())
            return
        # ramps: in pieces short enough that a speed is nearly constant over each
        remaining = dt
        while remaining > 1e-12:
            h = min(remaining, _RAMP_STEP_S)
            tl, tr = self._target_speeds()
            dv = self.accel_mm_s2 * h
            vl = self._wheel_left + max(-dv, min(dv, tl - self._wheel_left))
            vr = self._wheel_right + max(-dv, min(dv, tr - self._wheel_right))
            self._integrate_at(h, vl, vr, mean=(0.5 * (self._wheel_left + vl),
                                                0.5 * (self._wheel_right + vr)))
            remaining -= h

    def _target_speeds(self) -> tuple[float, float]:
        top = self.top_speed_mm_s
        return (max(-top, min(top, self._cmd_left)), max(-top, min(top, self._cmd_right)))

    def _integrate_at(self, dt: float, vl: float, vr: float,
                      mean: tuple[float, float] | None = None) -> None:
        """Turn the wheels for ``dt`` ending at speeds (vl, vr), at ``mean`` speeds meanwhile."""
        self._wheel_left, self._wheel_right = vl, vr
        ml, mr = mean if mean is not None else (vl, vr)
        # the body moves; what the wheels turned is what encoders, distance and angle see
        dl, dr = self.body.drive(left=ml, right=mr, dt=dt)
        if dl == 0.0 and dr == 0.0:
            return
        self._enc_left += dl * self.encoder_scale / MM_PER_COUNT
        self._enc_right += dr * self.encoder_scale / MM_PER_COUNT
        self._dist_acc += 0.5 * (dl + dr) * self.encoder_scale
        self._angle_acc += math.degrees((dr - dl) * self.encoder_scale / self.wheel_base_mm)
        self._charge_mah = max(0.0, self._charge_mah + self._current_ma() * dt / 3600.0)

    def _current_ma(self) -> int:
        return -int(150 + 0.6 * (abs(self._cmd_left) + abs(self._cmd_right)))

    def _set_wheels(self, left: float, right: float) -> None:
        self._cmd_left, self._cmd_right = float(left), float(right)
        self._safety_check()

    def _stop_wheels(self) -> None:
        self._cmd_left = self._cmd_right = 0.0

    def _safety_check(self) -> None:
        """Safe mode's own reactions (spec "Safe Mode"): wheel drop, or cliff while moving
        forward / turning on a small radius backward → stop and revert to Passive."""
        if self._mode is not OIMode.SAFE:
            return
        b = self._bumps
        dropped = b.wheel_drop_left or b.wheel_drop_right or b.caster_drop
        cliff = any(self._cliffs)
        vl, vr = self._cmd_left, self._cmd_right
        moving_risky = False
        if cliff and (vl or vr):
            v = 0.5 * (vl + vr)
            if v > 0:
                moving_risky = True
            elif vr != vl:
                radius = 0.5 * self.wheel_base_mm * (vr + vl) / (vr - vl)
                moving_risky = abs(radius) < _ROBOT_RADIUS_MM
        if dropped or moving_risky:
            log.info("safe mode: %s, stopping and reverting to passive",
                     "wheel drop" if dropped else "cliff")
            self._stop_wheels()
            self._enter_passive()

    def _enter_passive(self) -> None:
        if self._mode is not OIMode.PASSIVE:
            self._passive_since = self._time
        self._mode = OIMode.PASSIVE

    def _on_tick(self) -> bool:
        """One 15 ms sensor update; returns True if a stream frame was emitted."""
        self._safety_check()
        if self.encoder_noise_counts > 0.0 and (self._wheel_left or self._wheel_right):
            self._enc_left += self._rng.gauss(0.0, self.encoder_noise_counts)
            self._enc_right += self._rng.gauss(0.0, self.encoder_noise_counts)
        if (not self._asleep and self._mode is OIMode.PASSIVE
                and self._time - self._passive_since >= self.sleep_after_s):
            log.info("simulated %s: asleep after %.0f s in Passive without a BRC pulse",
                     self.model.value, self._time - self._passive_since)
            self._asleep = True
            self._stream_active = False
        if self._asleep:
            return False
        if self._stream_active and self._stream_ids:
            self._emit(self._stream_frame())
            self.frames_sent += 1
            return True
        return False

    def _stream_frame(self) -> bytes:
        """The stream frame of the current stream ids, ``[19][n][id][data…]…[checksum]``: the
        bytes ``oi.stream_frame`` of the packets' ``encode_packet`` gives, packed at once with
        the stream's precomputed layout (every 15 ms of simulated time)."""
        layout, template, slots = _stream_plan(self.model, self._stream_ids)
        args = list(template)
        for slot, get, lo, hi in slots:
            value = int(get(self))
            args[slot] = lo if value < lo else (hi if value > hi else value)
        body = layout.pack(*args)
        return body + bytes((-sum(body) & 0xFF,))

    def _emit(self, data: bytes) -> None:
        if self._line_mismatch():
            return  # at the wrong baud rate the host reads nothing it can use
        self._out += data
        excess = len(self._out) - self._max_output
        if excess > 0:
            if self.dropped_output_bytes == 0:
                log.warning("nobody reads the simulated robot: dropping old output")
            del self._out[:excess]
            self.dropped_output_bytes += excess

    # --- internals: sensors -------------------------------------------------------------------

    def _take_accumulator(self, name: str) -> int:
        acc = getattr(self, name)
        report = max(-32768, min(32767, math.trunc(acc)))
        setattr(self, name, acc - report)
        return report

    def _raw(self, pid: int) -> int:
        """The raw integer the robot reports for single packet ``pid`` (see :data:`_RAW`)."""
        return _RAW.get(pid, _zero)(self)

    def _packet_bytes(self, pid: int) -> bytes:
        raw = {m: self._raw(m) for m in member_ids(self.model, pid)}
        return encode_packet(self.model, pid, raw)

    # --- internals: commands ------------------------------------------------------------------

    def _process_input(self) -> None:
        buf = self._in
        while buf:
            if self._mode is OIMode.OFF and buf[0] not in self._off_mode_opcodes:
                # an Off OI only listens for Start (and Reset, which the Create 2 spec says is
                # always available); everything else is lost
                del buf[:1]
                continue
            try:
                n = oi.command_length(self.model, buf)
            except ValueError:
                log.debug("simulated %s: skipping unknown byte %d", self.model.value, buf[0])
                del buf[:1]
                continue
            if n is None or len(buf) < n:
                return  # wait for the rest of the command, as the robot does
            cmd = bytes(buf[:n])
            del buf[:n]
            accepted = self._execute(cmd[0], cmd[1:])
            self.commands.append(CommandRecord(self._time, cmd[0], cmd[1:], accepted))

    @property
    def _off_mode_opcodes(self) -> tuple[int, ...]:
        if self.model is Model.CREATE2:
            return (Opcode.START, Opcode.RESET)
        return (Opcode.START,)  # the Create 1 has no Reset

    def _execute(self, op: int, data: bytes) -> bool:
        mode = self._mode
        active = mode in (OIMode.SAFE, OIMode.FULL)
        if op == Opcode.START:
            self._stop_wheels()
            self._enter_passive()
        elif op in (Opcode.SAFE, Opcode.CONTROL):
            self._mode = OIMode.SAFE
            if self.model is Model.CREATE2:
                self.leds = LedState(0, 0, 0)  # Create 2 spec: Safe turns off all LEDs
            self._safety_check()
        elif op == Opcode.FULL:
            self._mode = OIMode.FULL
        elif op == Opcode.BAUD:
            rates = {code: rate for rate, code in oi.BAUD_CODES.items()}
            if data[0] not in rates:
                return False
            # Recorded only: a pty or socket has no line speed to change.
            self.baudrate = rates[data[0]]
        elif op in (Opcode.RESET, Opcode.STOP):
            self._stop_wheels()
            self._mode = OIMode.OFF
            self._stream_active = False
            self._stream_ids = ()
            if op == Opcode.RESET:
                self._emit(_BANNER)
        elif op in (Opcode.POWER, Opcode.SPOT, Opcode.CLEAN, Opcode.MAX, Opcode.SEEK_DOCK):
            self._stop_wheels()  # cleaning/demo modes are not simulated: they just end control
            self._enter_passive()
        elif op == Opcode.DRIVE:
            if not active:
                return False
            self._drive(int.from_bytes(data[0:2], "big", signed=True),
                        int.from_bytes(data[2:4], "big", signed=False))
        elif op == Opcode.DRIVE_DIRECT:
            if not active:
                return False
            right = int.from_bytes(data[0:2], "big", signed=True)
            left = int.from_bytes(data[2:4], "big", signed=True)
            self._req_right, self._req_left = _clamp(right, 500), _clamp(left, 500)
            self._set_wheels(self._req_left, self._req_right)
        elif op == Opcode.DRIVE_PWM:
            if not active:
                return False
            right = _clamp(int.from_bytes(data[0:2], "big", signed=True), 255)
            left = _clamp(int.from_bytes(data[2:4], "big", signed=True), 255)
            # modelled as speed proportional to duty cycle, full duty = 500 mm/s
            self._set_wheels(left * 500.0 / 255.0, right * 500.0 / 255.0)
        elif op == Opcode.LEDS:
            if not active:
                return False
            self.leds = LedState(data[0], data[1], data[2])
        elif op == Opcode.SONG:
            return self._song(data)
        elif op == Opcode.PLAY:
            return active and self._play(data[0])
        elif op == Opcode.SENSORS:
            if not is_packet_id(self.model, data[0]):
                return False
            self._emit(self._packet_bytes(data[0]))
        elif op == Opcode.QUERY_LIST:
            queried = list(data[1:])
            if not all(is_packet_id(self.model, i) for i in queried):
                return False
            self._emit(b"".join(self._packet_bytes(i) for i in queried))
        elif op == Opcode.STREAM:
            ids = tuple(data[1:])
            if not all(is_packet_id(self.model, i) for i in ids):
                return False
            self._stream_ids = ids
            self._stream_active = bool(ids)
        elif op == Opcode.PAUSE_RESUME_STREAM:
            self._stream_active = bool(data[0])
        else:
            log.debug("simulated %s: opcode %d accepted, not simulated", self.model.value, op)
        return True

    def _drive(self, velocity: int, radius_raw: int) -> None:
        v = _clamp(velocity, 500)
        radius = radius_raw - 0x10000 if radius_raw >= 0x8000 else radius_raw
        self._req_velocity, self._req_radius = v, radius
        half = 0.5 * self.wheel_base_mm
        if radius_raw in (0x8000, 0x7FFF) or radius == 0:
            left = right = float(v)
        elif radius == -1:
            left, right = float(v), float(-v)
        elif radius == 1:
            left, right = float(-v), float(v)
        else:
            r = float(_clamp(radius, 2000))
            left, right = v * (r - half) / r, v * (r + half) / r
            peak = max(abs(left), abs(right))
            if peak > 500:
                left, right = left * 500 / peak, right * 500 / peak
        self._set_wheels(left, right)

    def _song(self, data: bytes) -> bool:
        number, length = data[0], data[1]
        limit = 15 if self.model is Model.CREATE1 else 4
        if number > limit or not 1 <= length <= 16:
            return False
        notes = tuple((data[2 + 2 * i], data[3 + 2 * i]) for i in range(length))
        self.songs[number] = notes
        return True

    def _play(self, number: int) -> bool:
        if number not in self.songs or self._time < self._song_end:
            return False
        self._song_number = number
        self._song_end = self._time + sum(d for _, d in self.songs[number]) / 64.0
        self.played.append((self._time, number))
        return True

    def stream_frame_size(self, ids: Sequence[int] | None = None) -> int:
        """Bytes per stream frame for ``ids`` (default: the current stream)."""
        ids = self._stream_ids if ids is None else tuple(ids)
        return 3 + oi.stream_ids_size(self.model, ids)


def _clamp(value: int, limit: int) -> int:
    return max(-limit, min(limit, value))


def _wrap16(counts: float) -> int:
    return (round(counts) + 0x8000) % 0x10000 - 0x8000


def _zero(_sim: SimulatedCreate) -> int:
    return 0  # unused bytes, dirt detect, buttons, charging, IR left/right, brushes


def _raw_getters() -> dict[int, Callable[[SimulatedCreate], int]]:
    """Single packet id → the raw integer the simulated robot reports (ids not here: 0)."""
    c1: Callable[[SimulatedCreate], bool] = lambda s: s.model is Model.CREATE1  # noqa: E731
    get: dict[int, Callable[[SimulatedCreate], int]] = {
        7: lambda s: s._bumps.to_raw(),
        8: lambda s: int(s._wall),
        13: lambda s: int(s._virtual_wall),
        14: lambda s: s._overcurrents.to_raw(s.model),
        17: lambda s: 255 if c1(s) else 0,
        19: lambda s: s._take_accumulator("_dist_acc"),
        20: lambda s: s._take_accumulator("_angle_acc"),
        22: lambda s: s.voltage_mv,
        23: lambda s: s._current_ma(),
        24: lambda s: s.battery_temp_c,
        25: lambda s: int(s._charge_mah),
        26: lambda s: s.capacity_mah,
        27: lambda s: 300 if s._wall else 0,
        32: lambda s: 16 if c1(s) else 0,  # Create 1: baud-rate-change pin high (its default)
        35: lambda s: int(s._mode),
        36: lambda s: s._song_number,
        37: lambda s: int(s._time < s._song_end),
        38: lambda s: len(s._stream_ids),
        39: lambda s: s._req_velocity,
        40: lambda s: s._req_radius,
        41: lambda s: s._req_right,
        42: lambda s: s._req_left,
        43: lambda s: _wrap16(s._enc_left),
        44: lambda s: _wrap16(s._enc_right),
        45: lambda s: s._light_bumper | (32 if s._wall else 0),
        54: lambda s: int(0.4 * abs(s._cmd_left)),
        55: lambda s: int(0.4 * abs(s._cmd_right)),
        58: lambda s: int(s._cmd_left + s._cmd_right > 0 and not s._bumps.bump_left
                          and not s._bumps.bump_right),
    }
    for i in range(4):
        get[9 + i] = lambda s, i=i: int(s._cliffs[i])  # type: ignore[misc]
        get[28 + i] = lambda s, i=i: 20 if s._cliffs[i] else 2400  # type: ignore[misc]
    for i in range(6):
        get[46 + i] = lambda s, i=i: 1200 if s._light_bumper >> i & 1 else 8  # type: ignore[misc]
    return get


#: How the simulated robot computes each single packet's raw value (its sensor model).
_RAW = _raw_getters()


@functools.lru_cache(maxsize=64)
def _stream_plan(
    model: Model, ids: tuple[int, ...]
) -> tuple[struct.Struct, tuple[int, ...],
           tuple[tuple[int, Callable[[SimulatedCreate], int], int, int], ...]]:
    """A stream frame of ``ids`` without its checksum as one big-endian struct, the pack
    arguments with the constant bytes (header, n, packet ids) filled in, and for every member
    packet its argument slot, raw-value getter and raw range (values are saturated to it, as
    :func:`~marknav.robot.packets.encode_packet` does)."""
    n = oi.stream_ids_size(model, ids)
    if n > 255:
        raise ValueError(f"a stream payload has at most 255 bytes, got {n}")
    fmt = [">BB"]
    template: list[int] = [oi.STREAM_HEADER, n]
    slots: list[tuple[int, Callable[[SimulatedCreate], int], int, int]] = []
    for pid in ids:
        layout, specs, ranges = packet_layout(model, pid)
        fmt.append("B" + layout.format.lstrip(">"))
        template.append(pid)
        for spec, (lo, hi) in zip(specs, ranges, strict=True):
            slots.append((len(template), _RAW.get(spec.id, _zero), lo, hi))
            template.append(0)
    return struct.Struct("".join(fmt)), tuple(template), tuple(slots)
