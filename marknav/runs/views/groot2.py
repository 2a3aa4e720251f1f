"""A Groot2 server: Groot2 (BehaviorTree.CPP's monitor) watches a running marknav mission.

Groot2 polls a ZeroMQ REP socket (BehaviorTree.CPP 4.10 ``loggers/groot2_protocol.h`` and
``groot2_publisher.cpp``). A request is one or two frames; the first is 6 bytes: ``u8``
protocol (2), ``u8`` type, ``u32`` request id (little-endian). The reply's first frame repeats
them (protocol 2) and adds the server's 16-byte tree UUID; the payload is the second frame:

- ``T``: the tree as BehaviorTree.CPP XML with ``_uid`` on every node
  (:mod:`marknav.runs.records.btcpp`);
- ``S``: 3 bytes a node, ``u16`` uid and ``u8`` status (0 idle, 1 running, 2 success,
  3 failure), in uid order;
- ``B`` (second request frame: tree names separated by ``;``): msgpack of
  ``{name: {entry: value}}``: the blackboard under the tree's ID, entries named as the node
  types' ports name them (``target`` for ``/marknav/target``).

Anything else gets BehaviorTree.CPP's error reply, ``["error", why]``: a wrong header, an
unknown type, and the breakpoint requests (``I``, ``R``, ``U``, ``A``, ``X``, ``D``, ``r``,
``t``) — marknav's server only watches; it never holds a node. The PUB socket on port + 1,
where BehaviorTree.CPP announces breakpoints, is bound so that Groot2 connects, and stays
silent.

The server answers on its own thread from the last tick's statuses, which the run loop hands
over as one immutable bytes object per tick (:meth:`Groot2Server.tick`, a Recorder sink), so a
client never waits for the loop and the loop never waits for a client. The blackboard is read
when asked for (its values are frozen, replaced whole by the behaviours). Like BehaviorTree.CPP,
the server counts a client silent for 5 s as gone (:attr:`Groot2Server.watched`); having no
breakpoints, it has nothing to undo then.
"""

from __future__ import annotations

import logging
import struct
import threading
import time
import uuid
from collections.abc import Callable
from typing import Any

from marknav.runs.records.btcpp import tree_xml
from marknav.runs.records.btlog import SKIPPED, STATUS_CODES
from marknav.runs.records.tree_state import TreeState

log = logging.getLogger(__name__)

#: Groot2's default port (BehaviorTree.CPP's ``Groot2Publisher``).
DEFAULT_PORT = 1667
PROTOCOL = 2
HEADER = struct.Struct("<BBI")
#: How long the server thread waits for a request before it checks whether to stop (s):
#: BehaviorTree.CPP's receive timeout, 100 ms.
RECEIVE_TIMEOUT_S = 0.1
#: A reply not taken within this time is dropped (BehaviorTree.CPP: 1 s).
SEND_TIMEOUT_S = 1.0
#: A client silent this long is gone (BehaviorTree.CPP's heartbeat, 5 s).
HEARTBEAT_S = 5.0
MS_PER_S = 1000
#: A ``B`` request's frames: the header and the names.
B_FRAMES = 2


def status_bytes(uids: list[bytes], status: list[str]) -> bytes:
    """The ``S`` payload: uid then status code, 3 bytes a node."""
    buf = bytearray(b"".join(u + b"\0" for u in uids))
    buf[2::3] = bytes([STATUS_CODES.get(s, SKIPPED) for s in status])
    return bytes(buf)


def _blackboard(tree_id: str) -> dict[str, Any]:
    """The marknav blackboard as plain values, under port names."""
    import py_trees

    from marknav.behaviours import keys
    from marknav.runs.records.btcpp import _port_name
    from marknav.runs.records.runlog import jsonable

    bb = py_trees.blackboard.Blackboard
    entries = {}
    for key in keys.ALL_KEYS:
        if bb.exists(key):
            entries[_port_name(key)] = jsonable(bb.get(key))
    return entries


class Groot2Server:
    """Serves one tree to Groot2 on ``tcp://host:port`` (REP's peer) and ``port + 1`` (PUB).

    ``blackboard(tree_id)`` gives the entries a ``B`` request returns (default: marknav's
    blackboard). Use as a Recorder sink: ``tick(now, record, frames, state)`` each tick,
    ``close()`` at the end.
    """

    def __init__(self, xml: str, tree_id: str, n_nodes: int, *, port: int = DEFAULT_PORT,
                 host: str = "127.0.0.1",
                 blackboard: Callable[[str], dict[str, Any]] = _blackboard) -> None:
        import zmq

        self.xml = xml.encode("utf-8")
        self.tree_id = tree_id
        self.uuid = uuid.uuid4().bytes
        self._uids = [struct.pack("<H", i) for i in range(1, n_nodes + 1)]
        self._status = status_bytes(self._uids, ["INVALID"] * n_nodes)
        self._template = bytearray(self._status)
        self._ticks = 0
        #: The last ``B`` reply and the tick it was made in: several requests in one tick
        #: (a Groot2 polling faster than the loop ticks) read the blackboard once.
        self._dumped: tuple[int, bytes, bytes] | None = None
        self._blackboard = blackboard
        self._last_request = time.monotonic() - HEARTBEAT_S
        self.requests = 0
        self.errors = 0
        #: CPU seconds the server's thread used, set when it ends.
        self.thread_cpu_s = 0.0
        self._stop = threading.Event()
        self._ctx = zmq.Context()
        # A ROUTER socket, not REP: it answers each request by its sender's identity, so a
        # client that sent garbage or left before its reply leaves no state behind (a REP
        # socket must alternate receive and send, and can be left waiting on a gone peer).
        self._rep = self._ctx.socket(zmq.ROUTER)
        self._pub = self._ctx.socket(zmq.PUB)
        for sock in (self._rep, self._pub):
            sock.setsockopt(zmq.LINGER, 0)
            sock.setsockopt(zmq.SNDTIMEO, round(SEND_TIMEOUT_S * MS_PER_S))
        self._rep.setsockopt(zmq.RCVTIMEO, round(RECEIVE_TIMEOUT_S * MS_PER_S))
        try:
            self._rep.bind(f"tcp://{host}:{port}")
            self._pub.bind(f"tcp://{host}:{port + 1}")
        except zmq.ZMQError:
            self._rep.close()
            self._pub.close()
            self._ctx.term()
            raise
        self.port = port
        self._thread = threading.Thread(target=self._serve, name="groot2", daemon=True)
        self._thread.start()
        log.info("Groot2 server on tcp://%s:%d (tree %s, %d nodes)", host, port, tree_id,
                 n_nodes)

    @classmethod
    def for_tree(cls, root: Any, tree_id: str, **kwargs: Any) -> Groot2Server:
        state = TreeState.of_tree(root)
        return cls(tree_xml(root, tree_id, builtin_models=True), tree_id, len(state.names),
                   **kwargs)

    # -- the run loop's side -----------------------------------------------------------------
    @property
    def watched(self) -> bool:
        """A client asked within the last 5 s."""
        return time.monotonic() - self._last_request < HEARTBEAT_S

    def update(self, status: list[str]) -> None:
        """The tree's statuses after a tick (pre-order, as :class:`TreeState` holds them):
        ~5 µs for a 55-node tree, so it is done every tick, watched or not."""
        codes = STATUS_CODES
        buf = self._template
        buf[2::3] = bytes([codes.get(s, SKIPPED) for s in status])
        self._status = bytes(buf)
        self._ticks += 1

    def tick(self, now: float, record: Any, frames: Any, state: TreeState) -> None:
        self.update(state.status)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=RECEIVE_TIMEOUT_S * 10)
        self._rep.close()
        self._pub.close()
        self._ctx.term()

    # -- the server thread -------------------------------------------------------------------
    def _serve(self) -> None:
        try:
            self._loop()
        finally:
            self.thread_cpu_s = time.thread_time()

    def _loop(self) -> None:
        import zmq

        while not self._stop.is_set():
            try:
                frames = self._rep.recv_multipart()
            except zmq.Again:
                continue
            except zmq.ZMQError:
                log.exception("Groot2 server: receive failed")
                return
            # A REQ client's request arrives as [identity, b"", frames...].
            try:
                split = frames.index(b"")
            except ValueError:
                continue  # not from a REQ socket: nobody to answer
            envelope, request = frames[:split + 1], frames[split + 1:]
            self._last_request = time.monotonic()
            self.requests += 1
            reply = self.answer(request)
            if reply[0] == b"error":
                self.errors += 1
            try:
                self._rep.send_multipart(envelope + reply, flags=zmq.NOBLOCK)
            except zmq.ZMQError as exc:  # the client left: its reply is dropped
                log.debug("Groot2 server: reply dropped (%s)", exc)

    def answer(self, request: list[bytes]) -> list[bytes]:
        """The reply frames to one request (BehaviorTree.CPP's, byte for byte)."""
        if not request or len(request[0]) != HEADER.size:
            return [b"error", b"wrong request header"]
        _protocol, kind, request_id = HEADER.unpack(request[0])
        head = HEADER.pack(PROTOCOL, kind, request_id) + self.uuid
        if kind == ord("T"):
            return [head, self.xml]
        if kind == ord("S"):
            return [head, self._status]
        if kind == ord("B"):
            if len(request) != B_FRAMES:
                return [b"error", b"must be 2 parts message"]
            return [head, self._dump(request[1])]
        return [b"error", b"Request not recognized"]

    def _dump(self, names: bytes) -> bytes:
        import msgpack

        ticks, cached = self._ticks, self._dumped
        if cached is not None and cached[0] == ticks and cached[1] == names:
            return cached[2]
        out: dict[str, Any] = {}
        for name in names.decode("utf-8", "replace").split(";"):
            if name == self.tree_id:
                out[name] = self._blackboard(name)
        packed = bytes(msgpack.packb(out))
        self._dumped = (ticks, names, packed)
        return packed
