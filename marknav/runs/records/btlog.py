"""Groot2's replay file (``.btlog``, BehaviorTree.CPP 4's ``FileLogger2``) from a run log.

The format (BehaviorTree.CPP 4.10 ``src/loggers/bt_file_logger_v2.cpp``), little-endian:

- the 18 bytes ``BTCPP4-FileLogger2``, one byte protocol ``1``;
- ``i32`` length of the tree XML, then the XML (``_uid`` on every node);
- ``i64`` the first timestamp, microseconds since the Unix epoch;
- then 9 bytes a transition: 6-byte offset in microseconds from the first timestamp, ``u16``
  node uid, ``u8`` status (0 idle, 1 running, 2 success, 3 failure, 4 skipped).

A run log records each tick's changed nodes at the tick's run time, so the transitions are the
status changes of those records, at their time (the run's own clock: a simulated run's seconds,
not the wall clock's). The first timestamp is the wall-clock time the run started, which the
run log's ``tree`` record keeps (``epoch_us``); for a log written without it, the log file's
modification time less the run's length.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from marknav.runs.records.btcpp import nodes_of_state, tree_xml
from marknav.runs.records.tree_state import FAILURE, INVALID, RUNNING, SUCCESS, TreeState

MAGIC = b"BTCPP4-FileLogger2"
PROTOCOL = 1
RECORD_BYTES = 9
#: BehaviorTree.CPP's NodeStatus values.
STATUS_CODES = {INVALID: 0, RUNNING: 1, SUCCESS: 2, FAILURE: 3}
SKIPPED = 4
US_PER_S = 1_000_000
#: The largest offset 6 bytes hold: 2**48 µs, about 8.9 years of run.
MAX_OFFSET_US = (1 << 48) - 1


@dataclass(frozen=True)
class Transition:
    """One node's change of status: ``offset_us`` after the first timestamp."""

    offset_us: int
    uid: int
    status: int


@dataclass(frozen=True)
class BtLog:
    xml: str
    first_us: int
    transitions: list[Transition]


def transitions_of(records: list[dict[str, Any]]) -> tuple[TreeState, list[Transition]]:
    """The tree's shape and every status change of a run log's ticks, at its run time."""
    tree = next((r for r in records if r["kind"] == "tree"), None)
    if tree is None:
        raise ValueError("the run log has no tree record")
    state = TreeState.from_structure(tree["tree"])
    out: list[Transition] = []
    for rec in records:
        if rec["kind"] != "tick":
            continue
        offset = min(MAX_OFFSET_US, max(0, round(float(rec["t"]) * US_PER_S)))
        for key, (status, _message) in sorted(rec.get("nodes", {}).items(),
                                              key=lambda kv: int(kv[0])):
            i = int(key)
            if status != state.status[i]:
                out.append(Transition(offset, i + 1, STATUS_CODES.get(status, SKIPPED)))
                state.status[i] = status
    return state, out


def from_run_log(records: list[dict[str, Any]], *, log_mtime_s: float) -> BtLog:
    """The ``.btlog`` contents of a run log's records."""
    state, transitions = transitions_of(records)
    tree = next(r for r in records if r["kind"] == "tree")
    xml = tree.get("btcpp_xml") or tree_xml(nodes_of_state(state), "MainTree")
    first = tree.get("epoch_us")
    if first is None:
        last_t = max((float(r["t"]) for r in records), default=0.0)
        first = round((log_mtime_s - last_t) * US_PER_S)
    return BtLog(xml, int(first), transitions)


def encode(log: BtLog) -> bytes:
    xml = log.xml.encode("utf-8")
    parts = [MAGIC, bytes([PROTOCOL]), struct.pack("<i", len(xml)), xml,
             struct.pack("<q", log.first_us)]
    for t in log.transitions:
        parts.append(t.offset_us.to_bytes(6, "little") + struct.pack("<HB", t.uid, t.status))
    return b"".join(parts)


def decode(data: bytes) -> BtLog:
    """A ``.btlog`` read back; :class:`ValueError` naming what is wrong with it."""
    if not data.startswith(MAGIC):
        raise ValueError(f"not a Groot2 .btlog (it does not start with {MAGIC.decode()})")
    pos = len(MAGIC)
    if len(data) < pos + 5 or data[pos] != PROTOCOL:
        raise ValueError("unknown .btlog protocol")
    (n,) = struct.unpack_from("<i", data, pos + 1)
    pos += 5
    if n < 0 or len(data) < pos + n + 8:
        raise ValueError("the .btlog is cut short in its tree XML")
    xml = data[pos:pos + n].decode("utf-8")
    pos += n
    (first,) = struct.unpack_from("<q", data, pos)
    pos += 8
    body = data[pos:]
    if len(body) % RECORD_BYTES:
        raise ValueError(f"the .btlog ends in a partial record ({len(body) % RECORD_BYTES} "
                         "bytes)")
    out = []
    for k in range(0, len(body), RECORD_BYTES):
        offset = int.from_bytes(body[k:k + 6], "little")
        uid, status = struct.unpack_from("<HB", body, k + 6)
        out.append(Transition(offset, uid, status))
    return BtLog(xml, first, out)


def write(path: Path, log: BtLog) -> None:
    path.write_bytes(encode(log))
