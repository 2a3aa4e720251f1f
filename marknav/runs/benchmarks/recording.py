"""What the recording costs: the slalom's MCAP size, and the loop's speed with ``--record`` and
with ``--foxglove`` against without (``marknav bench recording``).

The three set-ups run interleaved, ``repeats`` times each, in this process (other work on a
shared machine then falls on all three alike); each figure is the median of its repeats.

- ``handover_share_of_loop_cpu``: the slowdown measured where it happens — the CPU time the
  loop spends handing each tick to the recording (the recorder's call and the queue's pickling
  on its feeder thread, thread CPU time) over the loop's own CPU time without it;
- ``loop_cpu_s``: the CPU time of marknav's own process, ``loop_thread_cpu_s`` of its main
  thread alone (the loop); ``recording_cpu_s``: of the recording's process (on the other core);
- ``wall_s`` and ``cycle_ms_p50`` (the control cycle's processing time: poll + tick): wall
  clock, which a loaded machine disturbs most.

Ratios are *with / without*: 1.05 is 5 % slower. With ``--foxglove`` a WebSocket client
(``websockets``, when installed, in a process of its own) subscribes to every channel, so the
server really sends.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import statistics
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from marknav.missions.schema import Mission

log = logging.getLogger(__name__)

SETUPS = ("plain", "record", "foxglove")
#: How long the benchmark's Foxglove client waits for the server, s.
CONNECT_TIMEOUT_S = 30.0


def _subscriber(port: int, ready: Any, stop: Any, results: Any) -> None:
    """A Foxglove client (in a process of its own: its CPU is not the loop's) subscribed to
    every channel until ``stop`` is set; puts what it got (messages, bytes) on ``results``."""
    counts: dict[str, float] = {}
    try:
        import websockets
        from websockets.typing import Subprotocol
    except ImportError:
        results.put(counts)
        return

    async def run() -> None:
        deadline = time.monotonic() + CONNECT_TIMEOUT_S
        ready.set()
        while True:  # the server starts with the run
            try:
                ws = await websockets.connect(f"ws://127.0.0.1:{port}",
                                              subprotocols=[Subprotocol("foxglove.sdk.v1")])
                break
            except OSError:
                if stop.is_set() or time.monotonic() > deadline:
                    return
                await asyncio.sleep(0.01)
        async with ws:
            while not stop.is_set():
                try:
                    msg = await asyncio.wait_for(ws.recv(), timeout=0.2)
                except TimeoutError:
                    continue
                except websockets.ConnectionClosed:
                    return
                if isinstance(msg, str):
                    op = json.loads(msg)
                    if op.get("op") == "advertise":
                        await ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                            {"id": ch["id"], "channelId": ch["id"]} for ch in op["channels"]]}))
                else:
                    counts["messages"] = counts.get("messages", 0) + 1
                    counts["bytes"] = counts.get("bytes", 0) + len(msg)

    asyncio.run(run())
    counts["cpu_s"] = time.process_time()  # this process's own: not the recording's
    results.put(counts)


@contextlib.contextmanager
def _handover_timed(spent: dict[str, float]) -> Iterator[None]:
    """While inside, the CPU time of what the loop does for the recording: the recorder's call
    (:meth:`Ros2Recording.tick`: the frame copy, the queue put) and the queue's pickling on its
    feeder thread (which holds the interpreter's lock), in ``spent`` (s, thread CPU time)."""
    from multiprocessing.reduction import ForkingPickler

    from marknav.runs.records.mcap_recording import Ros2Recording

    tick, dumps = Ros2Recording.tick, ForkingPickler.__dict__["dumps"]

    def timed_tick(self: Ros2Recording, *args: Any) -> None:
        t0 = time.thread_time()
        try:
            tick(self, *args)
        finally:
            spent["tick"] = spent.get("tick", 0.0) + time.thread_time() - t0

    def timed_dumps(cls: type, obj: Any, protocol: int | None = None) -> Any:
        t0 = time.thread_time()
        try:
            return dumps.__func__(cls, obj, protocol)
        finally:
            spent["pickle"] = spent.get("pickle", 0.0) + time.thread_time() - t0

    Ros2Recording.tick = timed_tick  # type: ignore[method-assign,assignment]
    ForkingPickler.dumps = classmethod(timed_dumps)  # type: ignore[assignment,method-assign]
    try:
        yield
    finally:
        Ros2Recording.tick = tick  # type: ignore[method-assign]
        ForkingPickler.dumps = dumps  # type: ignore[method-assign]


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _children_cpu_s() -> float:
    """CPU seconds of this process's finished children (the recording's process)."""
    import resource

    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return children.ru_utime + children.ru_stime


def _one(mission: Mission, setup: str, folder: Path, max_time_s: float,
         client: dict[str, float]) -> dict[str, float]:
    import multiprocessing

    from marknav.runs.loop.run import RunRequest, execute

    port = _free_port() if setup == "foxglove" else None
    req = RunRequest(mission=mission, max_time_s=max_time_s,
                     record_path=folder / f"{setup}.mcap" if setup == "record" else None,
                     foxglove_port=port)
    ctx = multiprocessing.get_context("spawn")
    ready, stop, results = ctx.Event(), ctx.Event(), ctx.Queue()
    subscriber = None
    if port is not None:
        subscriber = ctx.Process(target=_subscriber, args=(port, ready, stop, results),
                                 daemon=True)
        subscriber.start()
        ready.wait(CONNECT_TIMEOUT_S)  # trying to connect before the server starts
    children0 = _children_cpu_s()
    spent: dict[str, float] = {}
    cpu0, thread0 = time.process_time(), time.thread_time()
    try:
        with _handover_timed(spent):
            report = execute(req).report
    finally:
        loop_cpu = time.process_time() - cpu0
        loop_thread_cpu = time.thread_time() - thread0
        stop.set()
        got: dict[str, float] = {}
        if subscriber is not None:
            got = results.get(timeout=CONNECT_TIMEOUT_S)
            subscriber.join(timeout=CONNECT_TIMEOUT_S)
            for key in ("messages", "bytes"):
                client[key] = client.get(key, 0) + got.get(key, 0)
    recording_cpu = _children_cpu_s() - children0 - got.get("cpu_s", 0.0)
    out = {"wall_s": report.wall_time_s, "loop_cpu_s": loop_cpu,
           "loop_thread_cpu_s": loop_thread_cpu,
           "handover_cpu_s": spent.get("tick", 0.0) + spent.get("pickle", 0.0),
           "recording_cpu_s": recording_cpu,
           "cycle_ms_p50": float(report.tick_ms["p50"]), "sim_time_s": report.sim_time_s}
    if req.record_path is not None:
        out["bytes"] = float(req.record_path.stat().st_size)
        out["metadata_bytes"] = float(req.record_path.with_name("metadata.yaml").stat().st_size)
    return out


def bench_recording(*, mission: Mission | None = None, max_time_s: float = 60.0,
                    repeats: int = 3) -> dict[str, Any]:
    """The slalom (default) run ``repeats`` times each without a recording, with ``--record``
    and with ``--foxglove`` (and a subscribed client): size and speed ratios."""
    from marknav.runs.benchmarks.suite import default_slalom

    if repeats < 1:
        raise ValueError(f"repeats must be at least 1, got {repeats}")
    mission = mission if mission is not None else default_slalom()
    package = logging.getLogger("marknav")
    old = package.level
    package.setLevel(max(old, logging.ERROR))
    runs: dict[str, list[dict[str, float]]] = {s: [] for s in SETUPS}
    client: dict[str, float] = {}
    try:
        with tempfile.TemporaryDirectory(prefix="marknav-bench-") as tmp:
            for _ in range(repeats):
                for setup in SETUPS:
                    runs[setup].append(_one(mission, setup, Path(tmp), max_time_s, client))
    finally:
        package.setLevel(old)

    def median(setup: str, key: str) -> float:
        return float(statistics.median(r[key] for r in runs[setup]))

    out: dict[str, Any] = {"mission": mission.name, "repeats": repeats,
                           "sim_time_s": round(median("plain", "sim_time_s"), 2)}
    for setup in SETUPS:
        out[setup] = {k: round(median(setup, k), 3)
                      for k in ("wall_s", "loop_cpu_s", "loop_thread_cpu_s", "recording_cpu_s",
                                "cycle_ms_p50")}
        if setup != "plain":
            # what the loop itself does for the recording, as a share of the loop's CPU time:
            # the slowdown the recording causes, measured where it happens
            out[setup]["handover_share_of_loop_cpu"] = round(float(statistics.median(
                r["handover_cpu_s"] / max(r["loop_cpu_s"] - r["handover_cpu_s"], 1e-9)
                for r in runs[setup])), 4)
    out["record"]["mcap_mb"] = round(median("record", "bytes") / 1e6, 2)
    out["record"]["metadata_bytes"] = int(median("record", "metadata_bytes"))
    out["foxglove"]["client"] = ({"messages": int(client.get("messages", 0)) // repeats,
                                  "mb": round(client.get("bytes", 0) / repeats / 1e6, 2)}
                                 if client else "no client (websockets not installed)")
    for setup in ("record", "foxglove"):
        out[f"{setup}_over_plain"] = {
            k: round(median(setup, k) / max(median("plain", k), 1e-9), 3)
            for k in ("wall_s", "loop_cpu_s", "loop_thread_cpu_s", "cycle_ms_p50")}
        # Interference from other work only ever adds CPU time: the least of the repeats is
        # the figure least disturbed by a shared machine.
        least = min(r["loop_cpu_s"] for r in runs[setup])
        out[f"{setup}_over_plain"]["loop_cpu_s_least"] = round(
            least / max(min(r["loop_cpu_s"] for r in runs["plain"]), 1e-9), 3)
    return out
