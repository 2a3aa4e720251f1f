"""Groot2's .btlog: a slalom run's tree history, read back with a reader written here from the
format (not marknav's own decoder), has every status change the live tree made, at its time; the
same reader reads a .btlog BehaviorTree.CPP's own FileLogger2 wrote; bad files are refused."""

from __future__ import annotations

import struct
import time
from pathlib import Path
from typing import Any

import pytest

from marknav.cli.main import main
from marknav.missions.schema import load_mission
from marknav.runs.loop.run import RunRequest, execute
from marknav.runs.records import btlog, runlog
from marknav.runs.records.btcpp import read_tree_xml
from marknav.runs.records.tree_state import _preorder

ROOT = Path(__file__).resolve().parents[3]
SLALOM = ROOT / "missions" / "slalom.yaml"
CODES = {"INVALID": 0, "RUNNING": 1, "SUCCESS": 2, "FAILURE": 3}


def read(data: bytes) -> tuple[str, int, list[tuple[int, int, int]]]:
    """XML, first timestamp (µs since the epoch), (offset µs, uid, status) records."""
    assert data[:18] == b"BTCPP4-FileLogger2" and data[18] == 1
    (n,) = struct.unpack("<i", data[19:23])
    xml = data[23:23 + n].decode()
    (first,) = struct.unpack("<q", data[23 + n:31 + n])
    body = data[31 + n:]
    assert len(body) % 9 == 0
    recs = [(int.from_bytes(body[k:k + 6], "little"), *struct.unpack("<HB", body[k + 6:k + 9]))
            for k in range(0, len(body), 9)]
    return xml, first, recs


@pytest.mark.slow
def test_a_slalom_btlog_has_every_status_change_at_its_time(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    live: list[tuple[float, list[str]]] = []
    original = runlog.Recorder.tick

    def spy(self: runlog.Recorder, now: float, overruns: int) -> None:
        original(self, now, overruns)
        live.append((now, [n.status.value for n in _preorder(self.root)]))

    mp = pytest.MonkeyPatch()
    mp.setattr(runlog.Recorder, "tick", spy)
    try:
        execute(RunRequest(mission=load_mission(str(SLALOM)),
                           report_path=tmp_path / "report.json",
                           events_path=tmp_path / "report.events.jsonl"))
    finally:
        mp.undo()
    out = tmp_path / "slalom.btlog"
    assert main(["replay", str(tmp_path), "--btlog", str(out)]) == 0
    xml, first, recs = read(out.read_bytes())
    # What the live tree did, tick by tick, as (µs, uid, status).
    expected = []
    before = ["INVALID"] * len(live[0][1])
    for now, statuses in live:
        for i, (a, b) in enumerate(zip(before, statuses, strict=True)):
            if a != b:
                expected.append((round(now * 1e6), i + 1, CODES[b]))
        before = statuses
    assert len(expected) > 50  # four waypoints: searches, approaches, bypasses
    assert recs == expected
    assert f"({len(expected)} status changes" in capsys.readouterr().out
    # The XML names the same nodes under the uids the records use.
    tree = read_tree_xml(xml)
    assert tree["uids"] == list(range(1, len(live[0][1]) + 1))
    bypasses = [u for u, name in zip(tree["uids"], tree["names"], strict=True)
                if name == "Bypass"]
    assert len(bypasses) == 4
    for uid in bypasses:  # every bypass ran and succeeded
        assert [s for _, u, s in recs if u == uid][:2] == [1, 2]
    assert first > 1_600_000_000 * 1_000_000  # wall-clock microseconds, not run seconds


def test_btcpp_file_logger_output_reads_with_the_same_reader(tmp_path: Path) -> None:
    bt = pytest.importorskip("behaviortreepy")
    factory = bt.BehaviorTreeFactory()
    factory.register_simple_action("Do", lambda node: bt.NodeStatus.SUCCESS)
    tree = factory.create_tree_from_text(
        '<root BTCPP_format="4"><BehaviorTree ID="Main"><Sequence><Do/><Inverter><Do/>'
        "</Inverter></Sequence></BehaviorTree></root>")
    path = tmp_path / "ref.btlog"
    logger = bt.FileLogger(tree, str(path))
    assert tree.tick_while_running() == bt.NodeStatus.FAILURE
    deadline = time.monotonic() + 5.0  # its writer thread flushes every 10 ms
    while time.monotonic() < deadline:
        time.sleep(0.01)
        if len(read(path.read_bytes())[2]) == 12:
            break
    data = path.read_bytes()
    del logger
    xml, first, recs = read(data)
    assert read_tree_xml(xml)["uids"] == [1, 2, 3, 4]
    # Sequence runs; Do runs and succeeds; the Inverter runs its Do, which succeeds, and fails;
    # BehaviorTree.CPP then turns every node back to idle (0).
    assert [(uid, s) for _, uid, s in recs] == [
        (1, 1), (2, 1), (2, 2), (3, 1), (4, 1), (4, 2), (4, 0), (3, 3), (2, 0), (3, 0),
        (1, 3), (1, 0)]
    offsets = [t for t, _, _ in recs]
    assert offsets == sorted(offsets) and offsets[-1] < 1_000_000  # µs after the start
    mine = btlog.decode(data)  # marknav's decoder agrees with the format's reader
    assert (mine.xml, mine.first_us) == (xml, first)
    assert [(t.offset_us, t.uid, t.status) for t in mine.transitions] == recs


def _records() -> list[dict[str, Any]]:
    tree = {"names": ["Root", "A", "B"], "kinds": ["sequence", "leaf", "leaf"],
            "parents": [-1, 0, 0], "memory": [True, False, False]}
    return [
        {"t": 0.0, "kind": "tree", "tree": tree},  # an older log: no XML, no wall clock
        {"t": 0.0, "kind": "tick", "n": 0, "nodes": {"0": ["RUNNING", ""], "1": ["RUNNING", ""]}},
        {"t": 0.1, "kind": "tick", "n": 1, "nodes": {"1": ["RUNNING", "closer"]}},
        {"t": 0.2, "kind": "tick", "n": 2, "nodes": {"1": ["SUCCESS", ""], "2": ["FAILURE", ""],
                                                     "0": ["FAILURE", ""]}},
    ]


def test_message_changes_are_not_status_changes_and_old_logs_get_a_generic_tree() -> None:
    log = btlog.from_run_log(_records(), log_mtime_s=1000.0)
    _, first, recs = read(btlog.encode(log))
    assert recs == [(0, 1, 1), (0, 2, 1), (200_000, 1, 3), (200_000, 2, 2), (200_000, 3, 3)]
    assert first == round((1000.0 - 0.2) * 1e6)
    tree = read_tree_xml(log.xml)
    assert tree["tags"] == ["Sequence", "Behaviour", "Behaviour"]
    assert tree["names"] == ["Root", "A", "B"]


@pytest.mark.parametrize(("data", "why"), [
    (b"BTCPP3-FileLogger", "not a Groot2"),
    (b"BTCPP4-FileLogger2\x02", "protocol"),
    (b"BTCPP4-FileLogger2\x01" + struct.pack("<i", 50) + b"<root/>", "cut short"),
    (b"BTCPP4-FileLogger2\x01" + struct.pack("<i", 7) + b"<root/>" + bytes(8) + bytes(4),
     "partial record"),
])
def test_a_broken_btlog_is_refused_saying_why(data: bytes, why: str) -> None:
    with pytest.raises(ValueError, match=why):
        btlog.decode(data)


def test_a_btlog_name_without_the_extension_exits_2(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["replay", str(tmp_path), "--btlog", str(tmp_path / "x.log")]) == 2
    assert "*.btlog" in capsys.readouterr().err
