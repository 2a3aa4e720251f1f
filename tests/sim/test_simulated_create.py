"""The byte-level simulated Create: modes, command framing, motion, sensors, stream timing."""

from __future__ import annotations

import math

import pytest

from marknav.core.clock import ManualClock
from marknav.planning.kinematics import Pose
from marknav.robot import oi
from marknav.robot.odometry import MM_PER_COUNT
from marknav.robot.oi import Model, OIMode, StreamParser
from marknav.robot.packets import (
    SensorState,
    decode_id_data_pairs,
    decode_packet,
    group_table,
    packet_size,
    packet_table,
)
from marknav.sim.simulated_create import LedState, SimulatedCreate

C1, C2 = Model.CREATE1, Model.CREATE2
TICK = oi.STREAM_PERIOD_S


def started(model: Model = C2, mode: bytes = oi.safe(), **kwargs: object) -> SimulatedCreate:
    sim = SimulatedCreate(model=model, **kwargs)  # type: ignore[arg-type]
    sim.write(oi.start() + mode)
    return sim


def poll(sim: SimulatedCreate, packet_id: int) -> dict[int, object]:
    sim.read()
    sim.write(oi.sensors(packet_id, model=sim.model))
    data = sim.read()
    assert len(data) == packet_size(sim.model, packet_id)
    return decode_packet(sim.model, packet_id, data)


def test_off_until_start_then_passive_safe_full() -> None:
    sim = SimulatedCreate()
    assert sim.mode is OIMode.OFF
    sim.write(oi.safe() + oi.sensors(35, model=C2))  # ignored: the OI is off
    assert sim.mode is OIMode.OFF and sim.read() == b""
    sim.write(oi.start())
    assert sim.mode is OIMode.PASSIVE
    sim.write(oi.safe())
    assert sim.mode is OIMode.SAFE and poll(sim, 35) == {35: OIMode.SAFE}
    sim.write(oi.full())
    assert sim.mode is OIMode.FULL
    sim.write(oi.stop())
    assert sim.mode is OIMode.OFF


def test_a_partial_command_waits_for_its_data_bytes() -> None:
    sim = started()
    cmd = oi.drive_direct(left=100, right=-50)
    sim.write(cmd[:3])
    assert sim.wheel_speeds.left == 0.0
    sim.write(cmd[3:])
    assert (sim.wheel_speeds.left, sim.wheel_speeds.right) == (100.0, -50.0)


def test_drive_is_ignored_in_passive_mode() -> None:
    sim = started(mode=b"")
    sim.write(oi.drive_direct(left=200, right=200))
    sim.step(1.0)
    assert sim.pose == Pose(0.0, 0.0, math.pi / 2)
    assert sim.commands[-1].accepted is False


def test_straight_drive_moves_and_encoders_count() -> None:
    sim = started()
    sim.write(oi.drive_direct(left=200, right=200))
    for _ in range(100):
        sim.step(0.01)
    assert sim.pose.x == pytest.approx(0.0, abs=1e-9)
    assert sim.pose.y == pytest.approx(200.0)
    left, right = sim.encoder_counts
    assert left == right == round(200.0 / MM_PER_COUNT)
    assert poll(sim, 19) == {19: 200}
    assert poll(sim, 19) == {19: 0}  # distance resets when read


def test_drive_radius_and_spin() -> None:
    sim = started()
    sim.write(oi.drive(velocity=100, radius=500))  # left turn
    speeds = sim.wheel_speeds
    half = 0.5 * sim.wheel_base_mm
    assert speeds.left == pytest.approx(100 * (500 - half) / 500)
    assert speeds.right == pytest.approx(100 * (500 + half) / 500)
    sim.write(oi.turn_in_place(100, clockwise=True))
    assert (sim.wheel_speeds.left, sim.wheel_speeds.right) == (100.0, -100.0)
    values = poll(sim, 5)
    assert values[39] == 100 and values[40] == -1


def test_angle_accumulates_and_keeps_the_unreported_fraction() -> None:
    sim = started(C1)
    sim.write(oi.turn_in_place(50, clockwise=False))
    total = 0
    for _ in range(200):  # 3 s at 15 ms, about 0.74 deg per read
        sim.step(TICK)
        total += int(poll(sim, 20)[20])  # type: ignore[call-overload]
    expected = math.degrees(2 * 50 * 200 * TICK / sim.wheel_base_mm)
    assert abs(total - expected) < 1.0


def test_encoders_wrap_at_16_bits() -> None:
    sim = started()
    sim.write(oi.drive_direct(left=500, right=-500))
    sim.step(80.0)  # 40 m of wheel travel, > 2^16 counts
    counts = round(40000 / MM_PER_COUNT)
    left, right = sim.encoder_counts
    assert left == (counts + 32768) % 65536 - 32768
    assert right == (-counts + 32768) % 65536 - 32768


def test_wheel_mismatch_moves_the_ground_not_the_encoders() -> None:
    sim = started(right_scale=0.97)
    sim.write(oi.drive_direct(left=200, right=200))
    sim.step(5.0)
    assert sim.pose.theta < math.pi / 2  # the slow right wheel turns it right
    assert sim.encoder_counts[0] == sim.encoder_counts[1]


def test_cliff_in_safe_mode_while_driving_forward_drops_to_passive() -> None:
    sim = started()
    sim.write(oi.drive_direct(left=100, right=100))
    sim.set_cliff(front_left=True)
    assert sim.mode is OIMode.PASSIVE and sim.wheel_speeds.left == 0.0


def test_cliff_backing_straight_is_allowed_but_a_wheel_drop_is_not() -> None:
    sim = started()
    sim.set_cliff(left=True)
    sim.write(oi.drive_direct(left=-100, right=-100))
    sim.step(0.1)
    assert sim.mode is OIMode.SAFE and sim.wheel_speeds.left == -100.0
    sim.set_wheel_drop(right=True)
    assert sim.mode is OIMode.PASSIVE and sim.wheel_speeds.right == 0.0
    assert poll(sim, 7)[7].wheel_drop_right


def test_full_mode_ignores_cliffs_and_drops() -> None:
    sim = started(mode=oi.full())
    sim.write(oi.drive_direct(left=100, right=100))
    sim.set_cliff(left=True, right=True)
    sim.set_wheel_drop(left=True)
    sim.step(0.1)
    assert sim.mode is OIMode.FULL and sim.wheel_speeds.left == 100.0


def test_bump_sets_bits_and_stops_nothing() -> None:
    sim = started(C1)
    sim.write(oi.drive_direct(left=100, right=100))
    sim.set_bump(left=True, right=False)
    sim.step(0.1)
    assert sim.wheel_speeds.left == 100.0 and sim.mode is OIMode.SAFE
    value = poll(sim, 7)[7]
    assert value.bump_left and not value.bump_right  # type: ignore[attr-defined]


def test_stream_frames_every_15_ms_of_sim_time() -> None:
    sim = started()
    sim.write(oi.stream([7, 19, 35], model=C2))
    parser = StreamParser(C2)
    sim.step(0.1)  # ticks at 15, 30, ... 90 ms
    frames = parser.feed(sim.read())
    assert len(frames) == 6 and sim.frames_sent == 6
    sim.write(oi.pause_stream())
    sim.step(0.1)
    assert sim.read() == b""
    sim.write(oi.resume_stream())
    sim.step(0.03)
    assert len(parser.feed(sim.read())) == 2 and parser.bad_frames == 0


def test_stream_distance_sums_to_the_travel() -> None:
    sim = started(C1)
    sim.write(oi.stream([19, 20], model=C1) + oi.drive_direct(left=150, right=150))
    parser = StreamParser(C1)
    total = 0
    for _ in range(10):
        sim.step(0.101)  # last frame at the 1.005 s tick: 150.75 mm driven
        total += sum(f.values[19] for f in parser.feed(sim.read()))
    assert total == 150


@pytest.mark.parametrize("model", [C1, C2])
def test_sensors_and_query_list_answer_every_packet_and_group(model: Model) -> None:
    sim = started(model)
    ids = [*packet_table(model), *group_table(model)]
    for pid in ids:
        values = poll(sim, pid)
        assert values[35] == OIMode.SAFE if 35 in values else True
    sim.write(oi.query_list(ids, model=model))
    data = sim.read()
    assert len(data) == sum(packet_size(model, i) for i in ids)
    sim.write(oi.query_list([7, 13], model=model))
    assert len(sim.read()) == 2


def test_model_differences_in_replies() -> None:
    c1, c2 = started(C1), started(C2)
    assert poll(c1, 17) == {17: None} and poll(c2, 17) == {17: None}  # 255 vs 0 on the wire
    c1.write(oi.sensors(17, model=C1))
    c2.write(oi.sensors(17, model=C2))
    assert (c1.read(), c2.read()) == (bytes([255]), bytes([0]))
    c1.write(bytes([142, 100]))  # group 100 does not exist on a Create 1: no reply
    assert c1.read() == b""
    c1.set_wheel_drop(caster=True)
    assert poll(c1, 7)[7].caster_drop  # type: ignore[attr-defined]


def test_group_100_decodes_to_a_consistent_state() -> None:
    sim = started()
    sim.set_bump(left=False, right=True)
    sim.set_light_bumper(0b000110)
    sim.write(oi.drive_direct(left=120, right=80))
    state = SensorState().with_packets(poll(sim, 100))
    assert state.bump_right and not state.bump_left and state.light_bumper == 0b000110
    assert (state.requested_left_velocity, state.requested_right_velocity) == (120, 80)
    assert state.oi_mode is OIMode.SAFE and state.voltage_mv > 0


def test_leds_songs_and_play_are_recorded() -> None:
    sim = started()
    sim.write(oi.leds(bits=4, power_color=0, power_intensity=128))
    assert sim.leds == LedState(4, 0, 128)
    sim.write(oi.song(2, [(60, 32), (62, 32)], model=C2) + oi.play(2, model=C2))
    assert sim.songs[2] == ((60, 32), (62, 32))
    assert sim.played == [(0.0, 2)] and sim.song_playing
    assert poll(sim, 37) == {37: True}
    sim.write(oi.play(2, model=C2))  # refused while playing
    assert len(sim.played) == 1
    sim.step(1.01)
    assert not sim.song_playing
    sim.write(oi.start() + oi.play(2, model=C2))  # Play needs Safe/Full
    assert len(sim.played) == 1


def test_baud_is_recorded_and_harmless() -> None:
    sim = started()
    sim.write(oi.baud(19200) + oi.sensors(35, model=C2))
    assert sim.baudrate == 19200 and sim.read() == bytes([2])


def test_unknown_bytes_are_skipped() -> None:
    sim = started()
    sim.write(bytes([0, 1, 2, 200]) + oi.sensors(35, model=C2))
    assert sim.read() == bytes([2])


def test_reset_prints_a_banner_and_turns_the_oi_off() -> None:
    sim = started()
    sim.write(oi.reset())
    assert b"r3_robot/tags/release" in sim.read() and sim.mode is OIMode.OFF


def test_step_needs_a_manual_clock_and_runs_are_deterministic() -> None:
    def run(seed: int) -> Pose:
        sim = started(slip_std=0.05, seed=seed)
        sim.write(oi.drive_direct(left=200, right=150))
        sim.step(2.0)
        return sim.pose

    assert run(1) == run(1) != run(2)
    clock = ManualClock(10.0)
    sim = SimulatedCreate(clock=clock)
    clock.advance(1.0)
    sim.sync()
    assert sim.time == 11.0


def test_stream_frames_decode_with_the_driver_parser() -> None:
    sim = started(C1)
    ids = [7, 8, 9, 10, 11, 12, 14, 19, 20, 3, 5]
    sim.write(oi.stream(ids, model=C1))
    sim.step(TICK)
    data = sim.read()
    assert len(data) == 47 and sim.stream_frame_size() == 47
    values = decode_id_data_pairs(C1, data[2:-1])
    assert values[35] == OIMode.SAFE


def test_reset_is_answered_in_off_mode_on_a_create2() -> None:
    # Create 2 OI spec: Reset (7) is available in every mode, Off included.
    sim = SimulatedCreate(model=C2)
    assert sim.mode is OIMode.OFF
    sim.write(bytes([7]))
    banner = sim.read()
    assert banner.startswith(b"\r\nmarknav simulated Roomba 600 (Create 2)\r\n")
    assert sim.mode is OIMode.OFF and sim.commands[-1].opcode == 7
    # everything else is still lost while Off
    sim.write(bytes([142, 35]))
    assert sim.read() == b""


def test_create1_off_mode_ignores_opcode_7() -> None:
    sim = SimulatedCreate(model=C1)  # the Create 1 has no Reset
    sim.write(bytes([7]))
    assert sim.read() == b"" and list(sim.commands) == []


def test_drive_radius_minus_32768_drives_straight() -> None:
    # Packet 40 reports the straight radius 0x8000 read as signed: -32768. Sent back, the
    # driver's encoder must put 0x8000 on the wire and the robot must drive straight.
    sim = started()
    sim.write(oi.drive_straight(200))
    assert poll(sim, 40) == {40: -32768}
    wire = oi.drive(velocity=200, radius=-32768)
    assert list(wire) == [137, 0, 200, 128, 0]
    sim.write(wire)
    assert (sim.wheel_speeds.left, sim.wheel_speeds.right) == (200.0, 200.0)
