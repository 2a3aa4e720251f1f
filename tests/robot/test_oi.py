"""OI wire format: command bytes (the specs' own examples), ranges, and the sensor packet tables."""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest

from marknav.robot import oi
from marknav.robot.oi import Model, OIMode, Opcode
from marknav.robot.packets import (
    BumpsAndWheelDrops,
    Buttons,
    LightBumper,
    Overcurrents,
    SensorState,
    decode_packet,
    encode_packet,
    group_table,
    packet_size,
    packet_table,
)

C1, C2 = Model.CREATE1, Model.CREATE2


# --- commands: the specifications' byte examples ---------------------------------------------

def test_drive_direct_sends_the_right_wheel_first() -> None:
    assert list(oi.drive_direct(right=200, left=-200)) == [145, 0, 200, 255, 56]
    assert list(oi.drive_direct(left=200, right=-200)) == [145, 255, 56, 0, 200]


def test_drive_spec_example_reverse_on_500_mm_radius() -> None:
    assert list(oi.drive(velocity=-200, radius=500)) == [137, 255, 56, 1, 244]


def test_drive_special_radii() -> None:
    assert list(oi.drive_straight(100)) == [137, 0, 100, 128, 0]
    assert list(oi.drive(velocity=100, radius=oi.RADIUS_STRAIGHT_ALT)) == [137, 0, 100, 127, 255]
    assert list(oi.turn_in_place(150, clockwise=True)) == [137, 0, 150, 255, 255]
    assert list(oi.turn_in_place(-150, clockwise=False)) == [137, 0, 150, 0, 1]


def test_drive_clamps_velocity_and_radius_but_keeps_specials() -> None:
    assert oi.drive(velocity=900, radius=5000) == oi.drive(velocity=500, radius=2000)
    assert oi.drive(velocity=-900, radius=-5000) == oi.drive(velocity=-500, radius=-2000)
    assert list(oi.drive(velocity=0.6, radius=-1)) == [137, 0, 1, 255, 255]


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_speeds_raise(bad: float) -> None:
    with pytest.raises(ValueError, match="finite"):
        oi.drive_direct(left=bad, right=0)
    with pytest.raises(ValueError, match="finite"):
        oi.drive(velocity=bad, radius=100)


def test_radius_zero_raises() -> None:
    with pytest.raises(ValueError, match="radius 0"):
        oi.drive(velocity=100, radius=0)


def test_drive_direct_scales_both_wheels_by_one_factor() -> None:
    # 1000/600 -> 500/300: the ratio (the curve) is kept; clamping alone would give 500/500
    assert oi.drive_direct(left=1000, right=600) == oi.drive_direct(left=500, right=300)
    assert oi.drive_direct(left=-250, right=750) == oi.drive_direct(left=-167, right=500)


def test_drive_pwm_layout_and_scaling() -> None:
    assert list(oi.drive_pwm(left=-255, right=100)) == [146, 0, 100, 255, 1]
    assert oi.drive_pwm(left=510, right=100) == oi.drive_pwm(left=255, right=50)


def test_mode_and_stream_commands() -> None:
    assert oi.start() == oi.passive() == bytes([128])
    assert oi.safe() == bytes([131]) and oi.full() == bytes([132]) and oi.stop() == bytes([173])
    assert oi.set_mode(OIMode.SAFE) == oi.safe() and oi.set_mode(OIMode.PASSIVE) == oi.start()
    with pytest.raises(ValueError, match="OFF"):
        oi.set_mode(OIMode.OFF)
    assert list(oi.pause_stream()) == [150, 0] and list(oi.resume_stream()) == [150, 1]
    # spec examples: stream the left cliff signal and virtual wall; query bumpers + virtual wall
    assert list(oi.stream([29, 13], model=C2)) == [148, 2, 29, 13]
    assert list(oi.query_list([7, 13], model=C2)) == [149, 2, 7, 13]
    assert list(oi.sensors(100, model=C2)) == [142, 100]


def test_baud_codes() -> None:
    assert list(oi.baud(115200)) == [129, 11]
    assert list(oi.baud(57600)) == [129, 10]
    assert list(oi.baud(19200)) == [129, 7]
    with pytest.raises(ValueError, match="unsupported baud rate 12345"):
        oi.baud(12345)


def test_packet_ids_are_checked_per_model() -> None:
    assert list(oi.sensors(43, model=C2)) == [142, 43]
    with pytest.raises(ValueError, match="packet id 43 does not exist on the create1"):
        oi.sensors(43, model=C1)
    with pytest.raises(ValueError, match="packet id 100 does not exist on the create1"):
        oi.query_list([7, 100], model=C1)
    with pytest.raises(ValueError, match="packet id 102"):
        oi.stream([102], model=C2)
    with pytest.raises(ValueError, match="1-255 packet ids"):
        oi.query_list([], model=C2)


def test_leds_spec_examples_and_range() -> None:
    assert list(oi.leds(bits=4, power_color=0, power_intensity=128)) == [139, 4, 0, 128]
    assert list(oi.leds(bits=8, power_color=0, power_intensity=128)) == [139, 8, 0, 128]
    with pytest.raises(ValueError, match=r"power LED intensity must be an integer in 0\.\.255"):
        oi.leds(power_intensity=256)


def test_song_encoding_and_range_errors() -> None:
    assert list(oi.song(0, [(60, 32), (64, 16)], model=C2)) == [140, 0, 2, 60, 32, 64, 16]
    assert list(oi.play(3, model=C2)) == [141, 3]
    assert list(oi.song(15, [(72, 8)], model=C1)) == [140, 15, 1, 72, 8]
    with pytest.raises(ValueError, match=r"song number must be an integer in 0\.\.4"):
        oi.song(5, [(60, 8)], model=C2)
    with pytest.raises(ValueError, match="a song has 1-16 notes, got 0"):
        oi.song(0, [], model=C2)
    with pytest.raises(ValueError, match="a song has 1-16 notes, got 17"):
        oi.song(0, [(60, 8)] * 17, model=C1)
    with pytest.raises(ValueError, match="note 1 duration"):
        oi.song(0, [(60, 8), (60, 300)], model=C1)
    with pytest.raises(ValueError, match=r"0\.\.15"):
        oi.play(16, model=C1)


def test_command_length_frames_fixed_and_counted_commands() -> None:
    assert oi.command_length(C2, oi.drive_direct(left=1, right=2)) == 5
    assert oi.command_length(C2, bytes([148])) is None  # count byte not here yet
    assert oi.command_length(C2, bytes([148, 3])) == 5
    assert oi.command_length(C2, bytes([140, 0])) is None
    assert oi.command_length(C2, bytes([140, 0, 2])) == 7
    assert oi.command_length(C1, bytes([136])) == 2  # Create 1 Demo has a data byte
    assert oi.command_length(C2, bytes([136])) == 1  # Create 2 Max has none
    assert oi.command_length(C1, bytes([152, 4])) == 6  # Create 1 script
    with pytest.raises(ValueError, match="not an opcode of the create1"):
        oi.command_length(C1, bytes([Opcode.STOP]))
    with pytest.raises(ValueError, match="not an opcode of the create2"):
        oi.command_length(C2, bytes([152, 0]))


# --- sensor packets ---------------------------------------------------------------------------

def test_group_sizes_match_the_spec_tables() -> None:
    expected = {0: 26, 1: 10, 2: 6, 3: 10, 4: 14, 5: 12, 6: 52}
    assert {g: packet_size(C1, g) for g in group_table(C1)} == expected
    assert {g: packet_size(C2, g) for g in group_table(C2)} == {
        **expected, 100: 80, 101: 28, 106: 12, 107: 9}


def test_tables_cover_each_models_packets() -> None:
    assert sorted(packet_table(C1)) == list(range(7, 43))
    assert sorted(packet_table(C2)) == list(range(7, 59))
    signed = {pid for pid, spec in packet_table(C2).items() if spec.signed}
    assert signed == {19, 20, 23, 24, 39, 40, 41, 42, 43, 44, 54, 55, 56, 57}


def test_packet_7_bits_and_caster_only_on_create1() -> None:
    assert BumpsAndWheelDrops.from_raw(0b00001, C2) == BumpsAndWheelDrops(bump_right=True)
    assert BumpsAndWheelDrops.from_raw(0b00010, C2) == BumpsAndWheelDrops(bump_left=True)
    assert BumpsAndWheelDrops.from_raw(0b00100, C2) == BumpsAndWheelDrops(wheel_drop_right=True)
    assert BumpsAndWheelDrops.from_raw(0b01000, C2) == BumpsAndWheelDrops(wheel_drop_left=True)
    assert BumpsAndWheelDrops.from_raw(0b10000, C1) == BumpsAndWheelDrops(caster_drop=True)
    assert BumpsAndWheelDrops.from_raw(0b10000, C2) == BumpsAndWheelDrops()
    s = SensorState(model=C1).with_packets(decode_packet(C1, 7, bytes([0b11010])))
    assert (s.bump_left, s.bump_right, s.wheel_drop_left, s.wheel_drop_right, s.caster_drop) == (
        True, False, True, False, True)


def test_packet_14_bits_differ_between_models() -> None:
    # wheels: bit 4 left, bit 3 right on both
    assert Overcurrents.from_raw(0b10000, C1).left_wheel
    assert Overcurrents.from_raw(0b01000, C2).right_wheel
    # Create 1: bit 0 = low-side driver 1, bit 1 = LD0, bit 2 = LD2
    assert Overcurrents.from_raw(0b001, C1) == Overcurrents(low_side_driver_1=True)
    assert Overcurrents.from_raw(0b010, C1) == Overcurrents(low_side_driver_0=True)
    assert Overcurrents.from_raw(0b100, C1) == Overcurrents(low_side_driver_2=True)
    # Create 2: bit 0 = side brush, bit 2 = main brush
    assert Overcurrents.from_raw(0b001, C2) == Overcurrents(side_brush=True)
    assert Overcurrents.from_raw(0b100, C2) == Overcurrents(main_brush=True)
    for raw in range(32):
        for model in (C1, C2):
            value = Overcurrents.from_raw(raw, model)
            assert value.to_raw(model) == raw & (0b11111 if model is C1 else 0b11101)
    s = SensorState().with_packets(decode_packet(C2, 14, bytes([0b11000])))
    assert s.overcurrent_left_wheel and s.overcurrent_right_wheel


def test_packet_17_no_ir_value_differs() -> None:
    assert decode_packet(C1, 17, bytes([255])) == {17: None}
    assert decode_packet(C1, 17, bytes([0])) == {17: 0}
    assert decode_packet(C2, 17, bytes([0])) == {17: None}
    assert decode_packet(C2, 17, bytes([255])) == {17: 255}


def test_buttons_light_bumper_and_signed_values() -> None:
    assert decode_packet(C1, 18, bytes([0b101]))[18] == Buttons(play=True, advance=True)
    assert decode_packet(C2, 18, bytes([0b101]))[18] == Buttons(clean=True, dock=True)
    assert LightBumper.from_raw(0b100001) == LightBumper(left=True, right=True)
    values = decode_packet(C2, 101, bytes([0xFF, 0xFE, 0x80, 0x00]) + bytes(24))
    assert values[43] == -2 and values[44] == -32768
    s = SensorState().with_packets(decode_packet(C2, 3, bytes([2, 0x3B, 0x60, 0xFF, 0x38, 0xF6,
                                                              0x09, 0xC4, 0x0A, 0x8C])))
    assert (s.charging_state, s.voltage_mv, s.current_ma, s.battery_temp_c, s.charge_mah,
            s.capacity_mah) == (2, 15200, -200, -10, 2500, 2700)


def test_group_decode_fills_every_required_state_attribute() -> None:
    raw = {7: 0b11, 8: 1, 9: 1, 12: 1, 19: -5, 20: 7, 22: 15000, 35: 2, 39: -100, 40: 300,
           41: 120, 42: -80, 43: 1000, 44: -1000, 45: 0b101}
    data = encode_packet(C2, 100, raw)
    assert len(data) == 80
    s = SensorState().with_packets(decode_packet(C2, 100, data))
    assert (s.bump_left, s.bump_right, s.wall, s.cliff_left, s.cliff_right) == (
        True, True, True, True, True)
    assert not s.cliff_front_left and not s.caster_drop
    assert (s.distance_mm, s.angle_deg, s.voltage_mv, s.oi_mode) == (-5, 7, 15000, OIMode.SAFE)
    assert (s.requested_velocity, s.requested_radius, s.requested_right_velocity,
            s.requested_left_velocity) == (-100, 300, 120, -80)
    assert (s.encoder_left, s.encoder_right, s.light_bumper) == (1000, -1000, 0b101)
    assert s.received == frozenset(range(7, 59))


def test_decode_rejects_wrong_lengths_and_unknown_ids() -> None:
    with pytest.raises(ValueError, match="packet 6 has 52 data bytes on the create1, got 51"):
        decode_packet(C1, 6, bytes(51))
    with pytest.raises(ValueError, match="does not exist"):
        decode_packet(C1, 45, bytes(1))
    with pytest.raises(ValueError, match="OI mode 7 out of range"):
        decode_packet(C2, 35, bytes([7]))


def test_encode_saturates_like_the_robots_accumulators() -> None:
    assert encode_packet(C2, 19, {19: 40000}) == bytes([0x7F, 0xFF])
    assert encode_packet(C2, 19, {19: -40000}) == bytes([0x80, 0x00])


def test_drive_radius_read_back_signed_is_straight() -> None:
    # 0x8000 read as signed 16 bit (what packet 40 reports) is straight, not a -2000 mm arc.
    assert list(oi.drive(velocity=100, radius=-32768)) == [137, 0, 100, 128, 0]
    assert oi.drive(velocity=100, radius=oi.RADIUS_STRAIGHT_SIGNED) == oi.drive_straight(100)
    assert list(oi.drive(velocity=100, radius=-32767)) == [137, 0, 100, 248, 48]  # clamped -2000


# --- limits and messages (found by mutation testing, docs/mutation.md) ---------------------------


def test_list_lengths_at_their_limits() -> None:
    from marknav.robot.oi import query_list, stream, stream_frame

    m = Model.CREATE2
    assert query_list([7], model=m) == bytes([149, 1, 7])
    assert len(query_list([7] * 255, model=m)) == 2 + 255
    assert len(stream([7] * 255, model=m)) == 2 + 255
    assert len(stream_frame(bytes(255))) == 2 + 255 + 1
    with pytest.raises(ValueError, match=r"got 0$"):
        query_list([], model=m)
    with pytest.raises(ValueError, match=r"got 256$"):
        query_list([7] * 256, model=m)
    with pytest.raises(ValueError, match=r"^a stream has at most 255 packet ids, got 256$"):
        stream([7] * 256, model=m)
    with pytest.raises(ValueError, match=r"^a stream payload has at most 255 bytes, got 256$"):
        stream_frame(bytes(256))


def test_songs_at_their_limits_and_what_is_wrong_is_named() -> None:
    from marknav.robot.oi import play, song

    sixteen = [(60, 8)] * 16
    assert song(0, sixteen, model=Model.CREATE2)[:3] == bytes([140, 0, 16])
    with pytest.raises(ValueError, match=r"^a song has 1-16 notes, got 17$"):
        song(0, [*sixteen, (60, 8)], model=Model.CREATE2)
    with pytest.raises(ValueError, match=r"^note 1 must be a \(note, duration\) pair, got "):
        song(0, [(60, 8), (60,)], model=Model.CREATE2)  # type: ignore[list-item]
    with pytest.raises(ValueError, match=r"^note 0 number must be an integer in 0\.\.255"):
        song(0, [(300, 8)], model=Model.CREATE2)
    with pytest.raises(ValueError, match=r"^song number must be an integer in 0\.\.4, got 5$"):
        play(5, model=Model.CREATE2)


@pytest.mark.parametrize(("make", "message"), [
    (lambda: oi.drive_direct(left=math.nan, right=0), "^left must be finite"),
    (lambda: oi.drive_direct(left=0, right=math.inf), "^right must be finite"),
    (lambda: oi.drive(velocity=math.nan, radius=100), "^velocity must be finite"),
    (lambda: oi.drive(velocity=100, radius=math.nan), "^radius must be finite"),
    (lambda: oi.drive(velocity=100, radius=0),
     r"^radius 0 is undefined: use RADIUS_STRAIGHT or turn_in_place\(\)$"),
    (lambda: oi.turn_in_place(math.inf, clockwise=True), "^speed must be finite"),
    (lambda: oi.leds(bits=256), "^LED bits must be an integer in 0..255, got 256$"),
    (lambda: oi.leds(power_color=-1), "^power LED colour must be an integer in 0..255"),
    (lambda: oi.leds(bits=True), "^LED bits must be an integer"),  # a bool is not a byte
])
def test_bad_command_arguments_are_named(make: Callable[[], bytes], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        make()


def test_led_defaults_and_a_paused_stream() -> None:
    assert oi.leds() == bytes([139, 0, 0, 0])
    assert oi.pause_stream() == bytes([150, 0])


@pytest.mark.parametrize("model", [C1, C2])
def test_with_packets_is_a_replace_of_the_decoded_fields(model: Model) -> None:
    """The fast merge of a frame's packets equals dataclasses.replace with their fields, frame
    after frame of random bytes (every streamed packet), and the result stays frozen."""
    import dataclasses
    import random

    from marknav.robot.packets import encode_packet, state_updates

    rng = random.Random(7)
    ids = [7, 8, 9, 10, 11, 12, 14, 19, 20, 3, 5] + ([43, 44] if model is C2 else [])
    fast = slow = SensorState(model=model)
    for _ in range(50):
        decoded: dict[int, object] = {}
        for pid in ids:
            size = len(encode_packet(model, pid, {}))
            for _attempt in range(2000):  # random bytes until they are a valid packet
                try:
                    decoded.update(decode_packet(model, pid, bytes(rng.randrange(256)
                                                                   for _ in range(size))))
                    break
                except ValueError:  # e.g. an OI mode byte above 3
                    continue
            else:
                raise AssertionError(f"no valid random packet {pid}")
        fast = fast.with_packets(decoded)
        slow = dataclasses.replace(slow, received=slow.received | frozenset(decoded),
                                   **state_updates(model, decoded))
        assert fast == slow
    with pytest.raises(dataclasses.FrozenInstanceError):
        fast.wall = True  # type: ignore[misc]
