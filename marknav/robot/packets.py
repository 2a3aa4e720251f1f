"""Create Open Interface sensor packets as data: one table per robot model.

Implements the "Sensor Packets" sections and the "Sensors Quick Reference" / "Group Packet Sizes
and Contents" tables of the iRobot Create OI specification (Create 1, packets 0–42) and of the
iRobot Create 2 OI specification (Roomba 600 based, packets 0–58 and groups 100, 101, 106, 107).

Each single packet is a :class:`PacketSpec` ``(id, name, size, signed, decode)``: ``size`` data
bytes, big-endian (high byte first), two's complement when ``signed``; ``decode`` turns the raw
integer into its value (a ``bool``, an ``int``, an :class:`~enum.IntEnum` or a frozen dataclass for
bit fields). Group packets are the concatenation of their members in id order.

The models differ where the specifications differ:

- packet 7 bit 4 is the caster wheel drop on Create 1 only;
- packet 14: bits 3/4 are the right/left wheel on both, but bits 0–2 are low-side drivers 1, 0, 2
  on Create 1 and side brush, (vacuum), main brush on Create 2;
- packets 15–16 are two unused bytes on Create 1; on Create 2 15 is dirt detect;
- packet 17 means "no IR byte" with 255 on Create 1 and 0 on Create 2;
- packet 18: Play (bit 0) / Advance (bit 2) on Create 1, eight buttons on Create 2;
- packets 32–33 are the cargo bay inputs on Create 1 and unused (3 bytes) on Create 2;
- packets 43–58 and groups 100, 101, 106, 107 exist on Create 2 only.

:class:`SensorState` merges the latest value of every packet received into one frozen record.
"""

from __future__ import annotations

import dataclasses
import functools
import operator
import struct
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from enum import Enum, IntEnum
from types import MappingProxyType
from typing import Any

__all__ = [
    "BumpsAndWheelDrops",
    "Buttons",
    "CargoBayInputs",
    "ChargingSources",
    "ChargingState",
    "LightBumper",
    "Model",
    "OIMode",
    "Overcurrents",
    "PacketSpec",
    "SensorState",
    "decode_id_data_pairs",
    "decode_packet",
    "encode_packet",
    "group_table",
    "is_packet_id",
    "member_ids",
    "packet_layout",
    "packet_size",
    "packet_table",
    "state_updates",
    "stream_ids_size",
]


class Model(str, Enum):
    """The robot model: the OI differs between the Create 1 and the Create 2."""

    CREATE1 = "create1"
    CREATE2 = "create2"

    @property
    def default_baudrate(self) -> int:
        """The OI's power-on baud rate: 57600 (Create 1) or 115200 (Create 2)."""
        return 57600 if self is Model.CREATE1 else 115200

    @property
    def wheel_base_mm(self) -> float:
        """Distance between the wheels: 258 mm (Create 1), 235 mm (Create 2)."""
        return 258.0 if self is Model.CREATE1 else 235.0

    @classmethod
    def parse(cls, value: Model | str) -> Model:
        """The model from a model or its name (``"create1"``/``"create2"``); else ValueError."""
        if isinstance(value, Model):
            return value
        try:
            return cls(str(value).lower())
        except ValueError:
            raise ValueError(
                f"unknown robot model {value!r} (expected 'create1' or 'create2')"
            ) from None


class OIMode(IntEnum):
    """OI mode (packet 35)."""

    OFF = 0
    PASSIVE = 1
    SAFE = 2
    FULL = 3


class ChargingState(IntEnum):
    """Charging state (packet 21)."""

    NOT_CHARGING = 0
    RECONDITIONING = 1
    FULL_CHARGING = 2
    TRICKLE = 3
    WAITING = 4
    FAULT = 5


#: A bit-field packet's layout: (attribute name, bit number) for every bit the packet defines.
_BitTable = tuple[tuple[str, int], ...]


def _bits_from_raw(raw: int, table: _BitTable) -> dict[str, bool]:
    """``raw``'s bits named by ``table`` (bits the table leaves out are ignored)."""
    return {name: bool(raw >> bit & 1) for name, bit in table}


def _bits_to_raw(value: object, table: _BitTable) -> int:
    """The raw integer with ``table``'s bits set from ``value``'s attributes of those names."""
    raw = 0
    for name, bit in table:
        raw |= bool(getattr(value, name)) << bit
    return raw


#: Packet 7 (bumps and wheel drops); the caster wheel drop (bit 4) exists on Create 1 only.
_BUMPS_CREATE2: _BitTable = (("bump_right", 0), ("bump_left", 1), ("wheel_drop_right", 2),
                            ("wheel_drop_left", 3))
_BUMPS_BITS: Mapping[Model, _BitTable] = MappingProxyType({
    Model.CREATE1: (*_BUMPS_CREATE2, ("caster_drop", 4)),
    Model.CREATE2: _BUMPS_CREATE2,
})

#: Packet 14 (overcurrents): the wheels are bits 3/4 on both models, bits 0-2 differ.
_WHEEL_OVERCURRENTS: _BitTable = (("right_wheel", 3), ("left_wheel", 4))
_OVERCURRENT_BITS: Mapping[Model, _BitTable] = MappingProxyType({
    Model.CREATE1: (("low_side_driver_1", 0), ("low_side_driver_0", 1), ("low_side_driver_2", 2),
                    *_WHEEL_OVERCURRENTS),
    Model.CREATE2: (("side_brush", 0), ("main_brush", 2), *_WHEEL_OVERCURRENTS),
})

#: Packet 18 (buttons).
_BUTTON_BITS: Mapping[Model, _BitTable] = MappingProxyType({
    Model.CREATE1: (("play", 0), ("advance", 2)),
    Model.CREATE2: (("clean", 0), ("spot", 1), ("dock", 2), ("minute", 3), ("hour", 4),
                    ("day", 5), ("schedule", 6), ("clock", 7)),
})

#: Packet 34 (charging sources available), the same on both models.
_CHARGING_SOURCE_BITS: _BitTable = (("internal_charger", 0), ("home_base", 1))

#: Packet 32 (cargo bay digital inputs, Create 1).
_CARGO_BAY_BITS: _BitTable = (("digital_0", 0), ("digital_1", 1), ("digital_2", 2),
                            ("digital_3", 3), ("baud_rate_change", 4))

#: Packet 45 (light bumper, Create 2).
_LIGHT_BUMPER_BITS: _BitTable = (("left", 0), ("front_left", 1), ("center_left", 2),
                               ("center_right", 3), ("front_right", 4), ("right", 5))


@dataclass(frozen=True)
class BumpsAndWheelDrops:
    """Packet 7 (bits: ``_BUMPS_BITS``): bump right/left, wheel drop right/left, and the caster
    drop on Create 1 (always False when decoded for a Create 2)."""

    bump_right: bool = False
    bump_left: bool = False
    wheel_drop_right: bool = False
    wheel_drop_left: bool = False
    caster_drop: bool = False

    @classmethod
    def from_raw(cls, raw: int, model: Model) -> BumpsAndWheelDrops:
        return cls(**_bits_from_raw(raw, _BUMPS_BITS[model]))

    def to_raw(self) -> int:
        """The raw byte, every field written (a Create 2's caster_drop is False, see from_raw)."""
        return _bits_to_raw(self, _BUMPS_BITS[Model.CREATE1])


@dataclass(frozen=True)
class Overcurrents:
    """Packet 14 (bits: ``_OVERCURRENT_BITS``). Both models: the right and left wheel. Create 1:
    low-side drivers 1, 0, 2. Create 2: side brush, (vacuum, reserved, not decoded), main brush."""

    left_wheel: bool = False
    right_wheel: bool = False
    main_brush: bool = False
    side_brush: bool = False
    low_side_driver_0: bool = False
    low_side_driver_1: bool = False
    low_side_driver_2: bool = False

    @classmethod
    def from_raw(cls, raw: int, model: Model) -> Overcurrents:
        return cls(**_bits_from_raw(raw, _OVERCURRENT_BITS[model]))

    def to_raw(self, model: Model) -> int:
        return _bits_to_raw(self, _OVERCURRENT_BITS[model])


@dataclass(frozen=True)
class Buttons:
    """Packet 18 (bits: ``_BUTTON_BITS``). Create 1: Play, Advance. Create 2: Clean, Spot,
    Dock, Minute, Hour, Day, Schedule, Clock. Buttons a model lacks are False."""

    play: bool = False
    advance: bool = False
    clean: bool = False
    spot: bool = False
    dock: bool = False
    minute: bool = False
    hour: bool = False
    day: bool = False
    schedule: bool = False
    clock: bool = False

    @classmethod
    def from_raw(cls, raw: int, model: Model) -> Buttons:
        return cls(**_bits_from_raw(raw, _BUTTON_BITS[model]))


@dataclass(frozen=True)
class ChargingSources:
    """Packet 34 (bits: ``_CHARGING_SOURCE_BITS``): internal charger, home base."""

    internal_charger: bool = False
    home_base: bool = False

    @classmethod
    def from_raw(cls, raw: int) -> ChargingSources:
        return cls(**_bits_from_raw(raw, _CHARGING_SOURCE_BITS))


@dataclass(frozen=True)
class CargoBayInputs:
    """Packet 32 (Create 1; bits: ``_CARGO_BAY_BITS``): digital inputs 0–3 and the active-low
    baud-rate-change / device-detect pin (True = high, the default)."""

    digital_0: bool = False
    digital_1: bool = False
    digital_2: bool = False
    digital_3: bool = False
    baud_rate_change: bool = True

    @classmethod
    def from_raw(cls, raw: int) -> CargoBayInputs:
        return cls(**_bits_from_raw(raw, _CARGO_BAY_BITS))


@dataclass(frozen=True)
class LightBumper:
    """Packet 45 (Create 2; bits: ``_LIGHT_BUMPER_BITS``): left, front left, centre left,
    centre right, front right, right."""

    left: bool = False
    front_left: bool = False
    center_left: bool = False
    center_right: bool = False
    front_right: bool = False
    right: bool = False

    @classmethod
    def from_raw(cls, raw: int) -> LightBumper:
        return cls(**_bits_from_raw(raw, _LIGHT_BUMPER_BITS))

    def to_raw(self) -> int:
        return _bits_to_raw(self, _LIGHT_BUMPER_BITS)


@dataclass(frozen=True)
class PacketSpec:
    """One single sensor packet: id, name, data size in bytes, signedness and decoder.

    ``fields`` maps the decoded value to :class:`SensorState` attributes (empty for unused bytes).
    """

    id: int
    name: str
    size: int
    signed: bool
    decode: Callable[[int], Any] = int
    fields: Callable[[Any], dict[str, Any]] = field(default=lambda _v: {})


class _To:
    """The ``fields`` of a packet that sets one :class:`SensorState` attribute (its name is
    visible, so :func:`state_updates` sets it without building a dict)."""

    __slots__ = ("name",)

    def __init__(self, name: str) -> None:
        self.name = name

    def __call__(self, value: Any) -> dict[str, Any]:
        return {self.name: value}


def _to(name: str) -> Callable[[Any], dict[str, Any]]:
    return _To(name)


def _bool(raw: int) -> bool:
    return bool(raw & 1)


def _build_table(model: Model) -> dict[int, PacketSpec]:
    c1 = model is Model.CREATE1
    no_ir = 255 if c1 else 0

    def ir(raw: int) -> int | None:
        return None if raw == no_ir else raw

    def bumps(v: BumpsAndWheelDrops) -> dict[str, Any]:
        # the five bools by the packet's own names (the SensorState's too); not asdict's
        # recursive copy, for every stream frame
        return {name: getattr(v, name) for name, _bit in _BUMPS_BITS[Model.CREATE1]}

    def overcurrents(v: Overcurrents) -> dict[str, Any]:
        return {"overcurrents": v, "overcurrent_left_wheel": v.left_wheel,
                "overcurrent_right_wheel": v.right_wheel}

    specs = [
        PacketSpec(7, "bumps and wheel drops", 1, False,
                   lambda r: BumpsAndWheelDrops.from_raw(r, model), bumps),
        PacketSpec(8, "wall", 1, False, _bool, _to("wall")),
        PacketSpec(9, "cliff left", 1, False, _bool, _to("cliff_left")),
        PacketSpec(10, "cliff front left", 1, False, _bool, _to("cliff_front_left")),
        PacketSpec(11, "cliff front right", 1, False, _bool, _to("cliff_front_right")),
        PacketSpec(12, "cliff right", 1, False, _bool, _to("cliff_right")),
        PacketSpec(13, "virtual wall", 1, False, _bool, _to("virtual_wall")),
        PacketSpec(14, "overcurrents", 1, False,
                   lambda r: Overcurrents.from_raw(r, model), overcurrents),
        (PacketSpec(15, "unused", 1, False) if c1
         else PacketSpec(15, "dirt detect", 1, False, int, _to("dirt_detect"))),
        PacketSpec(16, "unused", 1, False),
        PacketSpec(17, "infrared character omni", 1, False, ir, _to("ir_omni")),
        PacketSpec(18, "buttons", 1, False, lambda r: Buttons.from_raw(r, model), _to("buttons")),
        PacketSpec(19, "distance", 2, True, int, _to("distance_mm")),
        PacketSpec(20, "angle", 2, True, int, _to("angle_deg")),
        PacketSpec(21, "charging state", 1, False, _charging_state, _to("charging_state")),
        PacketSpec(22, "voltage", 2, False, int, _to("voltage_mv")),
        PacketSpec(23, "current", 2, True, int, _to("current_ma")),
        PacketSpec(24, "battery temperature", 1, True, int, _to("battery_temp_c")),
        PacketSpec(25, "battery charge", 2, False, int, _to("charge_mah")),
        PacketSpec(26, "battery capacity", 2, False, int, _to("capacity_mah")),
        PacketSpec(27, "wall signal", 2, False, int, _to("wall_signal")),
        PacketSpec(28, "cliff left signal", 2, False, int, _to("cliff_left_signal")),
        PacketSpec(29, "cliff front left signal", 2, False, int, _to("cliff_front_left_signal")),
        PacketSpec(30, "cliff front right signal", 2, False, int,
                   _to("cliff_front_right_signal")),
        PacketSpec(31, "cliff right signal", 2, False, int, _to("cliff_right_signal")),
        (PacketSpec(32, "cargo bay digital inputs", 1, False, CargoBayInputs.from_raw,
                    _to("cargo_bay_inputs")) if c1 else PacketSpec(32, "unused", 1, False)),
        (PacketSpec(33, "cargo bay analog signal", 2, False, int, _to("cargo_bay_analog"))
         if c1 else PacketSpec(33, "unused", 2, False)),
        PacketSpec(34, "charging sources available", 1, False, ChargingSources.from_raw,
                   _to("charging_sources")),
        PacketSpec(35, "OI mode", 1, False, _oi_mode, _to("oi_mode")),
        PacketSpec(36, "song number", 1, False, int, _to("song_number")),
        PacketSpec(37, "song playing", 1, False, _bool, _to("song_playing")),
        PacketSpec(38, "number of stream packets", 1, False, int, _to("stream_packet_count")),
        PacketSpec(39, "requested velocity", 2, True, int, _to("requested_velocity")),
        PacketSpec(40, "requested radius", 2, True, int, _to("requested_radius")),
        PacketSpec(41, "requested right velocity", 2, True, int, _to("requested_right_velocity")),
        PacketSpec(42, "requested left velocity", 2, True, int, _to("requested_left_velocity")),
    ]
    if not c1:
        specs += [
            PacketSpec(43, "left encoder counts", 2, True, int, _to("encoder_left")),
            PacketSpec(44, "right encoder counts", 2, True, int, _to("encoder_right")),
            PacketSpec(45, "light bumper", 1, False, int, _to("light_bumper")),
            PacketSpec(46, "light bump left signal", 2, False, int,
                       _to("light_bump_left_signal")),
            PacketSpec(47, "light bump front left signal", 2, False, int,
                       _to("light_bump_front_left_signal")),
            PacketSpec(48, "light bump center left signal", 2, False, int,
                       _to("light_bump_center_left_signal")),
            PacketSpec(49, "light bump center right signal", 2, False, int,
                       _to("light_bump_center_right_signal")),
            PacketSpec(50, "light bump front right signal", 2, False, int,
                       _to("light_bump_front_right_signal")),
            PacketSpec(51, "light bump right signal", 2, False, int,
                       _to("light_bump_right_signal")),
            PacketSpec(52, "infrared character left", 1, False, ir, _to("ir_left")),
            PacketSpec(53, "infrared character right", 1, False, ir, _to("ir_right")),
            PacketSpec(54, "left motor current", 2, True, int, _to("left_motor_current_ma")),
            PacketSpec(55, "right motor current", 2, True, int, _to("right_motor_current_ma")),
            PacketSpec(56, "main brush motor current", 2, True, int,
                       _to("main_brush_current_ma")),
            PacketSpec(57, "side brush motor current", 2, True, int,
                       _to("side_brush_current_ma")),
            PacketSpec(58, "stasis", 1, False, int, _to("stasis")),
        ]
    return {s.id: s for s in specs}


def _oi_mode(raw: int) -> OIMode:
    try:
        return OIMode(raw)
    except ValueError:
        raise ValueError(f"OI mode {raw} out of range 0-3") from None


def _charging_state(raw: int) -> ChargingState | int:
    try:
        return ChargingState(raw)
    except ValueError:
        return raw


def _range(a: int, b: int) -> tuple[int, ...]:
    return tuple(range(a, b + 1))


_GROUPS_COMMON: dict[int, tuple[int, ...]] = {
    0: _range(7, 26),
    1: _range(7, 16),
    2: _range(17, 20),
    3: _range(21, 26),
    4: _range(27, 34),
    5: _range(35, 42),
    6: _range(7, 42),
}
_GROUPS_CREATE2: dict[int, tuple[int, ...]] = {
    **_GROUPS_COMMON,
    100: _range(7, 58),
    101: _range(43, 58),
    106: _range(46, 51),
    107: _range(54, 58),
}

_TABLES = {m: MappingProxyType(_build_table(m)) for m in Model}
_GROUPS = {Model.CREATE1: MappingProxyType(_GROUPS_COMMON),
           Model.CREATE2: MappingProxyType(_GROUPS_CREATE2)}


def packet_table(model: Model) -> Mapping[int, PacketSpec]:
    """The single (non-group) packets of ``model`` by id."""
    return _TABLES[model]


def group_table(model: Model) -> Mapping[int, tuple[int, ...]]:
    """The group packets of ``model``: group id → member packet ids, in the order sent."""
    return _GROUPS[model]


def is_packet_id(model: Model, packet_id: int) -> bool:
    """True if ``packet_id`` is a single or group packet of ``model``."""
    return packet_id in _TABLES[model] or packet_id in _GROUPS[model]


def member_ids(model: Model, packet_id: int) -> tuple[int, ...]:
    """The single packets a request for ``packet_id`` returns (itself, or a group's members)."""
    if packet_id in _GROUPS[model]:
        return _GROUPS[model][packet_id]
    if packet_id in _TABLES[model]:
        return (packet_id,)
    raise ValueError(f"packet id {packet_id} does not exist on the {model.value}")


def packet_size(model: Model, packet_id: int) -> int:
    """Number of data bytes the robot sends for ``packet_id`` (a group's is the sum)."""
    table = _TABLES[model]
    return sum(table[i].size for i in member_ids(model, packet_id))


@functools.cache
def packet_layout(model: Model, packet_id: int) -> tuple[struct.Struct, tuple[PacketSpec, ...],
                                                        tuple[tuple[int, int], ...]]:
    """How the data bytes of ``packet_id`` are laid out: a big-endian :class:`struct.Struct`
    (every single packet is 1 or 2 bytes), its member specs and their raw ranges. Computed
    once per (model, id): stream frames are decoded and encoded 67 times a second."""
    table = _TABLES[model]
    specs = tuple(table[i] for i in member_ids(model, packet_id))
    fmt = ">" + "".join({(1, False): "B", (1, True): "b", (2, False): "H", (2, True): "h"}
                        [(sp.size, sp.signed)] for sp in specs)
    ranges = tuple((-(1 << (8 * sp.size - 1)), (1 << (8 * sp.size - 1)) - 1) if sp.signed
                   else (0, (1 << (8 * sp.size)) - 1) for sp in specs)
    return struct.Struct(fmt), specs, ranges


def decode_packet(model: Model, packet_id: int, data: bytes) -> dict[int, Any]:
    """Decode the data bytes of one (single or group) packet: single id → decoded value.

    Raises ``ValueError`` for an id the model lacks or a wrong number of bytes.
    """
    layout, specs, _ranges = packet_layout(model, packet_id)
    if len(data) != layout.size:
        raise ValueError(f"packet {packet_id} has {layout.size} data bytes on the "
                         f"{model.value}, got {len(data)}")
    return {spec.id: spec.decode(raw) for spec, raw in zip(specs, layout.unpack(data),
                                                           strict=True)}


def decode_id_data_pairs(model: Model, payload: bytes) -> dict[int, Any]:
    """Decode a stream frame's payload, ``[id][data…][id][data…]…``: single id → value.

    Raises ``ValueError`` on an unknown id or when the bytes do not split into whole packets.
    A payload laid out like the previous one of its length and first id (a stream sends the
    same ids every 15 ms) is decoded with one ``unpack`` of that layout, after checking that
    every packet id is where the layout has it — the same result as walking the packets.
    """
    n = len(payload)
    plan = _FRAME_PLANS.get((model, n, payload[0])) if n else None
    if plan is not None:
        values = plan.layout.unpack(payload)
        if plan.ids_at(values) == plan.ids:
            out = dict(zip(plan.members, plan.member_values(values), strict=True))
            for index, pid, decode in plan.decoders:
                out[pid] = decode(values[index])
            return out
    out = {}
    ids: list[int] = []
    pos = 0
    while pos < n:
        pid = payload[pos]
        if not is_packet_id(model, pid):
            raise ValueError(f"unknown packet id {pid} at payload offset {pos}")
        layout, specs, _ranges = packet_layout(model, pid)
        size = layout.size
        if pos + 1 + size > n:
            raise ValueError(f"packet {pid} needs {size} data bytes, payload has "
                             f"{n - pos - 1} left")
        for spec, raw in zip(specs, layout.unpack_from(payload, pos + 1), strict=True):
            out[spec.id] = spec.decode(raw)
        ids.append(pid)
        pos += 1 + size
    if ids:
        if len(_FRAME_PLANS) >= 256:  # garbage decoded by chance must not grow it for ever
            _FRAME_PLANS.clear()
        _FRAME_PLANS[(model, n, ids[0])] = _frame_plan(model, tuple(ids))
    return out


@dataclass(frozen=True)
class _FramePlan:
    """A payload's layout for :func:`decode_id_data_pairs`: one struct over ``[id][data…]…``,
    where the ids are (``ids_at``) and what they must be, the member single ids with their
    raw values (``member_values``), and the members whose decoder is not ``int``."""

    layout: struct.Struct
    ids: tuple[int, ...]
    ids_at: Callable[[tuple[Any, ...]], tuple[int, ...]]
    members: tuple[int, ...]
    member_values: Callable[[tuple[Any, ...]], tuple[int, ...]]
    decoders: tuple[tuple[int, int, Callable[[int], Any]], ...]


def _getter(slots: list[int]) -> Callable[[tuple[Any, ...]], tuple[Any, ...]]:
    if len(slots) == 1:
        (only,) = slots
        return lambda values: (values[only],)
    return operator.itemgetter(*slots)


@functools.lru_cache(maxsize=256)
def _frame_plan(model: Model, ids: tuple[int, ...]) -> _FramePlan:
    fmt = [">"]
    id_slots: list[int] = []
    members: list[int] = []
    member_slots: list[int] = []
    decoders: list[tuple[int, int, Callable[[int], Any]]] = []
    slot = 0
    for pid in ids:
        layout, specs, _ranges = packet_layout(model, pid)
        fmt.append("B" + layout.format.lstrip(">"))
        id_slots.append(slot)
        slot += 1
        for spec in specs:
            members.append(spec.id)
            member_slots.append(slot)
            if spec.decode is not int:  # int() of an int is that int: nothing to do
                decoders.append((slot, spec.id, spec.decode))
            slot += 1
    return _FramePlan(struct.Struct("".join(fmt)), ids, _getter(id_slots), tuple(members),
                      _getter(member_slots), tuple(decoders))


#: (model, payload length, first id) → the layout of the last such payload decoded.
_FRAME_PLANS: dict[tuple[Model, int, int], _FramePlan] = {}


def encode_packet(model: Model, packet_id: int, raw_values: Mapping[int, int]) -> bytes:
    """The data bytes the robot sends for ``packet_id``, from raw integers per single id.

    Missing single ids are sent as 0. Values are saturated to each packet's range, as the robot
    caps its distance/angle accumulators.
    """
    layout, specs, ranges = packet_layout(model, packet_id)
    return layout.pack(*[max(lo, min(hi, int(raw_values.get(spec.id, 0))))
                         for spec, (lo, hi) in zip(specs, ranges, strict=True)])


def state_updates(model: Model, decoded: Mapping[int, Any]) -> dict[str, Any]:
    """The :class:`SensorState` attributes set by decoded single packets."""
    table = _TABLES[model]
    out: dict[str, Any] = {}
    for pid, value in decoded.items():
        fields = table[pid].fields
        if type(fields) is _To:
            out[fields.name] = value
        else:
            out.update(fields(value))
    return out


@dataclass(frozen=True)
class SensorState:
    """The latest value of every sensor packet received (defaults until one arrives).

    ``distance_mm`` and ``angle_deg`` are what the robot reported in the latest packet 19/20: the
    motion since its previous report, not a total. ``received`` holds every single packet id seen.
    """

    model: Model = Model.CREATE2
    bump_left: bool = False
    bump_right: bool = False
    wheel_drop_left: bool = False
    wheel_drop_right: bool = False
    caster_drop: bool = False
    wall: bool = False
    cliff_left: bool = False
    cliff_front_left: bool = False
    cliff_front_right: bool = False
    cliff_right: bool = False
    virtual_wall: bool = False
    overcurrent_left_wheel: bool = False
    overcurrent_right_wheel: bool = False
    overcurrents: Overcurrents = Overcurrents()
    dirt_detect: int = 0
    ir_omni: int | None = None
    ir_left: int | None = None
    ir_right: int | None = None
    buttons: Buttons = Buttons()
    distance_mm: int = 0
    angle_deg: int = 0
    charging_state: ChargingState | int = ChargingState.NOT_CHARGING
    voltage_mv: int = 0
    current_ma: int = 0
    battery_temp_c: int = 0
    charge_mah: int = 0
    capacity_mah: int = 0
    wall_signal: int = 0
    cliff_left_signal: int = 0
    cliff_front_left_signal: int = 0
    cliff_front_right_signal: int = 0
    cliff_right_signal: int = 0
    cargo_bay_inputs: CargoBayInputs = CargoBayInputs()
    cargo_bay_analog: int = 0
    charging_sources: ChargingSources = ChargingSources()
    oi_mode: OIMode = OIMode.OFF
    song_number: int = 0
    song_playing: bool = False
    stream_packet_count: int = 0
    requested_velocity: int = 0
    requested_radius: int = 0
    requested_right_velocity: int = 0
    requested_left_velocity: int = 0
    encoder_left: int = 0
    encoder_right: int = 0
    light_bumper: int = 0
    light_bump_left_signal: int = 0
    light_bump_front_left_signal: int = 0
    light_bump_center_left_signal: int = 0
    light_bump_center_right_signal: int = 0
    light_bump_front_right_signal: int = 0
    light_bump_right_signal: int = 0
    left_motor_current_ma: int = 0
    right_motor_current_ma: int = 0
    main_brush_current_ma: int = 0
    side_brush_current_ma: int = 0
    stasis: int = 0
    received: frozenset[int] = frozenset()

    def with_packets(self, decoded: Mapping[int, Any]) -> SensorState:
        """A new state with the decoded single packets (id → value) merged in."""
        if not decoded:
            return self
        updates = state_updates(self.model, decoded)
        unknown = updates.keys() - _SENSOR_FIELDS
        if unknown:
            raise TypeError(f"SensorState has no field {sorted(unknown)[0]!r}")
        # dataclasses.replace without re-running the frozen __init__ over ~60 fields (three
        # frames per control cycle): the same fields, copied, then updated.
        new = object.__new__(SensorState)
        state = new.__dict__
        state.update(self.__dict__)
        state.update(updates)
        state["received"] = self.received | frozenset(decoded)
        return new

    @classmethod
    def initial(cls, model: Model) -> SensorState:
        """The state before any packet arrived."""
        return cls(model=model)


#: SensorState's field names (what :meth:`SensorState.with_packets` may set).
_SENSOR_FIELDS = frozenset(f.name for f in dataclasses.fields(SensorState))


def stream_ids_size(model: Model, ids: Iterable[int]) -> int:
    """Payload length (the frame's n-bytes) of a stream of ``ids``: Σ (1 + data size)."""
    return sum(1 + packet_size(model, i) for i in ids)
