"""``marknav serve-tree``: the behaviour tree in a web browser, without ROS.

One page, served on 127.0.0.1 with everything in it (no script or style from the network): the
tree drawn with each node's status, a timeline to scrub through the ticks, the blackboard and
the status panel of the tick shown. Two sources feed it:

- a run log (:class:`LogSource`): every tick's status changes, panel and blackboard writes;
- a live tree (:class:`LiveSource`): a Groot2 server polled as Groot2 polls it — ``marknav run
  --groot2`` or any BehaviorTree.CPP program with a ``Groot2Publisher`` — each change of status
  becoming a tick of the timeline.

The page reads ``/api/tree`` (names, kinds, parents) once and ``/api/ticks?since=K`` (the ticks
from K on: ``t``, ``n``, ``nodes`` ``{index: [status, message]}``, ``panel``, ``bb``) every
half second while the source is live.
"""

from __future__ import annotations

import json
import logging
import struct
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from typing import Any
from urllib.parse import parse_qs, urlparse

from marknav.runs.records.btcpp import read_tree_xml
from marknav.runs.records.tree_state import FAILURE, INVALID, RUNNING, SUCCESS

log = logging.getLogger(__name__)

#: How often the live source asks the Groot2 server for statuses (Hz): Groot2's own pace is of
#: this order, and a browser cannot show changes faster.
LIVE_POLL_HZ = 20.0
#: Seconds the live source waits for a reply before it reconnects.
LIVE_TIMEOUT_S = 1.0
#: Groot2 status codes (idle after X is 10 + X) as marknav's status names.
_GROOT2_STATUS = {0: INVALID, 1: RUNNING, 2: SUCCESS, 3: FAILURE, 4: INVALID}
_IDLE_AFTER = 10
#: A Groot2 reply's frames: its header and the payload.
REPLY_FRAMES = 2
#: Tags of BehaviorTree.CPP's composites, as the drawing's kinds.
_KINDS = {"Sequence": "sequence", "ReactiveSequence": "sequence", "SequenceWithMemory":
          "sequence", "Fallback": "selector", "ReactiveFallback": "selector",
          "Parallel": "parallel", "ParallelAll": "parallel"}
_BUILTIN_DECORATORS = {"Inverter", "ForceSuccess", "ForceFailure", "RetryUntilSuccessful",
                       "Repeat", "Timeout", "Delay", "RunOnce", "KeepRunningUntilFailure"}


class LogSource:
    """A recorded run: its tree and ticks, from the run log's records."""

    live = False

    def __init__(self, records: list[dict[str, Any]]) -> None:
        tree = next((r for r in records if r["kind"] == "tree"), None)
        if tree is None:
            raise ValueError("the run log has no tree record")
        self.tree = {k: tree["tree"][k] for k in ("names", "kinds", "parents")}
        self.title = str(tree.get("mission", {}).get("name", "run"))
        self._ticks = [{"t": r["t"], "n": r.get("n", i), "nodes": r.get("nodes", {}),
                        "panel": r.get("panel", {}), "bb": r.get("bb", {})}
                       for i, r in enumerate(x for x in records if x["kind"] == "tick")]

    def ticks(self, since: int) -> list[dict[str, Any]]:
        return self._ticks[since:]

    def close(self) -> None:
        pass


class LiveSource:
    """A live tree, read from a Groot2 server on ``host:port``; a tick per change."""

    live = True

    def __init__(self, host: str, port: int, *, tree_id: str | None = None) -> None:
        import zmq

        self._zmq = zmq
        self.address = f"tcp://{host}:{port}"
        self._ctx = zmq.Context()
        self._sock = self._socket()
        xml = self._request(b"T")
        if xml is None:
            self.close()
            raise ConnectionError(f"no Groot2 server answered on {host}:{port}")
        parsed = read_tree_xml(xml.decode("utf-8"))
        models = parsed["models"]
        self.tree_id = tree_id or str(parsed["id"])
        self.title = self.tree_id
        self._uids: list[int | None] = parsed["uids"]
        self.tree = {"names": parsed["names"], "parents": parsed["parents"],
                     "kinds": [_kind(tag, models.get(tag), parsed["parents"], i)
                               for i, tag in enumerate(parsed["tags"])]}
        self._ticks: list[dict[str, Any]] = []
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._t0 = time.monotonic()
        self._thread = threading.Thread(target=self._poll, name="serve-tree-live", daemon=True)
        self._thread.start()

    def _socket(self) -> Any:
        sock = self._ctx.socket(self._zmq.REQ)
        sock.setsockopt(self._zmq.RCVTIMEO, round(LIVE_TIMEOUT_S * 1000))
        sock.setsockopt(self._zmq.LINGER, 0)
        sock.connect(self.address)
        return sock

    def _request(self, kind: bytes, extra: bytes | None = None) -> bytes | None:
        frames = [struct.pack("<BBI", 2, kind[0], 1), *([extra] if extra is not None else [])]
        try:
            self._sock.send_multipart(frames)
            reply = self._sock.recv_multipart()
        except self._zmq.ZMQError:  # no answer in time: a new socket, as Groot2 does
            self._sock.close()
            self._sock = self._socket()
            return None
        ok = len(reply) == REPLY_FRAMES and reply[0] != b"error"
        return bytes(reply[1]) if ok else None

    def _poll(self) -> None:
        import msgpack

        index = {uid: i for i, uid in enumerate(self._uids) if uid is not None}
        last: dict[int, str] = {}
        while not self._stop.is_set():
            payload = self._request(b"S")
            if payload is not None:
                changes: dict[str, list[str]] = {}
                for k in range(0, len(payload) - 2, 3):
                    uid = struct.unpack_from("<H", payload, k)[0]
                    code = payload[k + 2]
                    status = _GROOT2_STATUS.get(code % _IDLE_AFTER if code >= _IDLE_AFTER
                                                else code, INVALID)
                    i = index.get(uid)
                    if i is not None and last.get(i) != status:
                        last[i] = status
                        changes[str(i)] = [status, ""]
                if changes:
                    board = self._request(b"B", self.tree_id.encode())
                    bb = msgpack.unpackb(board).get(self.tree_id) if board else None
                    with self._lock:
                        n = len(self._ticks)
                        self._ticks.append({"t": round(time.monotonic() - self._t0, 3),
                                            "n": n, "nodes": changes, "panel": {},
                                            "bb": bb or {}})
            self._stop.wait(1.0 / LIVE_POLL_HZ)

    def ticks(self, since: int) -> list[dict[str, Any]]:
        with self._lock:
            return list(self._ticks[since:])

    def close(self) -> None:
        stop = getattr(self, "_stop", None)
        if stop is not None:
            stop.set()
            self._thread.join(timeout=LIVE_TIMEOUT_S * 3)
        self._sock.close()
        self._ctx.term()


def _kind(tag: str, category: str | None, parents: list[int], i: int) -> str:
    if tag in _KINDS:
        return _KINDS[tag]
    if category == "Decorator" or tag in _BUILTIN_DECORATORS:
        return "decorator"
    if category == "Control" or any(p == i for p in parents):
        return "sequence"
    return "leaf"


def page_html() -> bytes:
    return resources.files("marknav.runs.views").joinpath("tree_page.html").read_bytes()


class TreePageServer:
    """The page and its two JSON endpoints for one source, on ``host:port`` (0: any free)."""

    def __init__(self, source: LogSource | LiveSource, *, host: str = "127.0.0.1",
                 port: int = 0) -> None:
        self.source = source
        page = page_html()
        src = source

        class Handler(BaseHTTPRequestHandler):
            def do_GET(self) -> None:
                url = urlparse(self.path)
                if url.path == "/":
                    self._send(200, "text/html; charset=utf-8", page)
                elif url.path == "/api/tree":
                    self._json({**src.tree, "title": src.title, "live": src.live})
                elif url.path == "/api/ticks":
                    try:
                        since = max(0, int(parse_qs(url.query).get("since", ["0"])[0]))
                    except ValueError:
                        self._send(400, "text/plain", b"since: not a number")
                        return
                    self._json(src.ticks(since))
                else:
                    self._send(404, "text/plain", b"not found")

            def _json(self, value: Any) -> None:
                self._send(200, "application/json", json.dumps(value).encode())

            def _send(self, code: int, kind: str, body: bytes) -> None:
                self.send_response(code)
                self.send_header("Content-Type", kind)
                self.send_header("Content-Length", str(len(body)))
                self.send_header("Cache-Control", "no-store")
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, format: str, *args: Any) -> None:
                log.debug("serve-tree: " + format, *args)

        self.httpd = ThreadingHTTPServer((host, port), Handler)
        self.httpd.daemon_threads = True
        self.port = int(self.httpd.server_address[1])
        self.url = f"http://{host}:{self.port}/"
        self._thread = threading.Thread(target=self.httpd.serve_forever, name="serve-tree",
                                        daemon=True)

    def start(self) -> TreePageServer:
        self._thread.start()
        return self

    def close(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()
        self.source.close()
