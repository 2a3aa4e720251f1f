"""The iRobot Create Open Interface wire format, as data: opcodes, commands, stream frames.

Implements the "Open Interface Command Reference" of the Create 1 and Create 2 OI
specifications (Getting Started, Mode, Actuator and Input commands) and the Stream (148) frame
format ``[19][n][id][data…]…[checksum]``. Sensor packets are in :mod:`marknav.robot.packets`
and re-exported here.

Command encoders return the whole command as ``bytes`` (send it in one ``write``: a robot left
waiting for data bytes misreads what follows). All multi-byte values are big-endian two's
complement. Range policy, one rule per kind of value:

- **clamped** (a physical limit the caller may legitimately hit): Drive velocity to ±500 mm/s and
  radius to ±2000 mm (except the special radii); Drive Direct wheel speeds to ±500 mm/s and Drive
  PWM to ±255, where *both wheels are scaled by one factor* so the driven curve is unchanged.
  Non-integer values are rounded to the nearest integer.
- **ValueError** (a caller bug): NaN/infinite speeds, a radius of 0, packet ids the model lacks,
  song numbers/lengths/notes out of range, LED bytes outside 0–255, unsupported baud rates.

Stream checksum: the byte sum of the whole frame *including the header 19 and the checksum* is 0
mod 256. The Create 2 specification's example (``19 5 29 2 25 13 0 163``) satisfies this; the
Create 1 text's wording and example (…``182``) leave the header out, which real robots do not.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any

from marknav.robot.packets import (
    BumpsAndWheelDrops,
    Buttons,
    CargoBayInputs,
    ChargingSources,
    ChargingState,
    LightBumper,
    Model,
    OIMode,
    Overcurrents,
    PacketSpec,
    SensorState,
    decode_id_data_pairs,
    decode_packet,
    encode_packet,
    group_table,
    is_packet_id,
    member_ids,
    packet_size,
    packet_table,
    stream_ids_size,
)

__all__ = [
    "BAUD_CODES",
    "MAX_PWM",
    "MAX_RADIUS_MM",
    "MAX_VELOCITY_MM_S",
    "RADIUS_SPIN_CLOCKWISE",
    "RADIUS_SPIN_COUNTER_CLOCKWISE",
    "RADIUS_STRAIGHT",
    "RADIUS_STRAIGHT_ALT",
    "RADIUS_STRAIGHT_SIGNED",
    "STREAM_HEADER",
    "STREAM_PERIOD_S",
    "BumpsAndWheelDrops",
    "Buttons",
    "CargoBayInputs",
    "ChargingSources",
    "ChargingState",
    "LightBumper",
    "Model",
    "OIMode",
    "Opcode",
    "Overcurrents",
    "PacketSpec",
    "SensorState",
    "StreamFrame",
    "StreamParser",
    "baud",
    "checksum",
    "command_length",
    "decode_id_data_pairs",
    "decode_packet",
    "drive",
    "drive_direct",
    "drive_pwm",
    "drive_straight",
    "encode_packet",
    "full",
    "group_table",
    "is_packet_id",
    "leds",
    "member_ids",
    "packet_size",
    "packet_table",
    "passive",
    "pause_resume_stream",
    "pause_stream",
    "play",
    "query_list",
    "reset",
    "resume_stream",
    "safe",
    "sensors",
    "set_mode",
    "song",
    "start",
    "stop",
    "stream",
    "stream_frame",
    "stream_ids_size",
    "turn_in_place",
]


class Opcode(IntEnum):
    """OI opcodes. Where the models name one opcode differently, the Create 2 name is used and
    the Create 1 name is given in the comment."""

    RESET = 7  # Create 2 only
    START = 128
    BAUD = 129
    CONTROL = 130  # same as SAFE
    SAFE = 131
    FULL = 132
    POWER = 133  # Create 2 only
    SPOT = 134
    CLEAN = 135  # Create 1: Cover
    MAX = 136  # Create 1: Demo (1 data byte)
    DRIVE = 137
    MOTORS = 138  # Create 1: Low Side Drivers
    LEDS = 139
    SONG = 140
    PLAY = 141
    SENSORS = 142
    SEEK_DOCK = 143  # Create 1: Cover and Dock
    PWM_MOTORS = 144  # Create 1: PWM Low Side Drivers
    DRIVE_DIRECT = 145
    DRIVE_PWM = 146  # Create 2 only
    DIGITAL_OUTPUTS = 147  # Create 1 only
    STREAM = 148
    QUERY_LIST = 149
    PAUSE_RESUME_STREAM = 150
    SEND_IR = 151  # Create 1 only
    SCRIPT = 152  # Create 1 only
    PLAY_SCRIPT = 153  # Create 1 only
    SHOW_SCRIPT = 154  # Create 1 only
    WAIT_TIME = 155  # Create 1 only
    WAIT_DISTANCE = 156  # Create 1 only
    WAIT_ANGLE = 157  # Create 1 only
    WAIT_EVENT = 158  # Create 1 only
    SCHEDULING_LEDS = 162  # Create 2 only
    DIGIT_LEDS_RAW = 163  # Create 2 only
    DIGIT_LEDS_ASCII = 164  # Create 2 only
    BUTTONS = 165  # Create 2 only
    SCHEDULE = 167  # Create 2 only
    SET_DAY_TIME = 168  # Create 2 only
    STOP = 173  # Create 2 only


MAX_VELOCITY_MM_S = 500
MAX_RADIUS_MM = 2000
MAX_PWM = 255
#: Drive radius special cases (spec: "Straight = 32768 or 32767 = 0x8000 or 0x7FFF").
RADIUS_STRAIGHT = 0x8000
RADIUS_STRAIGHT_ALT = 0x7FFF
#: 0x8000 read as a signed 16-bit number, as packet 40 (Requested Radius) reports "straight":
#: a radius read back from the robot and sent again must drive straight too, not a 2 m arc.
RADIUS_STRAIGHT_SIGNED = -0x8000
RADIUS_SPIN_CLOCKWISE = -1
RADIUS_SPIN_COUNTER_CLOCKWISE = 1
#: Baud rate (bit/s) → baud code of the Baud command (129).
BAUD_CODES: Mapping[int, int] = {
    300: 0, 600: 1, 1200: 2, 2400: 3, 4800: 4, 9600: 5, 14400: 6, 19200: 7, 28800: 8,
    38400: 9, 57600: 10, 115200: 11,
}
STREAM_HEADER = 19
#: The robot updates its sensors and sends one stream frame every 15 ms.
STREAM_PERIOD_S = 0.015

_SONG_NUMBERS = {Model.CREATE1: 15, Model.CREATE2: 4}


def _i16(value: int) -> bytes:
    return int(value).to_bytes(2, "big", signed=True)


def _finite(name: str, value: float) -> float:
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return v


def _clamp(value: float, limit: int) -> int:
    return max(-limit, min(limit, round(value)))


def _byte(name: str, value: int, lo: int = 0, hi: int = 255) -> int:
    if isinstance(value, bool) or int(value) != value or not lo <= value <= hi:
        raise ValueError(f"{name} must be an integer in {lo}..{hi}, got {value!r}")
    return int(value)


def _scale_pair(left: float, right: float, limit: int) -> tuple[int, int]:
    """Both wheels scaled by one factor so that neither exceeds ``limit``, then rounded."""
    left = _finite("left", left)
    right = _finite("right", right)
    peak = max(abs(left), abs(right))
    if peak > limit:
        k = limit / peak
        left, right = left * k, right * k
    return _clamp(left, limit), _clamp(right, limit)


# --- Getting started and mode commands ---------------------------------------------------------

def start() -> bytes:
    """Start (128): starts the OI; from any mode the robot goes to Passive."""
    return bytes([Opcode.START])


def passive() -> bytes:
    """Passive mode is entered with Start (128) (there is no separate opcode)."""
    return start()


def reset() -> bytes:
    """Reset (7, Create 2): as if the battery were removed; the robot prints a banner."""
    return bytes([Opcode.RESET])


def stop() -> bytes:
    """Stop (173, Create 2): stops the OI and all streams; mode Off."""
    return bytes([Opcode.STOP])


def baud(rate: int) -> bytes:
    """Baud (129) to ``rate`` bit/s (wait 100 ms before sending at the new rate).

    Raises ValueError for a rate without a baud code (see :data:`BAUD_CODES`).
    """
    if rate not in BAUD_CODES:
        raise ValueError(f"unsupported baud rate {rate} (supported: {sorted(BAUD_CODES)})")
    return bytes([Opcode.BAUD, BAUD_CODES[rate]])


def safe() -> bytes:
    """Safe (131): full control except the robot stops itself on cliffs and wheel drops."""
    return bytes([Opcode.SAFE])


def full() -> bytes:
    """Full (132): full control, no built-in safety reactions."""
    return bytes([Opcode.FULL])


def set_mode(mode: OIMode) -> bytes:
    """The command that enters ``mode`` (Passive → Start; OFF → ValueError: use :func:`stop`)."""
    if mode is OIMode.PASSIVE:
        return start()
    if mode is OIMode.SAFE:
        return safe()
    if mode is OIMode.FULL:
        return full()
    raise ValueError(f"no command enters mode {mode.name} (use stop() on a Create 2)")


# --- Actuator commands ------------------------------------------------------------------------

def drive(*, velocity: float, radius: int) -> bytes:
    """Drive (137): ``[137][velocity hi][lo][radius hi][lo]``.

    ``velocity`` (mm/s, negative = backward) is clamped to ±500. ``radius`` (mm, positive = turn
    left) is clamped to ±2000 unless it is a special case, sent as is: :data:`RADIUS_STRAIGHT`
    (0x8000, sent ``128 0``; its signed reading −32768, :data:`RADIUS_STRAIGHT_SIGNED`, is the
    same), :data:`RADIUS_STRAIGHT_ALT` (0x7FFF), :data:`RADIUS_SPIN_CLOCKWISE`
    (−1) or :data:`RADIUS_SPIN_COUNTER_CLOCKWISE` (1). A radius of 0 raises ValueError.
    """
    v = _clamp(_finite("velocity", velocity), MAX_VELOCITY_MM_S)
    r_in = _finite("radius", radius)
    if r_in in (RADIUS_STRAIGHT, RADIUS_STRAIGHT_ALT, RADIUS_STRAIGHT_SIGNED):
        r_bytes = (int(r_in) & 0xFFFF).to_bytes(2, "big")
    elif round(r_in) == 0:
        raise ValueError("radius 0 is undefined: use RADIUS_STRAIGHT or turn_in_place()")
    else:
        r_bytes = _i16(_clamp(r_in, MAX_RADIUS_MM))
    return bytes([Opcode.DRIVE]) + _i16(v) + r_bytes


def drive_straight(velocity: float) -> bytes:
    """Drive (137) straight at ``velocity`` mm/s (radius 0x8000)."""
    return drive(velocity=velocity, radius=RADIUS_STRAIGHT)


def turn_in_place(speed: float, *, clockwise: bool) -> bytes:
    """Drive (137) spinning in place, each wheel at ``|speed|`` mm/s (radius ∓1)."""
    radius = RADIUS_SPIN_CLOCKWISE if clockwise else RADIUS_SPIN_COUNTER_CLOCKWISE
    return drive(velocity=abs(_finite("speed", speed)), radius=radius)


def drive_direct(*, left: float, right: float) -> bytes:
    """Drive Direct (145): ``[145][right hi][lo][left hi][lo]`` — the RIGHT wheel goes first.

    Wheel speeds in mm/s; if one exceeds ±500 both are scaled by the same factor.
    """
    l_mm, r_mm = _scale_pair(left, right, MAX_VELOCITY_MM_S)
    return bytes([Opcode.DRIVE_DIRECT]) + _i16(r_mm) + _i16(l_mm)


def drive_pwm(*, left: float, right: float) -> bytes:
    """Drive PWM (146, Create 2): ``[146][right hi][lo][left hi][lo]``, duty −255..255.

    If one exceeds ±255 both are scaled by the same factor.
    """
    l_pwm, r_pwm = _scale_pair(left, right, MAX_PWM)
    return bytes([Opcode.DRIVE_PWM]) + _i16(r_pwm) + _i16(l_pwm)


def leds(*, bits: int = 0, power_color: int = 0, power_intensity: int = 0) -> bytes:
    """LEDs (139): ``[139][LED bits][power colour][power intensity]``, each 0–255 (ValueError
    otherwise). Create 1 bits: 1 Play, 3 Advance; Create 2: 0 Debris, 1 Spot, 2 Dock, 3 Check
    Robot. Colour 0 = green … 255 = red."""
    return bytes([Opcode.LEDS, _byte("LED bits", bits), _byte("power LED colour", power_color),
                  _byte("power LED intensity", power_intensity)])


def song(number: int, notes: Sequence[tuple[int, int]], *, model: Model) -> bytes:
    """Song (140): ``[140][number][length][note][duration]…``.

    ``number`` 0–4 (Create 2) or 0–15 (Create 1); 1–16 ``(note, duration)`` pairs, note a MIDI
    number (31–127 sound, other bytes are rests), duration in 1/64 s (0–255). Anything out of
    range raises ValueError (a wrong song length would make the robot swallow later commands).
    """
    _byte("song number", number, 0, _SONG_NUMBERS[model])
    if not 1 <= len(notes) <= 16:
        raise ValueError(f"a song has 1-16 notes, got {len(notes)}")
    out = bytearray([Opcode.SONG, number, len(notes)])
    for i, pair in enumerate(notes):
        if len(pair) != 2:
            raise ValueError(f"note {i} must be a (note, duration) pair, got {pair!r}")
        out += bytes([_byte(f"note {i} number", pair[0]), _byte(f"note {i} duration", pair[1])])
    return bytes(out)


def play(number: int, *, model: Model) -> bytes:
    """Play (141) song ``number`` (0–4 Create 2, 0–15 Create 1; ValueError otherwise)."""
    return bytes([Opcode.PLAY, _byte("song number", number, 0, _SONG_NUMBERS[model])])


# --- Input commands ---------------------------------------------------------------------------

def _packet_id(model: Model, packet_id: int) -> int:
    if isinstance(packet_id, bool) or not isinstance(packet_id, int) or not is_packet_id(
        model, packet_id
    ):
        raise ValueError(f"packet id {packet_id!r} does not exist on the {model.value}")
    return packet_id


def sensors(packet_id: int, *, model: Model) -> bytes:
    """Sensors (142): one reply of the packet's data bytes (no header, no checksum)."""
    return bytes([Opcode.SENSORS, _packet_id(model, packet_id)])


def query_list(packet_ids: Iterable[int], *, model: Model) -> bytes:
    """Query List (149): ``[149][n][id]…``; one reply, the packets' data in the order asked."""
    ids = [_packet_id(model, p) for p in packet_ids]
    if not 1 <= len(ids) <= 255:
        raise ValueError(f"query list needs 1-255 packet ids, got {len(ids)}")
    return bytes([Opcode.QUERY_LIST, len(ids), *ids])


def stream(packet_ids: Iterable[int], *, model: Model) -> bytes:
    """Stream (148): ``[148][n][id]…``; a frame of those packets every 15 ms.

    Checks only that the ids exist; keeping the frame within the baud rate's budget (86 bytes per
    15 ms at 57600, 172 at 115200) is the caller's job — see :func:`stream_ids_size`.
    """
    ids = [_packet_id(model, p) for p in packet_ids]
    if len(ids) > 255:
        raise ValueError(f"a stream has at most 255 packet ids, got {len(ids)}")
    return bytes([Opcode.STREAM, len(ids), *ids])


def pause_resume_stream(resume: bool) -> bytes:
    """Pause/Resume Stream (150): ``[150][0]`` pauses, ``[150][1]`` resumes the last list."""
    return bytes([Opcode.PAUSE_RESUME_STREAM, 1 if resume else 0])


def pause_stream() -> bytes:
    return pause_resume_stream(False)


def resume_stream() -> bytes:
    return pause_resume_stream(True)


# --- Command framing (what a robot needs to know to read a command) --------------------------

_FIXED_COMMON: dict[int, int] = {
    Opcode.START: 0, Opcode.BAUD: 1, Opcode.CONTROL: 0, Opcode.SAFE: 0, Opcode.FULL: 0,
    Opcode.SPOT: 0, Opcode.CLEAN: 0, Opcode.DRIVE: 4, Opcode.MOTORS: 1, Opcode.LEDS: 3,
    Opcode.PLAY: 1, Opcode.SENSORS: 1, Opcode.SEEK_DOCK: 0, Opcode.PWM_MOTORS: 3,
    Opcode.DRIVE_DIRECT: 4, Opcode.PAUSE_RESUME_STREAM: 1,
}
_FIXED: dict[Model, dict[int, int]] = {
    Model.CREATE1: {
        **_FIXED_COMMON, Opcode.MAX: 1, Opcode.DIGITAL_OUTPUTS: 1, Opcode.SEND_IR: 1,
        Opcode.PLAY_SCRIPT: 0, Opcode.SHOW_SCRIPT: 0, Opcode.WAIT_TIME: 1,
        Opcode.WAIT_DISTANCE: 2, Opcode.WAIT_ANGLE: 2, Opcode.WAIT_EVENT: 1,
    },
    Model.CREATE2: {
        **_FIXED_COMMON, Opcode.RESET: 0, Opcode.POWER: 0, Opcode.MAX: 0, Opcode.DRIVE_PWM: 4,
        Opcode.SCHEDULING_LEDS: 2, Opcode.DIGIT_LEDS_RAW: 4, Opcode.DIGIT_LEDS_ASCII: 4,
        Opcode.BUTTONS: 1, Opcode.SCHEDULE: 15, Opcode.SET_DAY_TIME: 3, Opcode.STOP: 0,
    },
}
_COUNTED = {Opcode.STREAM, Opcode.QUERY_LIST}  # [op][n][n ids]


def command_length(model: Model, buffer: bytes | bytearray) -> int | None:
    """Total length in bytes of the command at the start of ``buffer``.

    ``None`` when more bytes are needed to know it (Song, Stream, Query List, Script carry their
    length in a data byte). Raises ValueError if ``buffer[0]`` is not an opcode of ``model``.
    """
    if not buffer:
        return None
    op = buffer[0]
    fixed = _FIXED[model].get(op)
    if fixed is not None:
        return 1 + fixed
    if op in _COUNTED:
        return 2 + buffer[1] if len(buffer) >= 2 else None
    if op == Opcode.SONG:
        return 3 + 2 * buffer[2] if len(buffer) >= 3 else None
    if op == Opcode.SCRIPT and model is Model.CREATE1:
        return 2 + buffer[1] if len(buffer) >= 2 else None
    raise ValueError(f"byte {op} is not an opcode of the {model.value}")


# --- Stream frames ----------------------------------------------------------------------------

def checksum(data: bytes | bytearray) -> int:
    """The byte that makes ``sum(data) + checksum`` ≡ 0 (mod 256)."""
    return -sum(data) & 0xFF


def stream_frame(payload: bytes) -> bytes:
    """A whole stream frame ``[19][n][payload…][checksum]`` (checksum covers the header)."""
    if len(payload) > 255:
        raise ValueError(f"a stream payload has at most 255 bytes, got {len(payload)}")
    head = bytes([STREAM_HEADER, len(payload)]) + payload
    return head + bytes([checksum(head)])


@dataclass(frozen=True)
class StreamFrame:
    """One good stream frame: decoded single packets (id → value), the raw payload, and
    ``offset``, the position of its header byte in everything the parser was fed."""

    values: Mapping[int, Any]
    payload: bytes
    offset: int


@dataclass
class StreamParser:
    """Incremental parser for Stream (148) frames: feed bytes as they arrive, in any chunks.

    A frame is accepted only if its checksum holds (sum including header ≡ 0 mod 256) *and* its
    payload splits into known ``[id][data]`` packets of the right sizes; otherwise it counts as
    bad and the parser resynchronises at the next 19 after the rejected header, so a 19 inside a
    payload or garbage before a frame costs at most the frames it overlaps.

    With ``expected_ids`` (the list the driver asked for) a header whose length byte differs from
    that list's payload size is skipped at once, without waiting for the bytes it announces.

    Counters: ``good_frames``, ``bad_frames`` (complete candidates with a wrong checksum or
    payload), ``skipped_bytes`` (bytes not part of a good frame).
    """

    model: Model
    expected_ids: Sequence[int] | None = None
    good_frames: int = 0
    bad_frames: int = 0
    skipped_bytes: int = 0
    _buf: bytearray = field(default_factory=bytearray, repr=False)
    _offset: int = field(default=0, repr=False)  # stream position of _buf[0]
    _expected_n: int | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        self.set_expected_ids(self.expected_ids)

    def set_expected_ids(self, ids: Sequence[int] | None) -> None:
        """Expect frames of exactly these packets (None: any well-formed frame)."""
        self.expected_ids = None if ids is None else tuple(ids)
        self._expected_n = None if ids is None else stream_ids_size(self.model, ids)

    @property
    def pending(self) -> int:
        """Bytes held while waiting for the rest of a candidate frame."""
        return len(self._buf)

    def _drop(self, n: int) -> None:
        del self._buf[:n]
        self._offset += n

    def feed(self, data: bytes | bytearray) -> list[StreamFrame]:
        """Consume ``data``; return the good frames completed by it, in order. Never raises on
        malformed input."""
        buf = self._buf
        buf += data
        frames: list[StreamFrame] = []
        while buf:
            start = buf.find(STREAM_HEADER)
            if start < 0:
                self.skipped_bytes += len(buf)
                self._drop(len(buf))
                break
            if start:
                self.skipped_bytes += start
                self._drop(start)
            if len(buf) < 2:
                break
            n = buf[1]
            if self._expected_n is not None and n != self._expected_n:
                self.skipped_bytes += 1
                self._drop(1)
                continue
            if len(buf) < n + 3:
                break
            frame = bytes(buf[:n + 3])
            values: dict[int, Any] | None = None
            if sum(frame) & 0xFF == 0:
                try:
                    values = decode_id_data_pairs(self.model, frame[2:-1])
                except ValueError:
                    values = None
            if values is None:
                self.bad_frames += 1
                self.skipped_bytes += 1
                self._drop(1)
                continue
            self.good_frames += 1
            frames.append(StreamFrame(values, frame[2:-1], self._offset))
            self._drop(n + 3)
        return frames
