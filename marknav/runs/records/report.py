"""The run report (JSON) and the event log (JSON Lines), as the design brief specifies.

The event log is written line by line and flushed as events happen, and the report is written
in a ``finally`` block, so an aborted, failed or interrupted run loses nothing.

Report keys: ``outcome`` ("success" | "unverified" | "failed" | "aborted"; "unverified": every
waypoint passed, one or more of them without the robot's own confirmation), ``reason``,
``sim_time_s``, ``wall_time_s``, ``ticks``, ``waypoints: [{colour, side, outcome, passed_on,
min_clearance_mm, mark: {index, x_mm, y_mm}, truth, truth_detail, doubt, check}]``
(``outcome``: the robot's own verdict, "passed" | "doubtful" | "unverified" | "failed" |
"pending"; ``doubt``: why the bypass doubted the pass; ``check``: what looking back decided),
``collisions``,
``safety_events: [{t, event, state}]``, ``tick_ms: {p50, p99, max}``, ``overruns`` — plus
``mission``, ``seed``, ``robot``, ``camera``, ``speedup`` and, from the simulator, ``truth_path:
[[t, x_mm, y_mm], ...]``, and ``overrides``: the ``--set KEY=VALUE`` settings the run used on top of
the mission file; and ``range_law``: the range law learnt while driving; ``frame_latency_ms``: the
processed frames' measured age (capture to use).
"""

from __future__ import annotations

import contextlib
import json
import logging
import math
import os
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np

log = logging.getLogger(__name__)

SUCCESS = "success"
FAILED = "failed"
ABORTED = "aborted"

#: A waypoint's verdict when the robot passed it by odometry but its own sightings do not
#: confirm the pass (the waypoint's ``doubt`` says why).
DOUBTFUL = "doubtful"
#: A waypoint's verdict when the pass was doubtful and looking back at the mark did not decide
#: its side; also the run's outcome when every waypoint was passed but one of them doubtful or
#: unverified (not "success": the robot does not know it passed every mark on its side).
UNVERIFIED = "unverified"
#: The waypoint verdicts of a mark the robot went past: sure, or not.
PASSED_OUTCOMES = ("passed", DOUBTFUL, UNVERIFIED)
#: The waypoint verdicts of a pass the robot is not sure of.
UNSURE_OUTCOMES = (DOUBTFUL, UNVERIFIED)


@dataclass
class WaypointResult:
    colour: str
    side: str
    outcome: str = "pending"  # "passed" | "doubtful" | "unverified" | "failed" | "pending"
    passed_on: str | None = None  # from ground truth (simulator only)
    min_clearance_mm: float | None = None  # from ground truth (simulator only)
    # Simulator only: the course's physical mark for this waypoint ({index, x_mm, y_mm}) and the
    # ground truth's verdict: "passed" | "wrong_side" | "skipped" | "out_of_order" |
    # "off_course" (marknav.runs.metrics.truth), with a few words on what happened.
    mark: dict[str, Any] | None = None
    truth: str | None = None
    truth_detail: str = ""
    # Why the robot doubted its own pass after the bypass, else None.
    doubt: str | None = None
    # What looking back at a doubtful pass decided: "confirmed" (outcome "passed"), "refuted"
    # ("failed"), "unverified" ("unverified"); None: not checked.
    check: str | None = None


class _Judged(Protocol):
    @property
    def outcome(self) -> str: ...

    @property
    def truth(self) -> str | None: ...


def reached(waypoints: Sequence[_Judged]) -> int:
    """How many waypoints the run got to: up to the last one the tree declared passed or the
    ground truth found passed in some way. Later ones were never reached — not skipped, which
    means driving beyond a course mark without passing it."""
    last = 0
    for i, w in enumerate(waypoints, start=1):
        if w.outcome in PASSED_OUTCOMES or (w.truth is not None and w.truth != "skipped"):
            last = i
    return last


@dataclass
class RunReport:
    mission: str
    outcome: str = ABORTED
    reason: str = "not started"
    sim_time_s: float = 0.0
    wall_time_s: float = 0.0
    ticks: int = 0
    waypoints: list[WaypointResult] = field(default_factory=list)
    collisions: int = 0
    safety_events: list[dict[str, Any]] = field(default_factory=list)
    tick_ms: dict[str, float] = field(default_factory=lambda: {"p50": 0.0, "p99": 0.0, "max": 0.0})
    overruns: int = 0
    seed: int | None = None
    robot: str = "sim"
    camera: str = "sim"
    # The simulator engine ("builtin" or "mujoco"); None on real hardware.
    engine: str | None = "builtin"
    # Simulator only: the simulated Create after the run (wheels, OI mode): proof that the
    # wheels were stopped and the robot returned to Passive, whatever ended the run.
    sim_final: dict[str, Any] | None = None
    # The --set KEY=VALUE settings the mission ran with, on top of its file.
    overrides: list[str] = field(default_factory=list)
    # The range law perception learnt while driving (camera.learn_range), ready to paste.
    range_law: dict[str, Any] | None = None
    # Simulator only: the true path, [[t, x_mm, y_mm], ...] at 10 Hz, to re-check the truth.
    truth_path: list[list[float]] | None = None
    # The processed frames' age when processed (capture to tick), measured: {p50, p95, max,
    # frames}; plus frames_beyond_history: frames older than the pose history (placed with its
    # oldest pose).
    frame_latency_ms: dict[str, float] | None = None

    def set_frame_latencies(self, latency_s: Sequence[float], beyond_history: int = 0) -> None:
        if latency_s:
            ms = np.asarray(latency_s) * 1000.0
            self.frame_latency_ms = {
                "p50": round(float(np.percentile(ms, 50)), 1),
                "p95": round(float(np.percentile(ms, 95)), 1),
                "max": round(float(ms.max()), 1),
                "frames": len(ms),
                "frames_beyond_history": beyond_history,
            }

    @property
    def speedup(self) -> float | None:
        if self.wall_time_s <= 0:
            return None
        return self.sim_time_s / self.wall_time_s

    def set_tick_times(self, tick_s: list[float]) -> None:
        if tick_s:
            ms = np.asarray(tick_s) * 1000.0
            self.tick_ms = {
                "p50": round(float(np.percentile(ms, 50)), 3),
                "p99": round(float(np.percentile(ms, 99)), 3),
                "max": round(float(ms.max()), 3),
            }

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        s = self.speedup
        d["speedup"] = round(s, 2) if s is not None and math.isfinite(s) else None
        d["sim_time_s"] = round(self.sim_time_s, 3)
        d["wall_time_s"] = round(self.wall_time_s, 3)
        return d

    def write(self, path: str | Path) -> None:
        """Write the report (its folder must exist: see :mod:`marknav.core.outputs`). A regular
        file is replaced atomically; anything else (``/dev/stdout``) is written in place.
        Raises ``OSError`` if it cannot be written (ENOSPC, EACCES…)."""
        p = Path(path)
        text = json.dumps(self.to_dict(), indent=2) + "\n"
        if p.exists() and not p.is_file():
            with open(p, "w", encoding="utf-8") as fh:
                fh.write(text)
            return
        tmp = p.with_name(p.name + ".tmp")
        try:
            tmp.write_text(text, encoding="utf-8")
            tmp.replace(p)
        except OSError:
            tmp.unlink(missing_ok=True)
            raise


class EventLog:
    """Append-only JSON Lines log, each record written whole as it happens.

    Opening it raises ``OSError`` (check the path first: :mod:`marknav.core.outputs`). Each record
    is one ``os.write`` of one whole line (unbuffered: nothing waits in memory). A write that
    fails later (a full disk: ENOSPC, a file size limit: EFBIG) never stops the run: the part
    of the record that did reach the file is taken back (truncated), so the log ends with its
    last whole line, the log stops there, and :attr:`error` says why. Times never go
    backwards: an event stamped earlier than the one before it (a safety transition seen late)
    is written at the later time.
    """

    def __init__(self, path: str | Path | None) -> None:
        self.path = Path(path) if path is not None else None
        self._fd: int | None = None
        self._size = 0  # bytes of whole records written
        self.count = 0
        self.error: str | None = None
        self._last_t = 0.0
        if self.path is not None:
            self._fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC
                               | getattr(os, "O_CLOEXEC", 0), 0o666)

    def write(self, t: float, kind: str, **data: Any) -> None:
        self.count += 1
        if self._fd is None:
            return
        t = max(float(t), self._last_t)
        self._last_t = t
        record = {"t": round(t, 4), "kind": kind, **data}
        line = (json.dumps(record, default=str) + "\n").encode("utf-8")
        done = 0
        try:
            while done < len(line):  # one write, unless the file takes only part of it
                done += os.write(self._fd, line[done:])
        except OSError as exc:
            if done:  # a part of the line reached the file: take it back
                with contextlib.suppress(OSError):  # /dev/full cannot be truncated
                    os.ftruncate(self._fd, self._size)
            self._failed(exc)
            return
        self._size += len(line)

    def _failed(self, exc: OSError) -> None:
        self.error = f"cannot write the event log {self.path}: {exc.strerror or exc}"
        log.error("%s; the run goes on without it", self.error)
        fd, self._fd = self._fd, None
        if fd is not None:
            with contextlib.suppress(OSError):
                os.close(fd)

    def close(self) -> None:
        fd, self._fd = self._fd, None
        if fd is not None:
            try:
                os.close(fd)
            except OSError as exc:  # a network file system reports a lost write here
                self._failed(exc)

    def __enter__(self) -> EventLog:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
