"""The fast stream-frame paths give the same bytes and values as the straightforward ones.

The simulated Create packs a whole stream frame with one precomputed layout
(``SimulatedCreate._stream_frame``) and looks its raw values up in a table; the driver's
``decode_id_data_pairs`` reuses the previous payload's layout; ``state_updates`` sets
one-attribute packets directly. Each is compared here with the implementation it replaced
(kept below as the reference: the Create's ``_raw`` if-chain, ``encode_packet`` per packet
and ``oi.stream_frame``; the packet-by-packet decoder), over random robot states, random
stream lists and damaged payloads.
"""

from __future__ import annotations

import math
import random
from typing import Any

import pytest

from marknav.robot import oi
from marknav.robot.oi import Model
from marknav.robot.packets import (
    BumpsAndWheelDrops,
    OIMode,
    Overcurrents,
    decode_id_data_pairs,
    encode_packet,
    group_table,
    is_packet_id,
    member_ids,
    packet_layout,
    packet_table,
    state_updates,
)
from marknav.sim.simulated_create import SimulatedCreate, _wrap16

# --- the implementations the fast paths replaced ------------------------------------------


def reference_raw(sim: SimulatedCreate, pid: int) -> int:
    """The simulated Create's raw packet values as its if-chain computed them."""
    c1 = sim.model is Model.CREATE1
    vl, vr = sim._cmd_left, sim._cmd_right
    if pid == 7:
        return sim._bumps.to_raw()
    if pid == 8:
        return int(sim._wall)
    if 9 <= pid <= 12:
        return int(sim._cliffs[pid - 9])
    if pid == 13:
        return int(sim._virtual_wall)
    if pid == 14:
        return sim._overcurrents.to_raw(sim.model)
    if pid == 17:
        return 255 if c1 else 0
    if pid == 19:
        return sim._take_accumulator("_dist_acc")
    if pid == 20:
        return sim._take_accumulator("_angle_acc")
    if pid == 22:
        return sim.voltage_mv
    if pid == 23:
        return sim._current_ma()
    if pid == 24:
        return sim.battery_temp_c
    if pid == 25:
        return int(sim._charge_mah)
    if pid == 26:
        return sim.capacity_mah
    if pid == 27:
        return 300 if sim._wall else 0
    if 28 <= pid <= 31:
        return 20 if sim._cliffs[pid - 28] else 2400
    if pid == 32:
        return 16 if c1 else 0
    if pid == 35:
        return int(sim._mode)
    if pid == 36:
        return sim._song_number
    if pid == 37:
        return int(sim._time < sim._song_end)
    if pid == 38:
        return len(sim._stream_ids)
    if pid == 39:
        return sim._req_velocity
    if pid == 40:
        return sim._req_radius
    if pid == 41:
        return sim._req_right
    if pid == 42:
        return sim._req_left
    if pid == 43:
        return _wrap16(sim._enc_left)
    if pid == 44:
        return _wrap16(sim._enc_right)
    if pid == 45:
        return sim._light_bumper | (32 if sim._wall else 0)
    if 46 <= pid <= 51:
        return 1200 if sim._light_bumper >> (pid - 46) & 1 else 8
    if pid == 54:
        return int(0.4 * abs(vl))
    if pid == 55:
        return int(0.4 * abs(vr))
    if pid == 58:
        return int(vl + vr > 0 and not sim._bumps.bump_left and not sim._bumps.bump_right)
    return 0


def reference_frame(sim: SimulatedCreate) -> bytes:
    payload = b"".join(
        bytes([pid]) + encode_packet(sim.model, pid, {m: reference_raw(sim, m)
                                                      for m in member_ids(sim.model, pid)})
        for pid in sim._stream_ids)
    return oi.stream_frame(payload)


def reference_decode(model: Model, payload: bytes) -> dict[int, Any]:
    out: dict[int, Any] = {}
    pos = 0
    n = len(payload)
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
        pos += 1 + size
    return out


def reference_updates(model: Model, decoded: dict[int, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for pid, value in decoded.items():
        out.update(packet_table(model)[pid].fields(value))
    return out


# --- random states and streams ------------------------------------------------------------


def random_state(sim: SimulatedCreate, rng: random.Random) -> None:
    """Every input of the raw values, at random (including values the ranges saturate)."""
    sim._bumps = BumpsAndWheelDrops(*(rng.random() < 0.3 for _ in range(5)))
    sim._cliffs = tuple(rng.random() < 0.2 for _ in range(4))  # type: ignore[assignment]
    sim._wall = rng.random() < 0.3
    sim._virtual_wall = rng.random() < 0.3
    sim._light_bumper = rng.randrange(64)
    sim._overcurrents = Overcurrents(left_wheel=rng.random() < 0.2,
                                     right_wheel=rng.random() < 0.2)
    sim._cmd_left = rng.uniform(-500, 500)
    sim._cmd_right = rng.choice([0.0, rng.uniform(-500, 500)])
    sim._dist_acc = rng.choice([rng.uniform(-50, 50), rng.uniform(-1e6, 1e6)])
    sim._angle_acc = rng.uniform(-40000, 40000)
    sim._enc_left = rng.uniform(-1e6, 1e6)
    sim._enc_right = rng.uniform(-70000, 70000)
    sim.voltage_mv = rng.choice([15200, rng.randrange(0, 70000)])
    sim._charge_mah = rng.uniform(0, 70000)
    sim.battery_temp_c = rng.randrange(-200, 200)
    sim._mode = rng.choice(list(OIMode))
    sim._song_number = rng.randrange(5)
    sim._song_end = sim._time + rng.choice([-1.0, 1.0])
    sim._req_velocity = rng.randrange(-500, 501)
    sim._req_radius = rng.choice([rng.randrange(-2000, 2001), 32767, -32768])
    sim._req_left = rng.randrange(-500, 501)
    sim._req_right = rng.randrange(-500, 501)


def random_stream(model: Model, rng: random.Random) -> tuple[int, ...]:
    """Single and group packet ids (repeats allowed) whose frame fits the 255-byte limit."""
    ids = sorted(set(packet_table(model)) | set(group_table(model)))
    stream: list[int] = []
    while True:
        pid = rng.choice(ids)
        if oi.stream_ids_size(model, [*stream, pid]) > 255:
            return tuple(stream) or (7,)
        stream.append(pid)
        if rng.random() < 0.15:
            return tuple(stream)


def twin(model: Model, ids: tuple[int, ...], seed: int) -> SimulatedCreate:
    sim = SimulatedCreate(model=model)
    sim._stream_ids = ids
    random_state(sim, random.Random(seed))
    return sim


@pytest.mark.parametrize("model", list(Model))
def test_stream_frames_are_byte_identical_to_the_packet_by_packet_encoder(model: Model) -> None:
    rng = random.Random(16)
    streams = [(7, 8, 9, 10, 11, 12, 14, 19, 20, 3, 5, 43, 44, 45)[:11 if model is Model.CREATE1
                                                                    else 14]]
    streams += [random_stream(model, rng) for _ in range(60)]
    for k, ids in enumerate(streams):
        for seed in range(5):
            fast, slow = twin(model, ids, 100 * k + seed), twin(model, ids, 100 * k + seed)
            for _ in range(3):  # twice more: the accumulators keep what was not reported
                assert fast._stream_frame() == reference_frame(slow), (ids, seed)
            assert (fast._dist_acc, fast._angle_acc) == (slow._dist_acc, slow._angle_acc)


def test_a_streaming_simulated_create_sends_the_reference_bytes() -> None:
    """Through the public byte interface: Stream, drive, then every frame of a second."""
    sims = [SimulatedCreate(), SimulatedCreate()]
    for sim in sims:
        sim.write(oi.start() + oi.safe()
                  + oi.stream([7, 19, 20, 3, 5, 43, 44, 100], model=Model.CREATE2)
                  + oi.drive_direct(left=220, right=180))
        sim.read()
    fast, slow = sims
    for i in range(67):
        t = (i + 1) * oi.STREAM_PERIOD_S
        fast.advance_to(t)
        expected = b""
        with slow._lock:  # the reference frame for the same moment, from the twin's state
            while slow._t0 + slow._tick * oi.STREAM_PERIOD_S <= t:
                tick_t = slow._t0 + slow._tick * oi.STREAM_PERIOD_S
                slow._integrate(tick_t - slow._time)
                slow._time = tick_t
                slow._tick += 1
                expected += reference_frame(slow)
        assert fast.read() == expected and len(expected) > 0


@pytest.mark.parametrize("model", list(Model))
def test_decoding_reuses_layouts_without_changing_a_value(model: Model) -> None:
    rng = random.Random(61)
    streams = [random_stream(model, rng) for _ in range(40)]
    for k, ids in enumerate(streams):
        for seed in range(4):
            payload = twin(model, ids, 10 * k + seed)._stream_frame()[2:-1]
            for _ in range(2):  # the first decode records the layout, the second uses it
                decoded = decode_id_data_pairs(model, payload)
                expected = reference_decode(model, payload)
                assert decoded == expected and list(decoded) == list(expected)
                assert [type(v) for v in decoded.values()] == [type(v) for v in
                                                               expected.values()]
                assert state_updates(model, decoded) == reference_updates(model, expected)
                assert list(state_updates(model, decoded)) == list(reference_updates(
                    model, expected))


@pytest.mark.parametrize("model", list(Model))
def test_damaged_payloads_fail_or_decode_as_before(model: Model) -> None:
    """Same length and first id as a payload whose layout is known, but other bytes: a
    changed id, value or length must give what the packet-by-packet decoder gives (a value
    or the same error)."""
    rng = random.Random(7)
    ids = (7, 19, 20, 3, 35, 5) if model is Model.CREATE1 else (7, 19, 20, 3, 35, 5, 43, 101)
    good = twin(model, ids, 1)._stream_frame()[2:-1]
    decode_id_data_pairs(model, good)  # its layout is now known
    cases = [good[:-1], good + b"\x07\x00"]
    for _ in range(400):
        damaged = bytearray(good)
        for _ in range(rng.randrange(1, 3)):
            damaged[rng.randrange(1, len(damaged))] = rng.randrange(256)
        cases.append(bytes(damaged))
    for payload in cases:
        try:
            expected: Any = reference_decode(model, payload)
        except ValueError as exc:
            expected = ("error", str(exc))
        try:
            got: Any = decode_id_data_pairs(model, payload)
        except ValueError as exc:
            got = ("error", str(exc))
        assert got == expected, payload.hex()
        decode_id_data_pairs(model, good)  # keep the good layout the remembered one


def test_raw_values_match_the_if_chain_for_every_packet() -> None:
    for model in Model:
        for seed in range(30):
            fast, slow = twin(model, (7,), seed), twin(model, (7,), seed)
            for pid in range(0, 60):
                assert fast._raw(pid) == reference_raw(slow, pid), (model, pid)
            assert math.isclose(fast._dist_acc, slow._dist_acc, rel_tol=0, abs_tol=0)
