"""The complete run log: everything a run saw and did, one JSON line per record, written as it
goes (each line flushed), so an aborted run keeps everything up to its abort.

Records (``t``: seconds since the run started, never decreasing; ``kind`` names the record):

- ``start`` (the runner): mission and environment.
- ``tree``: the tree's shape (``names``, ``kinds``, ``parents`` in pre-order), the mission
  (route, pass sides, clearance, colours) and, in the simulator, the world (marks, walls, boxes).
- ``tick`` (every tick): ``n``; ``nodes``: ``{index: [status, message]}`` for the nodes whose
  status or feedback changed; ``panel``: the live view's status figures (target, range, bearing,
  wheel speeds, safety state, marks in view, camera rate, frame latency, overruns); ``pose``:
  odometry ``[x_mm, y_mm, theta_rad]``; ``truth``: the simulator's true pose; ``bb``: the
  blackboard values behaviours wrote this tick (``/marknav/passed`` and ``/marknav/plans``:
  only the entries added).
- ``frame`` (each processed camera frame): ``index``, ``size``, ``captured_t`` (its capture
  time, run seconds), ``latency_ms`` (its age when processed), ``marks``: per detection the
  pixels (``x_px``, ``y_px``, ``axes_px``, ``angle_deg``) and the estimate (``forward_mm``,
  ``left_mm``, ``world``); ``image``: the JPEG file (relative to the log) when frames are saved.
- ``safety`` (the runner): each safety transition.
- ``status`` (the runner): the root's status when it changes.
- ``report``: the run report as written (ground truth included), the simulator's collision points
  and which world mark each waypoint was matched to.
- ``end`` (the runner): outcome and reason — also after Ctrl-C, a safety abort or a crash.

:func:`read_log` reads a log back; :class:`Replay` rebuilds the tree and panel at any tick.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import logging
import math
import stat
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import py_trees

from marknav.behaviours import keys
from marknav.core import signals
from marknav.core.errors import InputError
from marknav.core.inputfile import MAX_LOG_BYTES, read_bytes, stat_path
from marknav.runs.records.btcpp import tree_xml
from marknav.runs.records.report import EventLog, RunReport
from marknav.runs.records.tree_state import SUCCESS, TreeState

log = logging.getLogger(__name__)

#: Blackboard keys whose every new value is logged (frames and marks go in ``frame`` records).
LOGGED_KEYS = (keys.TARGET, keys.DRIVER, keys.RECOVERY, keys.KNOWN)
#: Keys that only grow: the entries added are logged.
APPENDED_KEYS = (keys.PASSED, keys.PLANS)


def jsonable(value: Any) -> Any:
    """A JSON-ready copy: dataclasses as dicts, tuples as lists, floats rounded, plans sampled."""
    if isinstance(value, float):
        return round(value, 3) if math.isfinite(value) else None
    if value is None or isinstance(value, (bool, int, str)):
        return value
    if isinstance(value, np.generic):
        return jsonable(value.item())
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    from marknav.planning.bezier import BypassPlan

    if isinstance(value, BypassPlan):
        return {"start": jsonable(value.start_pose), "end": jsonable(value.end_pose),
                "mark_xy": jsonable(value.mark_xy), "side": value.side,
                "clearance_mm": jsonable(value.clearance_mm),
                "points": [[round(float(x), 1), round(float(y), 1)]
                           for x, y in value.sample(50.0)]}
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: jsonable(getattr(value, f.name)) for f in dataclasses.fields(value)}
    return str(value)


def _pose(p: Any) -> list[float]:
    return [round(float(p.x), 1), round(float(p.y), 1), round(float(p.theta), 4)]


class Recorder:
    """Watches a run tick by tick: feeds the run log, the live view and the Rerun recording.

    ``view`` (a :mod:`~marknav.runs.views.display` view) and ``sinks`` (objects with
    ``tick(record, frame_image)`` and ``close()``, e.g. the Rerun recording) are optional;
    ``frames_hz`` saves camera frames as JPEG files beside the log at most that often.
    """

    def __init__(
        self,
        root: py_trees.behaviour.Behaviour,
        env: Any,
        events: EventLog,
        *,
        mission: Any = None,
        view: Any = None,
        sinks: Sequence[Any] = (),
        frames_hz: float | None = None,
        finish: Callable[[RunReport], dict[str, Any]] | None = None,
    ) -> None:
        self.root = root
        self.env = env
        self.events = events
        self.mission = mission
        self.view = view
        self.sinks = list(sinks)
        self.frames_hz = frames_hz
        self._finish = finish
        self.state = TreeState.of_tree(root)
        self.n = 0
        self._t0: float | None = None
        self._last_bb: dict[str, Any] = {}
        self._perceptions: list[Any] | None = None
        self._last_frame: dict[int, int] = {}
        self._frame_times: deque[float] = deque(maxlen=40)
        self._last_saved: float | None = None
        self._frames_lost = False  # a frame could not be written: no more are tried
        self._started = False
        self.logging = events.path is not None or bool(self.sinks)
        #: What :meth:`show` draws and sends: the last tick's panel, record and frames.
        self._shown: tuple[float, dict[str, Any], dict[str, Any] | None,
                           list[tuple[dict[str, Any], Any]]] | None = None

    # -- called by the runner ----------------------------------------------------------------
    def tick(self, now: float, overruns: int) -> None:
        """After each tick: ``now`` is run time (s), ``overruns`` so far. Writes the tick's
        records to the run log (the runner holds signals off meanwhile); :meth:`show` then
        draws it."""
        if not self._started:
            self._started = True
            self._begin(now)
        changes = self.state.capture(now)
        frames = self._frames(now)
        panel = self.panel(now, overruns)
        record: dict[str, Any] | None = None
        if self.logging:
            record = {"n": self.n, "nodes": changes, "panel": panel}
            robot = self.env.robot
            record["pose"] = _pose(robot.pose())
            create = getattr(self.env, "create", None)
            if create is not None:
                record["truth"] = _pose(create.pose)
            bb = self._blackboard()
            if bb:
                record["bb"] = bb
            # A tick's frames and the tick itself go in together: a signal cannot split them.
            with signals.deferred():
                for fr, image in frames:
                    self._save_image(now, fr, image)
                    self.events.write(now, "frame", **fr)
                self.events.write(now, "tick", **record)
        self._shown = (now, panel, record, frames)
        self.n += 1

    def show(self) -> None:
        """The last tick on the live view and the sinks (the viewer). Outside the runner's
        signal hold: a terminal or a viewer that blocks cannot keep Ctrl-C from stopping the
        wheels."""
        if self._shown is None:
            return
        panel = self._shown[1]
        self._feed_sinks()
        if self.view is not None:
            self.view.update(self.state, panel)

    def finish(self, report: RunReport) -> None:
        """Before the runner's ``end`` record: the report, with ground truth when there is some."""
        if self.view is not None:
            self.view.close()
        # A signal between a tick's records and its showing: the recording still gets it (a
        # sink that already had it, cut short inside, knows the tick by its number).
        self._feed_sinks()
        extra = self._finish(report) if self._finish is not None else {}
        if self.logging:
            self.events.write(report.sim_time_s, "report", report=report.to_dict(), **extra)
        for sink in self.sinks:
            try:
                sink.close()
            except Exception:
                log.exception("closing %s failed", sink)

    def _feed_sinks(self) -> None:
        """The last tick to the sinks, once: ``_shown`` is cleared only when all have it."""
        if self._shown is None:
            return
        now, _panel, record, frames = self._shown
        if record is not None:
            for sink in self.sinks:
                sink.tick(now, record, frames, self.state)
        self._shown = None

    # -- the status panel --------------------------------------------------------------------
    def panel(self, now: float, overruns: int) -> dict[str, Any]:
        """The figures of the status panel, as plain values (also logged every tick)."""
        bb = py_trees.blackboard.Blackboard
        robot = self.env.robot
        out: dict[str, Any] = {"t": round(now, 3), "tick": self.n}
        if self.root.status.value == SUCCESS:
            out["target"] = "none: every waypoint passed"
        else:
            target = bb.get(keys.TARGET) if bb.exists(keys.TARGET) else None
            if target is not None:
                out["target"] = f"{target.label}, pass on its {target.side}"
                s = target.sighting
                if s is None:
                    out["target"] += (" (out of view, remembered)" if target.remembered
                                      else " (not in view)")
                else:
                    out["range_mm"] = round(s.range_mm, 0)
                    out["bearing_deg"] = round(math.degrees(s.bearing_rad), 1)
                    # as Seen? counts it: 0 when the newest frame shows it (capture times
                    # on both sides, so the camera's latency is no age)
                    frame_now = bb.get(keys.FRAME) if bb.exists(keys.FRAME) else None
                    out["seen_s_ago"] = round(keys.unseen_s(s, frame_now,
                                                            now + (self._t0 or 0.0)), 2)
        safety = getattr(robot, "safety", None)
        wheels = getattr(safety, "wheels", None)
        if wheels is not None:
            out["wheels_mm_s"] = [int(wheels[0]), int(wheels[1])]
        out["safety"] = robot.safety_state
        marks = bb.get(keys.MARKS) if bb.exists(keys.MARKS) else ()
        out["marks"] = [f"{m.colour} {m.range_mm / 1000.0:.2f} m" for m in marks[:4]]
        if len(marks) > 4:
            out["marks"].append(f"+{len(marks) - 4}")
        ft = self._frame_times
        out["camera_hz"] = (round((len(ft) - 1) / (ft[-1] - ft[0]), 1)
                            if len(ft) > 2 and ft[-1] > ft[0] else None)
        frame = bb.get(keys.FRAME) if bb.exists(keys.FRAME) else None
        if frame is not None:
            out["latency_ms"] = round(1000.0 * frame.latency_s, 1)
        out["overruns"] = overruns
        out["active"] = (self.state.active_path().split(" / ")[-1]
                         if self.root.status.value == "RUNNING" else "finished")
        return out

    # -- internals ---------------------------------------------------------------------------
    def _begin(self, now: float) -> None:
        self._t0 = self.env.clock.now() - now
        if not self.logging:
            return
        info: dict[str, Any] = {"tree": self.state.structure()}
        # Groot2's view of the same tree, and the wall-clock start: 'replay --btlog' needs both.
        info["btcpp_xml"] = tree_xml(self.root, getattr(self.mission, "name", "MainTree"))
        info["epoch_us"] = round((time.time() - now) * 1_000_000)
        m = self.mission
        if m is not None:
            from marknav.sim.builtin_camera import mark_bgr

            info["mission"] = {
                "name": m.name, "route": list(m.route),
                "sides": [m.side_of(c) for c in m.route],
                "clearance_mm": m.navigation.clearance_mm,
                "mark_radius_mm": m.marks.radius_mm,
                "colours": {c.name: [int(v) for v in np.asarray(mark_bgr(c)).reshape(-1)[:3]]
                            for c in m.palette()},
            }
        world = getattr(self.env, "world", None)
        if world is not None:
            radius = m.marks.radius_mm if m is not None else 100.0
            info["world"] = {
                "marks": [{"colour": k.colour, "xy": list(k.xy), "radius_mm": k.radius(radius)}
                          for k in world.marks],
                "walls": [[*w.segment()[0], *w.segment()[1]] for w in world.walls],
                "boxes": [[list(c) for c in b.corners()] for b in world.boxes],
            }
        self.events.write(now, "tree", **jsonable(info))

    def _blackboard(self) -> dict[str, Any]:
        bb = py_trees.blackboard.Blackboard
        out: dict[str, Any] = {}
        for key in LOGGED_KEYS:
            value = bb.get(key) if bb.exists(key) else None
            if value is not self._last_bb.get(key):
                self._last_bb[key] = value
                out[key] = jsonable(value)
        for key in APPENDED_KEYS:
            value = bb.get(key) if bb.exists(key) else ()
            last = self._last_bb.get(key, ())
            if value is not last:
                self._last_bb[key] = value
                added = value[len(last):] if value[:len(last)] == last else value
                if added:
                    out[key] = jsonable(added)
        return out

    def _frames(self, now: float) -> list[tuple[dict[str, Any], Any]]:
        """New camera frames the perception nodes processed this tick: (record, image)."""
        if self._perceptions is None:
            self._perceptions = [n for n in self.root.iterate() if hasattr(n, "last_frame")]
        out = []
        for node in self._perceptions:
            frame = node.last_frame
            if frame is None or self._last_frame.get(id(node)) == frame.index:
                continue
            self._last_frame[id(node)] = frame.index
            self._frame_times.append(now)
            if not self.logging:
                continue
            bb = py_trees.blackboard.Blackboard
            seen = bb.get(keys.MARKS) if bb.exists(keys.MARKS) else ()
            found = list(getattr(node, "last_detections", ()))
            marks = []
            for k, det in enumerate(found):
                d: dict[str, Any] = {"colour": det.colour, "x_px": round(det.x, 1),
                                     "y_px": round(det.y, 1),
                                     "axes_px": [round(a, 1) for a in det.axes],
                                     "angle_deg": round(det.angle_deg, 1)}
                if len(seen) == len(found):
                    s = seen[k]
                    d.update(forward_mm=round(s.forward_mm, 1), left_mm=round(s.left_mm, 1),
                             range_mm=round(s.range_mm, 1),
                             world=[round(s.world_x, 1), round(s.world_y, 1)])
                marks.append(d)
            h, w = frame.image.shape[:2]
            record = {"index": frame.index, "size": [w, h], "marks": marks}
            info = bb.get(keys.FRAME) if bb.exists(keys.FRAME) else None
            if info is not None and info.index == frame.index:  # capture time, age when used
                record["captured_t"] = round(info.t - (self._t0 or 0.0), 4)
                record["latency_ms"] = round(1000.0 * info.latency_s, 1)
            out.append((record, frame.image))
        return out

    def _save_image(self, now: float, record: dict[str, Any], image: Any) -> None:
        if self.frames_hz is None or self.events.path is None or self._frames_lost:
            return
        if self._last_saved is not None and now - self._last_saved < 1.0 / self.frames_hz - 1e-9:
            return
        import cv2

        folder = self.events.path.parent / (self.events.path.name.split(".")[0] + ".frames")
        name = f"{record['index']:06d}.jpg"
        ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 85])
        if not ok:
            return
        try:
            folder.mkdir(parents=True, exist_ok=True)
            (folder / name).write_bytes(data.tobytes())
        except OSError as exc:  # a full disk, a quota, a removed folder: the run goes on
            with contextlib.suppress(OSError):  # half a file is no frame
                (folder / name).unlink(missing_ok=True)
            # Said once; the frames are a by-product of the run: losing them must not end it.
            log.warning("cannot save camera frames in %s (%s): no more frames are saved; the "
                        "run goes on", folder, exc.strerror or exc)
            self._frames_lost = True
            return
        record["image"] = f"{folder.name}/{name}"
        self._last_saved = now


# -- reading a log back ----------------------------------------------------------------------

def resolve_log(path: str | Path) -> Path:
    """A run folder (its ``*.events.jsonl``) or a log file; InputError when there is none."""
    p = Path(path)
    st = stat_path(p, field="RUN")
    if st is not None and stat.S_ISDIR(st.st_mode):
        found = sorted(p.glob("*.events.jsonl"))
        if not found:
            raise InputError("no run log (*.events.jsonl) in this folder", file=str(p))
        return found[0]
    if st is None:
        raise InputError("no such file or folder", file=str(p))
    return p  # read_log refuses anything but a regular file, without blocking


def read_log(path: str | Path) -> list[dict[str, Any]]:
    """Every record of a run log; InputError naming FILE:LINE for a line that is not JSON."""
    p = resolve_log(path)
    data = read_bytes(p, limit=MAX_LOG_BYTES, what="a run log")
    lines = data.split(b"\n")
    out = []
    for lineno, raw in enumerate(lines, start=1):
        last = lineno == len(lines)  # no newline after it: written last, maybe cut short
        if not raw.strip():
            continue
        try:
            rec = json.loads(raw.decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            if lineno > 1 and last:
                break  # the last line of a log cut short (power loss): keep the rest
            why = exc.msg if isinstance(exc, json.JSONDecodeError) else "not UTF-8 text"
            raise InputError(f"not a run-log line: {why}", file=str(p), line=lineno) from None
        if not isinstance(rec, dict) or "kind" not in rec or "t" not in rec:
            raise InputError("not a run-log record (needs 't' and 'kind')", file=str(p),
                             line=lineno)
        out.append(rec)
    return out


class Replay:
    """A recorded run, tick by tick: the tree's statuses and the status panel at any tick."""

    def __init__(self, records: list[dict[str, Any]]) -> None:
        self.records = records
        tree = next((r for r in records if r["kind"] == "tree"), None)
        if tree is None:
            raise InputError("this log has no tree record (written by an older marknav, or "
                             "the run ended before its first tick)")
        self.info = tree
        self.ticks = [r for r in records if r["kind"] == "tick"]
        if not self.ticks:
            raise InputError("this log has no ticks")
        self.times = [float(r["t"]) for r in self.ticks]
        self.end = next((r for r in reversed(records) if r["kind"] == "end"), None)
        self.report = next((r for r in reversed(records) if r["kind"] == "report"), None)

    def __len__(self) -> int:
        return len(self.ticks)

    def state_at(self, k: int) -> TreeState:
        """The tree after tick ``k`` (0-based), rebuilt from the changes of ticks 0..k."""
        state = TreeState.from_structure(self.info["tree"])
        for rec in self.ticks[:k + 1]:
            state.apply(rec.get("nodes", {}))
        return state

    def states(self) -> Iterator[tuple[dict[str, Any], TreeState]]:
        """Each tick record with the tree after it (one state, updated in place)."""
        state = TreeState.from_structure(self.info["tree"])
        for rec in self.ticks:
            state.apply(rec.get("nodes", {}))
            yield rec, state

    def index_at(self, t: float) -> int:
        """The last tick at or before time ``t`` (the first tick if ``t`` is earlier)."""
        k = int(np.searchsorted(np.asarray(self.times), t, side="right")) - 1
        return max(0, min(k, len(self.ticks) - 1))

    def next_change(self, k: int) -> int:
        """The next tick after ``k`` where a node's status changed (the last tick if none)."""
        state = self.state_at(k)
        for j in range(k + 1, len(self.ticks)):
            nodes = self.ticks[j].get("nodes", {})
            if any(state.status[int(i)] != v[0] for i, v in nodes.items()):
                return j
            state.apply(nodes)
        return len(self.ticks) - 1

    def records_of(self, kind: str) -> list[dict[str, Any]]:
        return [r for r in self.records if r["kind"] == kind]
