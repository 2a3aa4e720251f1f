"""The OI encoder and stream parser at edges mutation testing found unasserted (docs/mutation.md,
drivers/oi.py): a bool is no packet id, a command's length is unknown until its count byte
arrived, a wrong-length header is dropped as soon as its length byte is in, garbage is counted
every time it occurs, and the expected packet list is kept."""

from __future__ import annotations

import pytest

from marknav.robot import oi
from marknav.robot.oi import Model, Opcode, StreamParser

C1, C2 = Model.CREATE1, Model.CREATE2

# bumps left+right, distance -12, angle 90, mode Safe: packets 7, 19, 20, 35 (as test_oi_stream.py)
SPEC_FRAME = bytes([19, 10, 7, 3, 19, 255, 244, 20, 0, 90, 35, 2, 64])
SPEC_IDS = (7, 19, 20, 35)
# the Create 2 spec's example: packets 29 and 13, well formed, a different list
CREATE2_EXAMPLE = bytes([19, 5, 29, 2, 25, 13, 0, 163])


@pytest.mark.parametrize("build", [
    lambda pid: oi.sensors(pid, model=C2),
    lambda pid: oi.query_list([7, pid], model=C2),
    lambda pid: oi.stream([pid], model=C2),
])
@pytest.mark.parametrize("pid", [True, False])
def test_a_bool_is_not_a_packet_id(build, pid) -> None:
    # True == 1 and False == 0 as integers; packet 1 exists (a group), so True must be refused
    # for what it is, not for its value.
    with pytest.raises(ValueError, match=rf"^packet id {pid!r} does not exist on the create2$"):
        build(pid)
    assert oi.sensors(1, model=C2) == bytes([Opcode.SENSORS, 1])


@pytest.mark.parametrize(("model", "op"), [
    (C2, Opcode.STREAM), (C2, Opcode.QUERY_LIST), (C1, Opcode.SCRIPT), (C2, Opcode.SONG)])
def test_a_counted_command_needs_its_count_byte_before_its_length_is_known(model, op) -> None:
    assert oi.command_length(model, bytes([op])) is None
    if op == Opcode.SONG:  # [140][number][count]: the count is the third byte
        assert oi.command_length(model, bytes([op, 0])) is None
        assert oi.command_length(model, bytes([op, 0, 3])) == 3 + 2 * 3
    else:
        assert oi.command_length(model, bytes([op, 4])) == 2 + 4
    assert oi.command_length(model, b"") is None


def test_a_wrong_length_header_is_dropped_as_soon_as_its_length_byte_arrives() -> None:
    parser = StreamParser(C2, expected_ids=SPEC_IDS)
    # a 19 and a length byte that is not the expected list's: both are gone at once, nothing
    # is held back waiting for a third byte
    assert parser.feed(bytes([19, 200])) == []
    assert (parser.pending, parser.skipped_bytes, parser.bad_frames) == (0, 2, 0)
    # a header with the right length is held while its frame comes in
    assert parser.feed(SPEC_FRAME[:2]) == []
    assert parser.pending == 2
    (frame,) = parser.feed(SPEC_FRAME[2:])
    assert frame.offset == 2 and parser.pending == 0
    # garbage, then a wrong-length header: every byte of both is counted
    assert parser.feed(b"\x01\x02" + bytes([19, 99])) == []
    assert (parser.pending, parser.skipped_bytes) == (0, 2 + 4)


def test_skipped_bytes_add_up_over_every_run_of_garbage() -> None:
    parser = StreamParser(C2)
    frames = parser.feed(b"\x01\x02\x03" + SPEC_FRAME + b"\x04\x05" + SPEC_FRAME)
    assert [f.offset for f in frames] == [3, 3 + len(SPEC_FRAME) + 2]
    assert parser.skipped_bytes == 5
    frames = parser.feed(b"\x06" + SPEC_FRAME)
    assert [f.offset for f in frames] == [3 + 2 * len(SPEC_FRAME) + 2 + 1]
    assert (parser.skipped_bytes, parser.good_frames) == (6, 3)


def test_the_expected_packet_list_is_kept_and_enforced() -> None:
    parser = StreamParser(C2, expected_ids=list(SPEC_IDS))
    assert parser.expected_ids == SPEC_IDS
    # a well-formed frame (good checksum, known packets) of another list is not the stream the
    # driver asked for: its header is skipped and the frame is not returned
    assert parser.feed(CREATE2_EXAMPLE) == []
    assert parser.good_frames == 0 and parser.skipped_bytes == len(CREATE2_EXAMPLE)
    assert len(parser.feed(SPEC_FRAME)) == 1
    parser.set_expected_ids([29, 13])
    assert parser.expected_ids == (29, 13)
    assert len(parser.feed(CREATE2_EXAMPLE)) == 1
    assert parser.feed(SPEC_FRAME) == []
    parser.set_expected_ids(None)
    assert parser.expected_ids is None
    assert len(parser.feed(SPEC_FRAME + CREATE2_EXAMPLE)) == 2
