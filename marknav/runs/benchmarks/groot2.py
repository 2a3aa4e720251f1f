"""``marknav bench groot2``: what Groot2 watching a run costs the run loop.

The simulated slalom runs as fast as the machine allows, in three arms taken in turn
(``repeats`` rounds, so a change in the machine's load falls on every arm alike): without the
Groot2 server; with it and no client; with it and a client that asks for the statuses 100 times
a second and for the blackboard every tenth time, as a Groot2 polling hard does.

The figures are CPU times, which other processes on a shared machine disturb far less than wall
times (given too, best round of each arm): the loop thread's CPU per control cycle in each arm
(the server's work is on its own thread, so this must not move), and the server's CPU per
request (its own thread's; ZeroMQ's I/O threads are C++ and never hold Python's lock). A
thread holds Python's lock for at most its CPU time, so at the mission's rate a 100 Hz client
can delay the loop by at most ``server_cpu_ms_per_cycle_at_rate`` per cycle:
``slowdown_bound_at_rate`` is that over the loop's own CPU per cycle. And measured directly:
in the polled arm the client polls for :data:`PHASE_S`, is silent as long, and so on;
``tick_slowdown_polling`` is the median tick in its polling phases over the median in its
silent ones (on a loaded machine this wall-clock ratio scatters widely, both ways).
"""

from __future__ import annotations

import logging
import socket
import struct
import threading
import time
from typing import Any

import numpy as np
import py_trees

from marknav.runs.views.groot2 import Groot2Server

#: How often the benchmark's client asks for the statuses (Hz), and every how many status
#: requests it asks for the blackboard.
POLL_HZ = 100.0
BLACKBOARD_EVERY = 10
#: The client polls for this long, then is silent as long, and so on (s): ticks in both kinds
#: of phase, close in time, see the same load from the machine's other processes.
PHASE_S = 0.25
#: Seconds the client waits for a reply before it counts the server gone.
REPLY_TIMEOUT_S = 0.5


def _free_port_pair() -> int:
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
    raise RuntimeError("no two free TCP ports in a row")


def _poll(port: int, stop: threading.Event, counts: list[int],
          phases: list[tuple[float, float, bool]]) -> None:
    import zmq

    ctx = zmq.Context()
    sock = ctx.socket(zmq.REQ)
    sock.setsockopt(zmq.RCVTIMEO, round(REPLY_TIMEOUT_S * 1000))
    sock.setsockopt(zmq.LINGER, 0)
    sock.connect(f"tcp://127.0.0.1:{port}")
    n = 0
    period = 1.0 / POLL_HZ
    due = time.monotonic()
    phase_start, polling = time.perf_counter(), True
    try:
        while not stop.is_set():
            now = time.perf_counter()
            if now - phase_start >= PHASE_S:  # alternate: polling, silent, polling...
                phases.append((phase_start, now, polling))
                phase_start, polling = now, not polling
            if not polling:
                time.sleep(period)
                due = time.monotonic()
                continue
            n += 1
            if n % BLACKBOARD_EVERY == 0:
                frames = [struct.pack("<BBI", 2, ord("B"), n), b"slalom"]
            else:
                frames = [struct.pack("<BBI", 2, ord("S"), n)]
            sock.send_multipart(frames)
            try:
                sock.recv_multipart()
            except zmq.Again:  # no server yet (or any more): a new socket, as Groot2 does
                sock.close()
                sock = ctx.socket(zmq.REQ)
                sock.setsockopt(zmq.RCVTIMEO, round(REPLY_TIMEOUT_S * 1000))
                sock.setsockopt(zmq.LINGER, 0)
                sock.connect(f"tcp://127.0.0.1:{port}")
                continue
            counts[0] += 1
            due += period
            time.sleep(max(0.0, due - time.monotonic()))
    finally:
        phases.append((phase_start, time.perf_counter(), polling))
        sock.close()
        ctx.term()


def _by_phase(ticks: list[tuple[float, float]],
              phases: list[tuple[float, float, bool]]) -> tuple[float | None, float | None]:
    """Median tick (ms) in the client's polling phases and in its silent ones."""
    out: dict[bool, list[float]] = {True: [], False: []}
    k = 0
    for start, duration in ticks:
        while k < len(phases) and phases[k][1] < start:
            k += 1
        if k < len(phases) and phases[k][0] <= start:
            out[phases[k][2]].append(1000.0 * duration)
    med = {p: float(np.median(v)) if v else None for p, v in out.items()}
    return med[True], med[False]


def _arm(mission: Any, max_time_s: float, groot2: bool, polled: bool) -> dict[str, Any]:
    from marknav.runs.loop.run import RunRequest, execute

    port = _free_port_pair()
    stop = threading.Event()
    counts = [0]
    phases: list[tuple[float, float, bool]] = []
    client = threading.Thread(target=_poll, args=(port, stop, counts, phases), daemon=True)
    if polled:
        client.start()
    servers: list[Groot2Server] = []
    close = Groot2Server.close

    def closing(server: Groot2Server) -> None:  # keep the server to read its figures
        close(server)
        servers.append(server)

    ticks: list[tuple[float, float]] = []
    tick = py_trees.trees.BehaviourTree.tick

    def timed_tick(tree: Any, *args: Any, **kwargs: Any) -> None:
        t0 = time.perf_counter()
        tick(tree, *args, **kwargs)
        ticks.append((t0, time.perf_counter() - t0))

    cpu0 = time.thread_time()
    setattr(Groot2Server, "close", closing)  # noqa: B010 (a method, wrapped for the run)
    setattr(py_trees.trees.BehaviourTree, "tick", timed_tick)  # noqa: B010
    try:
        report = execute(RunRequest(mission=mission, max_time_s=max_time_s,
                                    groot2=("127.0.0.1", port) if groot2 else None)).report
        cpu_s = time.thread_time() - cpu0
    finally:
        setattr(Groot2Server, "close", close)  # noqa: B010
        setattr(py_trees.trees.BehaviourTree, "tick", tick)  # noqa: B010
        stop.set()
        if polled:
            client.join()
    server_s = servers[0].thread_cpu_s if servers else 0.0
    cycles = max(1, report.ticks)
    polled_ms, silent_ms = _by_phase(ticks, phases)
    return {"server_cpu_ms": 1000.0 * server_s / cycles,
            "tick_ms_polled_phases": polled_ms, "tick_ms_silent_phases": silent_ms,
            "requests": servers[0].requests if servers else 0,
            "cycle_ms": 1000.0 * report.wall_time_s / cycles,
            "tick_ms_p50": report.tick_ms["p50"],
            "loop_cpu_ms": 1000.0 * cpu_s / cycles, "outcome": report.outcome,
            "cycles": report.ticks, "replies": counts[0],
            "replies_hz": counts[0] / report.wall_time_s if report.wall_time_s > 0 else 0.0}


def bench_groot2(*, max_time_s: float = 60.0, repeats: int = 3) -> dict[str, Any]:
    """The three arms' cycle times (ms, best of ``repeats``) and the client's slowdown."""
    from marknav.runs.benchmarks.suite import default_slalom

    mission = default_slalom()
    package = logging.getLogger("marknav")
    old = package.level
    package.setLevel(max(old, logging.ERROR))
    arms: dict[str, list[dict[str, Any]]] = {"no_server": [], "server": [], "polled": []}
    try:
        for _ in range(repeats):
            arms["no_server"].append(_arm(mission, max_time_s, groot2=False, polled=False))
            arms["server"].append(_arm(mission, max_time_s, groot2=True, polled=False))
            arms["polled"].append(_arm(mission, max_time_s, groot2=True, polled=True))
    finally:
        package.setLevel(old)
    loop = {k: min(r["loop_cpu_ms"] for r in v) for k, v in arms.items()}
    wall = {k: min(r["cycle_ms"] for r in v) for k, v in arms.items()}
    # The server thread's CPU per request (its idle wake-ups, every 100 ms, counted in).
    per_request = max(r["server_cpu_ms"] * r["cycles"] / max(1, r["requests"])
                      for r in arms["polled"])
    # At the mission's own rate, a 100 Hz client sends POLL_HZ / rate_hz requests a cycle; if
    # the server held the interpreter's lock for all of their CPU time, the loop would wait
    # that long: the bound of the slowdown.
    per_cycle = per_request * POLL_HZ / mission.control.rate_hz
    polled = [r["tick_ms_polled_phases"] for r in arms["polled"] if r["tick_ms_polled_phases"]]
    silent = [r["tick_ms_silent_phases"] for r in arms["polled"] if r["tick_ms_silent_phases"]]
    phase_ratio = (float(np.median(polled)) / float(np.median(silent))
                   if polled and silent else None)
    return {
        "sim_time_s": max_time_s,
        "repeats": repeats,
        "poll_hz": POLL_HZ,
        "replies_hz": round(max(r["replies_hz"] for r in arms["polled"]), 1),
        "loop_cpu_ms_per_cycle_no_server": round(loop["no_server"], 3),
        "loop_cpu_ms_per_cycle_server": round(loop["server"], 3),
        "loop_cpu_ms_per_cycle_polled": round(loop["polled"], 3),
        "server_cpu_ms_per_request": round(per_request, 4),
        "server_cpu_ms_per_cycle_at_rate": round(per_cycle, 4),
        "slowdown_bound_at_rate": round(per_cycle / loop["polled"], 4),
        # measured: the median tick while the client polls over the median while it is silent,
        # in the same runs (its phases alternate every PHASE_S)
        "tick_ms_polling": round(float(np.median(polled)), 3) if polled else None,
        "tick_ms_silent": round(float(np.median(silent)), 3) if silent else None,
        "tick_slowdown_polling": round(phase_ratio, 3) if phase_ratio else None,
        # wall figures: on a loaded machine the other processes move these most
        "cycle_ms_wall_no_server": round(wall["no_server"], 3),
        "cycle_ms_wall_server": round(wall["server"], 3),
        "cycle_ms_wall_polled": round(wall["polled"], 3),
    }
