"""``marknav run --foxglove PORT``: the recording's channels, live, to a WebSocket client.

The client is a plain ``websockets`` connection speaking ``foxglove.sdk.v1`` (what Foxglove
speaks): it reads the server's advertisements, subscribes to the camera and the tree, and
decodes what arrives while the mission runs at wall-clock speed.
"""

from __future__ import annotations

import asyncio
import json
import socket
import struct
import threading
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("foxglove")
websockets = pytest.importorskip("websockets")

from marknav.cli.main import main  # noqa: E402

ROOT = Path(__file__).resolve().parents[3]
SLALOM = ROOT / "missions" / "slalom.yaml"
WANTED = ("/camera/image/compressed", "/marknav/tree")
#: Binary server message: opcode 1 (message data), u32 subscription id, u64 log time.
MESSAGE_DATA = 1
HEADER = struct.Struct("<BIQ")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


async def _client(port: int, got: dict[str, list[bytes]], info: dict[str, Any],
                  deadline: float) -> None:
    while True:  # the server starts once the mission has been checked
        try:
            ws = await websockets.connect(f"ws://127.0.0.1:{port}",
                                          subprotocols=["foxglove.sdk.v1"])
            break
        except OSError:
            if time.monotonic() > deadline:
                raise
            await asyncio.sleep(0.05)
    topics: dict[int, str] = {}
    async with ws:
        info["subprotocol"] = ws.subprotocol
        try:
            while time.monotonic() < deadline:
                msg = await asyncio.wait_for(ws.recv(), timeout=deadline - time.monotonic())
                if isinstance(msg, str):
                    op = json.loads(msg)
                    if op["op"] == "advertise":
                        subs = []
                        for ch in op["channels"]:
                            info.setdefault("advertised", {})[ch["topic"]] = ch
                            if ch["topic"] in WANTED:
                                topics[ch["id"]] = ch["topic"]
                                subs.append({"id": ch["id"], "channelId": ch["id"]})
                        if subs:
                            await ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
                    continue
                opcode, sub, _t = HEADER.unpack_from(msg)
                if opcode == MESSAGE_DATA:
                    got[topics[sub]].append(bytes(msg[HEADER.size:]))
        except (websockets.ConnectionClosed, TimeoutError):
            return  # the run ended: the server stopped


@pytest.mark.slow
def test_a_client_receives_the_camera_and_the_tree_while_the_mission_runs(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from rosbags.typesys import Stores, get_typestore

    port = _free_port()
    got: dict[str, list[bytes]] = defaultdict(list)
    info: dict[str, Any] = {}
    deadline = time.monotonic() + 120.0
    client = threading.Thread(target=lambda: asyncio.run(_client(port, got, info, deadline)))
    client.start()
    try:
        code = main(["run", str(SLALOM), "--tree", "none", "--realtime", "--max-time", "4",
                     "--report", str(tmp_path / "report.json"), "--foxglove", str(port)])
    finally:
        client.join(timeout=130)
    assert code == 1, capsys.readouterr().err  # the time limit: the route is not done in 4 s
    assert info["subprotocol"] == "foxglove.sdk.v1"
    advertised = info["advertised"]
    assert advertised["/marknav/tree"]["schemaEncoding"] == "ros2msg"
    assert advertised["/marknav/tree"]["encoding"] == "cdr"
    # images at 5 Hz and the tree every tick (20 Hz) for most of 4 s of wall-clock time
    assert len(got["/camera/image/compressed"]) >= 5
    assert len(got["/marknav/tree"]) >= 20
    store = get_typestore(Stores.ROS2_JAZZY)
    image = store.deserialize_cdr(got["/camera/image/compressed"][-1],
                                  "sensor_msgs/msg/CompressedImage")
    assert image.format == "jpeg" and bytes(image.data[:2]) == b"\xff\xd8"
    ticks = [json.loads(store.deserialize_cdr(raw, "std_msgs/msg/String").data)["tick"]
             for raw in got["/marknav/tree"]]
    assert ticks == sorted(ticks) and len(set(ticks)) == len(ticks)


def test_the_server_speaks_only_the_sdk_subprotocol() -> None:
    from websockets.exceptions import InvalidStatus

    from marknav.runs.views.foxglove_live import FoxgloveLive

    live = FoxgloveLive(0)

    async def connect(subprotocol: str) -> str:
        async with websockets.connect(f"ws://127.0.0.1:{live.port}",
                                      subprotocols=[subprotocol]) as ws:
            return json.loads(await asyncio.wait_for(ws.recv(), timeout=10))["op"]

    try:
        assert asyncio.run(connect("foxglove.sdk.v1")) == "serverInfo"
        with pytest.raises(InvalidStatus) as refused:
            asyncio.run(connect("foxglove.websocket.v1"))
        assert refused.value.response.status_code == 400
    finally:
        live.close()
