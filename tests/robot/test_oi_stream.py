"""Stream (148) frame parser: spec vectors, checksum rule, resynchronisation, fuzzing."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from marknav.robot import oi
from marknav.robot.oi import Model, OIMode, StreamParser
from marknav.robot.packets import SensorState, encode_packet, packet_table

C1, C2 = Model.CREATE1, Model.CREATE2

# bumps left+right, distance -12, angle 90, mode Safe
SPEC_FRAME = bytes([19, 10, 7, 3, 19, 255, 244, 20, 0, 90, 35, 2, 64])
# the Create 2 spec's example: left cliff signal (29) and virtual wall (13)
CREATE2_EXAMPLE = bytes([19, 5, 29, 2, 25, 13, 0, 163])


def test_spec_frame_decodes() -> None:
    parser = StreamParser(C2)
    (frame,) = parser.feed(SPEC_FRAME)
    s = SensorState().with_packets(frame.values)
    assert (s.bump_left, s.bump_right, s.distance_mm, s.angle_deg, s.oi_mode) == (
        True, True, -12, 90, OIMode.SAFE)
    assert (parser.good_frames, parser.bad_frames, parser.skipped_bytes) == (1, 0, 0)


def test_stream_frame_builds_the_spec_frames() -> None:
    assert oi.stream_frame(SPEC_FRAME[2:-1]) == SPEC_FRAME
    assert oi.stream_frame(bytes([29, 2, 25, 13, 0])) == CREATE2_EXAMPLE
    assert sum(SPEC_FRAME) % 256 == 0


def test_checksum_includes_the_header() -> None:
    # The Create 2 example (sum incl. header = 256) is accepted and decodes to 0x0219 = 537
    (frame,) = StreamParser(C2).feed(CREATE2_EXAMPLE)
    assert frame.values == {29: 0x0219, 13: False}
    # The Create 1 text's checksum (182) leaves the header out: rejected as bad.
    parser = StreamParser(C1)
    assert parser.feed(bytes([19, 5, 29, 2, 25, 13, 0, 182])) == []
    assert parser.bad_frames == 1


def test_byte_by_byte_feeding_gives_the_same_frame() -> None:
    parser = StreamParser(C2)
    frames = [f for b in SPEC_FRAME * 3 for f in parser.feed(bytes([b]))]
    assert len(frames) == 3 and parser.good_frames == 3 and parser.pending == 0
    assert [f.offset for f in frames] == [0, 13, 26]


def test_garbage_then_frame_resyncs_and_counts_skipped() -> None:
    parser = StreamParser(C2)
    frames = parser.feed(b"\x00\x01\x02" + SPEC_FRAME)
    assert len(frames) == 1 and frames[0].offset == 3
    assert parser.skipped_bytes == 3 and parser.bad_frames == 0


def test_wrong_checksum_is_bad_and_not_committed() -> None:
    corrupted = bytearray(SPEC_FRAME)
    corrupted[5] ^= 0x40  # distance byte flipped
    # Knowing the frame length (the driver always does), the next frame comes out at once.
    parser = StreamParser(C2, expected_ids=[7, 19, 20, 35])
    frames = parser.feed(bytes(corrupted) + SPEC_FRAME)
    assert [f.offset for f in frames] == [len(SPEC_FRAME)]
    assert frames[0].values[19] == -12 and parser.bad_frames == 1


def test_without_expected_ids_a_false_header_only_delays_frames() -> None:
    # After the bad frame the parser rescans from its byte 1 and meets the payload's 19 followed
    # by 255: it must see 258 bytes before rejecting that, then it finds every later frame.
    corrupted = bytearray(SPEC_FRAME)
    corrupted[5] ^= 0x40
    parser = StreamParser(C2)
    frames = parser.feed(bytes(corrupted) + SPEC_FRAME)
    assert frames == [] and parser.pending > 0
    frames += parser.feed(SPEC_FRAME * 20)
    assert [f.offset for f in frames] == [len(SPEC_FRAME) * k for k in range(1, 22)]
    assert parser.good_frames == 21


def test_starting_at_a_19_inside_the_payload_recovers() -> None:
    # Join mid-frame, right at the payload's 19 (followed by 255): rejected, the rest kept
    parser = StreamParser(C2)
    frames = parser.feed(SPEC_FRAME[4:] + SPEC_FRAME * 21)
    assert len(frames) == 21 and frames[0].offset == len(SPEC_FRAME) - 4


def test_unparseable_payload_with_good_checksum_is_bad() -> None:
    parser = StreamParser(C2)
    unknown_id = oi.stream_frame(bytes([99, 0]))
    short = oi.stream_frame(bytes([20, 0]))  # angle needs 2 data bytes
    assert parser.feed(unknown_id + short) == []
    assert parser.bad_frames == 2 and parser.good_frames == 0
    create2_only = oi.stream_frame(bytes([45, 1]))
    parser1 = StreamParser(C1)
    assert parser1.feed(create2_only) == [] and parser1.bad_frames == 1
    assert len(StreamParser(C2).feed(create2_only)) == 1


def test_group_ids_in_a_stream() -> None:
    payload = bytes([3]) + encode_packet(C1, 3, {22: 14000, 23: -300})
    (frame,) = StreamParser(C1).feed(oi.stream_frame(payload))
    assert frame.values[22] == 14000 and frame.values[23] == -300


def test_expected_ids_skip_wrong_length_headers_without_waiting() -> None:
    parser = StreamParser(C2, expected_ids=[7, 19, 20, 35])
    # a stray 19 announcing 200 bytes would otherwise hold the next frames back
    assert len(parser.feed(bytes([19, 200]) + SPEC_FRAME)) == 1
    assert parser.skipped_bytes == 2 and parser.bad_frames == 0


def _payload(model: Model, ids: list[int], raw: dict[int, int]) -> bytes:
    return b"".join(bytes([i]) + encode_packet(model, i, raw) for i in ids)


_C2_IDS = [i for i in packet_table(C2) if i not in (35,)]  # 35 must hold a valid mode


@st.composite
def frames(draw: st.DrawFn) -> bytes:
    ids = draw(st.lists(st.sampled_from(_C2_IDS), min_size=1, max_size=8))
    raw = {i: draw(st.integers(-40000, 70000)) for i in ids}
    payload = _payload(C2, ids, raw)
    if draw(st.booleans()):
        payload += bytes([35, draw(st.integers(0, 3))])
    return oi.stream_frame(payload)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    chunks=st.lists(st.tuples(st.binary(max_size=40), frames()), min_size=1, max_size=8),
    tail=st.binary(max_size=40),
    split=st.integers(1, 17),
)
def test_fuzz_every_frame_not_overlapped_by_garbage_is_recovered(
    chunks: list[tuple[bytes, bytes]], tail: bytes, split: int
) -> None:
    data = bytearray()
    placed: list[tuple[int, bytes]] = []
    for garbage, frame in chunks:
        data += garbage
        placed.append((len(data), frame))
        data += frame
    data += tail
    data += bytes(258)  # the stream goes on (no 19 here): every pending candidate is decided
    parser = StreamParser(C2)
    got = []
    for i in range(0, len(data), split):  # never raises, whatever the chunking
        got += parser.feed(bytes(data[i:i + split]))
    by_offset = {f.offset: f for f in got}
    for offset, frame in placed:
        if offset in by_offset:
            assert oi.stream_frame(by_offset[offset].payload) == frame
            continue
        # Lost only if a frame accepted out of garbage covers its start.
        assert any(f.offset < offset < f.offset + len(f.payload) + 3 for f in got), (
            f"frame at {offset} lost")
    assert parser.good_frames == len(got)
    consumed = sum(len(f.payload) + 3 for f in got)
    assert parser.skipped_bytes + consumed + parser.pending == len(data)
    for f in got:  # only checksummed frames are ever committed
        assert sum(oi.stream_frame(f.payload)) % 256 == 0


_DRIVER_IDS = [7, 8, 9, 10, 11, 12, 14, 19, 20, 3, 5, 43, 44, 45]


@settings(max_examples=200, deadline=None)
@given(
    garbage=st.lists(st.binary(max_size=60), min_size=1, max_size=6),
    values=st.lists(st.integers(-32768, 32767), min_size=6, max_size=6),
)
def test_fuzz_driver_stream_with_expected_ids(garbage: list[bytes], values: list[int]) -> None:
    raw = {19: values[0], 20: values[1], 43: values[2], 44: values[3], 23: values[4],
           35: values[5] % 4, 7: values[5] % 16}
    frame = oi.stream_frame(_payload(C2, _DRIVER_IDS, raw))
    data = b"".join(g + frame for g in garbage) + bytes(len(frame))
    parser = StreamParser(C2, expected_ids=_DRIVER_IDS)
    got = parser.feed(data)
    starts = []
    pos = 0
    for g in garbage:
        starts.append(pos + len(g))
        pos += len(g) + len(frame)
    offsets = [f.offset for f in got]
    for start in starts:
        assert start in offsets or any(o < start < o + len(frame) for o in offsets)
    for f in got:
        if f.offset in starts:
            assert SensorState().with_packets(f.values).encoder_left == values[2]


@given(st.binary(max_size=600))
@settings(max_examples=300, deadline=None)
def test_fuzz_random_bytes_never_raise(data: bytes) -> None:
    for model in (C1, C2):
        parser = StreamParser(model)
        got = parser.feed(data)
        for f in got:
            SensorState(model=model).with_packets(f.values)
        consumed = sum(len(f.payload) + 3 for f in got)
        assert parser.skipped_bytes + parser.pending + consumed == len(data)
        assert parser.pending <= 257  # never holds more than one candidate frame


@pytest.mark.parametrize("model", [C1, C2])
def test_every_single_packet_round_trips_through_a_frame(model: Model) -> None:
    table = packet_table(model)
    ids = [i for i in table if i != 35]
    raw = {i: (-3 if table[i].signed else 3) for i in ids}
    parser = StreamParser(model)
    (frame,) = parser.feed(oi.stream_frame(_payload(model, ids, raw)))
    assert set(frame.values) == set(ids)
