"""The Groot2 server, with a client that speaks Groot2's protocol byte for byte: first checked
against BehaviorTree.CPP's own server (behaviortreepy's Groot2Publisher), then pointed at
marknav's: the tree XML, the statuses tick by tick, the blackboard, and clients that send
garbage, vanish or poll at 100 Hz."""

from __future__ import annotations

import random
import socket
import struct
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import py_trees
import pytest

from marknav.runs.records.btcpp import read_tree_xml
from marknav.runs.records.tree_state import TreeState
from marknav.runs.views.groot2 import Groot2Server

zmq = pytest.importorskip("zmq")
msgpack = pytest.importorskip("msgpack")

STATUS = {"INVALID": 0, "RUNNING": 1, "SUCCESS": 2, "FAILURE": 3}


def free_port_pair() -> int:
    """A TCP port P with P + 1 free too."""
    for _ in range(50):
        with socket.socket() as a:
            a.bind(("127.0.0.1", 0))
            port = int(a.getsockname()[1])
            with socket.socket() as b:
                try:
                    b.bind(("127.0.0.1", port + 1))
                except OSError:
                    continue
        return port
    raise RuntimeError("no two free ports in a row")


class Groot2Client:
    """What Groot2 sends and checks: a 6-byte header (u8 protocol 2, u8 type, u32 id), and a
    reply that repeats it and adds the tree's 16-byte UUID."""

    def __init__(self, port: int, timeout_s: float = 5.0) -> None:
        self.ctx = zmq.Context()
        self.sock = self.ctx.socket(zmq.REQ)
        self.sock.setsockopt(zmq.RCVTIMEO, round(timeout_s * 1000))
        self.sock.setsockopt(zmq.LINGER, 0)
        self.sock.connect(f"tcp://127.0.0.1:{port}")
        self.tree_uuid: bytes | None = None

    def raw(self, frames: list[bytes]) -> list[bytes]:
        self.sock.send_multipart(frames)
        return [bytes(f) for f in self.sock.recv_multipart()]

    def request(self, kind: str, *extra: bytes) -> bytes:
        request_id = random.getrandbits(32)
        reply = self.raw([struct.pack("<BBI", 2, ord(kind), request_id), *extra])
        assert len(reply) == 2, reply
        head = reply[0]
        assert len(head) == 22
        assert struct.unpack("<BBI", head[:6]) == (2, ord(kind), request_id)
        if self.tree_uuid is None:
            self.tree_uuid = head[6:]
        assert head[6:] == self.tree_uuid  # one tree for the server's life
        return reply[1]

    def tree(self) -> dict[str, Any]:
        return read_tree_xml(self.request("T").decode())

    def statuses(self) -> dict[int, int]:
        payload = self.request("S")
        assert len(payload) % 3 == 0
        return {struct.unpack_from("<H", payload, k)[0]: payload[k + 2]
                for k in range(0, len(payload), 3)}

    def blackboard(self, *names: str) -> dict[str, Any]:
        out = msgpack.unpackb(self.request("B", ";".join(names).encode()))
        assert isinstance(out, dict)
        return out

    def close(self) -> None:
        self.sock.close()
        self.ctx.term()


GARBAGE: list[list[bytes]] = [
    [b"x"],                                             # short header
    [b"\x02T\x00\x00\x00\x00\x00"],                     # 7 bytes
    [struct.pack("<BBI", 2, ord("Q"), 1)],              # unknown request
    [struct.pack("<BBI", 2, ord("B"), 2)],              # blackboard without names
    [struct.pack("<BBI", 2, ord("I"), 3), b"{}"],       # a breakpoint
]


# --- the reference server -------------------------------------------------------------------

@pytest.fixture
def reference() -> Iterator[tuple[Any, Groot2Client]]:
    bt = pytest.importorskip("behaviortreepy")
    factory = bt.BehaviorTreeFactory()
    factory.register_simple_action("Do", lambda node: bt.NodeStatus.SUCCESS)
    tree = factory.create_tree_from_text(
        '<root BTCPP_format="4"><BehaviorTree ID="Main"><Sequence name="S"><Do name="a"/>'
        '<Inverter><Do name="b"/></Inverter></Sequence></BehaviorTree></root>')
    port = free_port_pair()
    publisher = bt.Groot2Publisher(tree, port)
    client = Groot2Client(port)
    yield tree, client
    client.close()
    del publisher


def test_the_client_against_behaviortree_cpp(reference: tuple[Any, Groot2Client]) -> None:
    tree, client = reference
    xml = client.tree()
    assert xml["names"] == ["S", "a", "Inverter", "b"] and xml["uids"] == [1, 2, 3, 4]
    assert client.statuses() == {1: 0, 2: 0, 3: 0, 4: 0}
    tree.tick_once()
    # BehaviorTree.CPP resets nodes to idle after its tick: 10 + the status they had.
    assert client.statuses() == {1: 13, 2: 12, 3: 13, 4: 12}
    assert client.blackboard("Main") == {"Main": None}
    for frames in GARBAGE[:4]:
        assert client.raw(frames)[0] == b"error"


def test_marknav_answers_garbage_as_behaviortree_cpp_does(
        reference: tuple[Any, Groot2Client]) -> None:
    _, theirs = reference
    root = py_trees.composites.Sequence("S", memory=True,
                                        children=[py_trees.behaviours.Success("a")])
    server = Groot2Server.for_tree(root, "Main", port=free_port_pair(), blackboard=lambda _: {})
    ours = Groot2Client(server.port)
    try:
        for frames in GARBAGE[:4]:
            assert ours.raw(frames) == theirs.raw(frames), frames
        assert ours.raw(GARBAGE[4])[0] == b"error"  # marknav sets no breakpoints
        assert ours.tree()["names"] == ["S", "a"]  # and still answers
        assert server.errors == len(GARBAGE) and server.requests == len(GARBAGE) + 1
    finally:
        ours.close()
        server.close()


# --- marknav's server on a tree ticked here -------------------------------------------------

def test_statuses_follow_the_tree_tick_by_tick_and_the_blackboard_is_served() -> None:
    root = py_trees.composites.Sequence("Route", memory=True, children=[
        py_trees.behaviours.TickCounter("Three ticks", duration=3,
                                        completion_status=py_trees.common.Status.SUCCESS),
        py_trees.composites.Selector("Either", memory=False, children=[
            py_trees.behaviours.Failure("No"), py_trees.behaviours.Success("Yes")]),
    ])
    state = TreeState.of_tree(root)
    entries = {"ticks": 0}
    server = Groot2Server.for_tree(root, "Route", port=free_port_pair(),
                                   blackboard=lambda name: dict(entries))
    client = Groot2Client(server.port)
    try:
        tree = client.tree()
        assert tree["names"] == ["Route", "Three ticks", "Either", "No", "Yes"]
        assert tree["tags"] == ["Sequence", "TickCounter", "ReactiveFallback",
                                "AlwaysFailure", "AlwaysSuccess"]
        assert client.statuses() == {1: 0, 2: 0, 3: 0, 4: 0, 5: 0}
        seen = []
        for n in range(5):
            root.tick_once()
            entries["ticks"] = n + 1
            state.capture()
            server.tick(float(n), None, None, state)
            got = client.statuses()
            assert got == {i + 1: STATUS[node.status.value]
                           for i, node in enumerate(state._nodes)}
            seen.append(got)
            assert client.blackboard("Route", "Other") == {"Route": {"ticks": n + 1}}
        # running 3 ticks, then success; the route finished, so the 5th tick starts again
        assert [s[2] for s in seen] == [1, 1, 1, 2, 1]
        assert [s[1] for s in seen] == [1, 1, 1, 2, 1]
        assert seen[3] == {1: 2, 2: 2, 3: 2, 4: 3, 5: 2}  # No failed, Yes succeeded
        assert server.watched
    finally:
        client.close()
        server.close()


def test_a_client_that_vanishes_mid_request_does_not_stop_the_server() -> None:
    root = py_trees.behaviours.Success("a")
    server = Groot2Server.for_tree(root, "T", port=free_port_pair(), blackboard=lambda _: {})
    try:
        for _ in range(20):  # ask and leave before the reply
            gone = Groot2Client(server.port)
            gone.sock.send_multipart([struct.pack("<BBI", 2, ord("T"), 9)])
            gone.close()
        with socket.create_connection(("127.0.0.1", server.port)) as raw:
            raw.sendall(b"GET / HTTP/1.1\r\n\r\n" + bytes(range(256)))  # not ZeroMQ at all
        client = Groot2Client(server.port)
        assert client.tree()["names"] == ["a"]
        client.close()
    finally:
        server.close()
    assert not server._thread.is_alive()


def test_a_port_in_use_is_refused_naming_the_option(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    from marknav.cli.main import main

    port = free_port_pair()
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", port))
        busy.listen()
        code = main(["run", "slalom", "--tree", "none", "--max-time", "1", "--groot2",
                     str(port), "--report", str(tmp_path / "r.json")])
    assert code == 2
    assert "--groot2" in capsys.readouterr().err


@pytest.mark.parametrize("value", ["80", "x", "host:70000"])
def test_bad_groot2_addresses_exit_2(value: str, capsys: pytest.CaptureFixture[str]) -> None:
    from marknav.cli.main import main

    assert main(["run", "slalom", "--groot2", value]) == 2
    assert "--groot2" in capsys.readouterr().err


# --- a whole slalom run, watched ------------------------------------------------------------

@pytest.mark.slow
def test_a_slalom_run_watched_at_100_hz_by_groot2(tmp_path: Path) -> None:
    from marknav.missions.schema import load_mission
    from marknav.runs.loop.run import RunRequest, execute
    from marknav.runs.records import runlog
    from marknav.runs.records.tree_state import _preorder

    slalom = Path(__file__).resolve().parents[3] / "missions" / "slalom.yaml"
    port = free_port_pair()
    ticks: list[dict[int, int]] = []
    original = runlog.Recorder.tick

    def spy(self: runlog.Recorder, now: float, overruns: int) -> None:
        original(self, now, overruns)
        ticks.append({i + 1: STATUS[n.status.value] for i, n in enumerate(_preorder(self.root))})

    polled: list[dict[int, int]] = []
    boards: list[dict[str, Any]] = []
    trees: list[dict[str, Any]] = []
    stop = threading.Event()

    def groot2() -> None:  # what Groot2 does: the tree once, then statuses at 100 Hz
        while not stop.is_set():
            try:
                client = Groot2Client(port, timeout_s=0.5)
                trees.append(client.tree())
                break
            except zmq.Again:
                client.close()
        while not stop.is_set():
            try:
                polled.append(client.statuses())
                if len(polled) % 10 == 0:
                    boards.append(client.blackboard("slalom"))
            except zmq.Again:  # the run is over: its server is gone
                break
            time.sleep(0.01)
        client.close()

    def vandal() -> None:  # garbage, and clients that leave without their reply
        while not stop.is_set():
            try:
                c = Groot2Client(port, timeout_s=0.2)
                c.raw([b"\xff" * random.randint(0, 40)])
                c.sock.send_multipart([struct.pack("<BBI", 2, ord("S"), 1)])
                c.close()
            except zmq.Again:
                c.close()
            time.sleep(0.02)

    threads = [threading.Thread(target=groot2), threading.Thread(target=vandal)]
    mp = pytest.MonkeyPatch()
    mp.setattr(runlog.Recorder, "tick", spy)
    try:
        for t in threads:
            t.start()
        result = execute(RunRequest(mission=load_mission(str(slalom)), realtime=True,
                                    report_path=tmp_path / "report.json",
                                    events_path=tmp_path / "report.events.jsonl",
                                    groot2=("127.0.0.1", port)))
    finally:
        stop.set()
        for t in threads:
            t.join()
        mp.undo()
    assert result.report.outcome == "success"
    assert trees and trees[0]["names"][:2] == ["Mission", "Perception"]
    assert len(trees[0]["uids"]) == len(ticks[0])
    # Every status reply is the tree after one of its ticks, in the order of the ticks.
    where = 0
    matched = 0
    for reply in polled:
        while where < len(ticks) and ticks[where] != reply:
            where += 1
        if where < len(ticks):
            matched += 1
    assert len(polled) > 100 and matched >= len(polled) - 2  # the last may be after the end
    assert any("target" in b.get("slalom", {}) for b in boards)
