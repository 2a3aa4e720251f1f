"""A run in the Rerun viewer (``rerun-sdk``, the ``viewer`` extra): live, or from a run log.

The run's one recording is the MCAP file of ``marknav run --record``
(:mod:`marknav.runs.records.mcap_recording`), which Rerun opens itself (``marknav view``);
this module streams a run to a spawned viewer (``--viewer``), or a run log that has no recording.

Entities (timeline ``run``: seconds since the run started; ``tick``: the tick number):

- ``camera/image``: processed camera frames, JPEG-compressed (``rr.EncodedImage``), at most
  ``frames_hz`` a second of run time (:data:`RECORD_FRAMES_HZ` by default: the tree ticks at
  20 Hz and an image per tick made a 41 s run 22 MB); ``camera/detections``: the ellipses
  detected in the frame shown, labelled with colour and estimated range (logged with each
  image, so they always match the picture under them);
- ``map/marks`` (the world's marks, simulator), ``map/walls``, ``map/boxes``; ``map/robot``
  (odometry, every tick), ``map/truth`` (the simulator's true pose), ``map/path/*`` (the driven
  path), ``map/plan/*`` (each bypass plan, odometry frame), ``map/seen`` (marks placed from the
  latest frame);
  Rerun's 2D views draw y downwards, so the map is logged with y negated (north is up on
  screen, and a mark passed on its left looks it);
- ``plots/range_mm``, ``plots/bearing_deg``, ``plots/wheels/left``, ``plots/wheels/right``;
- ``tree`` (the compact tree and the status panel as text, at every status change and otherwise
  at the image rate), ``events`` (status and safety changes).

Rerun's SDK and viewer send anonymous usage data unless told not to; marknav sets
``RERUN_ANALYTICS=0`` before it loads the SDK or starts the viewer (set ``RERUN_ANALYTICS=1``
yourself to allow it).
"""

from __future__ import annotations

import logging
import os
import sys
from pathlib import Path
from typing import Any

from marknav.core.errors import InputError
from marknav.core.inputfile import MAX_IMAGE_BYTES, read_bytes
from marknav.runs.records.tree_state import TreeState
from marknav.runs.views.display import status_text

log = logging.getLogger(__name__)

EXTRA_HINT = "pip install 'marknav[viewer]'"
#: Points per driven-path strip (the path is logged as growing strips of this many points).
PATH_CHUNK = 100
#: Camera frames per second of run time kept in a recording unless ``--frames`` says otherwise:
#: enough to follow a mark through a bypass (the search turns at 40 °/s: 8 ° between images);
#: the 41 s slalom run then records 4.9 MB (every frame at 20 Hz: 22.7 MB).
RECORD_FRAMES_HZ = 5.0
#: JPEG quality (0..100) of frames that arrive unencoded: a noisy simulated 640×480 frame is
#: ~20 kB at 70, ~34 kB at 80, ~75 kB at 90; a mark's rim stays clear to the eye at 70.
RECORD_JPEG_QUALITY = 70


def require_rerun(option: str) -> Any:
    """Import rerun with analytics off; InputError (exit 2) naming the extra when missing."""
    os.environ.setdefault("RERUN_ANALYTICS", "0")
    try:
        import rerun as rr
    except ImportError:
        raise InputError(f"needs the Rerun SDK, which is not installed: {EXTRA_HINT}",
                         field=option) from None
    return rr


def require_display(option: str) -> None:
    """The viewer is a desktop window: InputError (exit 2) on a Linux machine without one."""
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY")
                                                 or os.environ.get("WAYLAND_DISPLAY")):
        then = ("open the recording where there is one, or in Foxglove or Lichtblick"
                if option == "view" else
                "save a recording with --record FILE.mcap and open it with "
                "'marknav view FILE.mcap' where there is one")
        raise InputError("the Rerun viewer needs a display (neither DISPLAY nor WAYLAND_DISPLAY "
                         f"is set); {then}", field=option)


def _up(xy: Any) -> list[float]:
    """World (x, y) for a 2D view whose y points down: north up on screen."""
    return [float(xy[0]), -float(xy[1])]


def _blueprint(rr: Any) -> Any:
    rrb = rr.blueprint
    return rrb.Blueprint(rrb.Horizontal(
        rrb.Vertical(rrb.Spatial2DView(origin="camera", name="camera"),
                     rrb.TimeSeriesView(origin="plots", name="range, bearing, wheels")),
        rrb.Spatial2DView(origin="map", name="map (north up)"),
        rrb.Vertical(rrb.TextDocumentView(origin="tree", name="tree"),
                     rrb.TextLogView(origin="events", name="events")),
        column_shares=[2, 2, 2]))


def _rgb(bgr: Any) -> list[int]:
    b, g, r = (int(v) for v in bgr[:3])
    return [r, g, b]


class RerunSink:
    """Streams a run to a spawned viewer (``spawn``; else to no sink: tests count what it
    logs); fed by the run recorder or a run log."""

    def __init__(self, mission: Any, world: Any, *, spawn: bool = False,
                 colours: dict[str, list[int]] | None = None,
                 frames_hz: float | None = RECORD_FRAMES_HZ,
                 jpeg_quality: int = RECORD_JPEG_QUALITY) -> None:
        """``frames_hz``: at most this many camera images per second of run time (``None``:
        every frame); ``jpeg_quality``: 0..100 for frames that arrive unencoded."""
        if frames_hz is not None and not frames_hz > 0:
            raise ValueError(f"frames_hz must be positive or None, got {frames_hz}")
        if not 0 <= jpeg_quality <= 100:
            raise ValueError(f"jpeg_quality must be in 0..100, got {jpeg_quality}")
        rr = require_rerun("--viewer" if spawn else "view")
        self.rr = rr
        self.rec = rr.RecordingStream("marknav")
        if spawn:
            # The viewer process inherits RERUN_ANALYTICS=0 from this process.
            self.rec.spawn(connect=False)
            try:
                self.rec.set_sinks(rr.GrpcSink(), default_blueprint=_blueprint(rr))
            except Exception as exc:
                raise InputError(f"cannot start the viewer: {exc}") from None
        self.colours = dict(colours or {})
        if mission is not None and not self.colours:
            from marknav.sim.builtin_camera import mark_bgr

            self.colours = {c.name: _rgb(list(mark_bgr(c))) for c in mission.palette()}
        self.frames_hz = frames_hz
        self.jpeg_quality = jpeg_quality
        self._last_image_t: float | None = None
        self._last_tree_t: float | None = None
        self.frames = 0
        self.images = 0
        self.ticks = 0
        self._path: list[list[float]] = []
        self._plans = 0
        self._last_status: tuple[str, ...] | None = None
        self._static(mission, world)

    # -- static scene ------------------------------------------------------------------------
    def _static(self, mission: Any, world: Any) -> None:
        if world is None:
            return
        radius = mission.marks.radius_mm if mission is not None else 100.0
        self.static_world({
            "marks": [{"colour": m.colour, "xy": list(m.xy), "radius_mm": m.radius(radius)}
                      for m in world.marks],
            "walls": [[*w.segment()[0], *w.segment()[1]] for w in world.walls],
            "boxes": [[list(c) for c in b.corners()] for b in world.boxes],
        })

    def static_world(self, world: dict[str, Any]) -> None:
        rr, rec = self.rr, self.rec
        marks = world.get("marks", [])
        if marks:
            rec.log("map/marks", rr.Ellipses2D(
                centers=[_up(m["xy"]) for m in marks],
                half_sizes=[[m["radius_mm"], m["radius_mm"]] for m in marks],
                colors=[self.colours.get(m["colour"], [128, 128, 128]) for m in marks],
                labels=[f"{i + 1}: {m['colour']}" for i, m in enumerate(marks)]), static=True)
        if world.get("walls"):
            rec.log("map/walls", rr.LineStrips2D(
                [[_up(w[:2]), _up(w[2:])] for w in world["walls"]], colors=[[90, 90, 90]]),
                static=True)
        if world.get("boxes"):
            rec.log("map/boxes", rr.LineStrips2D(
                [[_up(c) for c in [*b, b[0]]] for b in world["boxes"]],
                colors=[[160, 160, 160]]), static=True)

    # -- per tick ----------------------------------------------------------------------------
    def tick(self, now: float, record: dict[str, Any], frames: list[tuple[dict[str, Any], Any]],
             state: TreeState) -> None:
        rr, rec = self.rr, self.rec
        rec.set_time("run", duration=now)
        rec.set_time("tick", sequence=int(record.get("n", self.ticks)))
        for fr, image in frames:
            self._frame(now, fr, image)
        pose = record.get("pose")
        if pose is not None:
            rec.log("map/robot", rr.Points2D([_up(pose)], radii=[60.0], colors=[[30, 30, 30]]))
            self._path.append(_up(pose))
            k = (len(self._path) - 1) // PATH_CHUNK
            if len(self._path) % 5 == 0 or len(self._path) % PATH_CHUNK == 1:
                strip = self._path[k * PATH_CHUNK - (1 if k else 0):]
                rec.log(f"map/path/{k}", rr.LineStrips2D([strip], colors=[[0, 0, 0]]))
        truth = record.get("truth")
        if truth is not None:
            rec.log("map/truth", rr.Points2D([_up(truth)], radii=[40.0], colors=[[0, 160, 0]]))
        for plan in record.get("bb", {}).get("/marknav/plans", []):
            pts = plan.get("plan", {}).get("points", [])
            if pts:
                rec.log(f"map/plan/{self._plans}", rr.LineStrips2D(
                    [[_up(p) for p in pts]], colors=[[148, 0, 211]],
                    labels=[f"#{plan.get('waypoint', -1) + 1} {plan.get('reason', '')}"]))
                self._plans += 1
        panel = record.get("panel", {})
        if "range_mm" in panel:
            rec.log("plots/range_mm", rr.Scalars(float(panel["range_mm"])))
            rec.log("plots/bearing_deg", rr.Scalars(float(panel.get("bearing_deg", 0.0))))
        wheels = panel.get("wheels_mm_s")
        if wheels is not None:
            rec.log("plots/wheels/left", rr.Scalars(float(wheels[0])))
            rec.log("plots/wheels/right", rr.Scalars(float(wheels[1])))
        status = tuple(state.status)
        changed = status != self._last_status
        if changed or self._tree_due(now):
            # Every status change, and the panel's figures between changes at the image rate
            # (they are also plotted every tick): the text every tick was a quarter of the file.
            self._last_tree_t = now
            text = (state.text(style="unicode", max_rows=60) + "\n\n"
                    + "\n".join(status_text(panel)))
            rec.log("tree", rr.TextDocument(text))
        if changed:
            self._last_status = status
            rec.log("events", rr.TextLog(state.active_path(), level="INFO"))
        self.ticks += 1

    def event(self, now: float, text: str, level: str = "WARN") -> None:
        self.rec.set_time("run", duration=now)
        self.rec.log("events", self.rr.TextLog(text, level=level))

    def _tree_due(self, now: float) -> bool:
        if self.frames_hz is None or self._last_tree_t is None:
            return True
        return now - self._last_tree_t >= 1.0 / self.frames_hz - 1e-9

    def _image_due(self, now: float) -> bool:
        if self.frames_hz is None or self._last_image_t is None:
            return True
        return now - self._last_image_t >= 1.0 / self.frames_hz - 1e-9

    def _frame(self, now: float, fr: dict[str, Any], image: Any) -> None:
        rr, rec = self.rr, self.rec
        marks = fr.get("marks", [])
        if image is not None and self._image_due(now):
            self._last_image_t = now
            data = image if isinstance(image, bytes) else _jpeg(image, self.jpeg_quality)
            rec.log("camera/image", rr.EncodedImage(contents=data, media_type="image/jpeg"))
            rec.log("camera/detections", rr.Ellipses2D(
                centers=[[m["x_px"], m["y_px"]] for m in marks],
                half_sizes=[m["axes_px"] for m in marks],
                colors=[self.colours.get(m["colour"], [255, 255, 255]) for m in marks],
                labels=[f"{m['colour']} {m['range_mm'] / 1000.0:.2f} m" if "range_mm" in m
                        else m["colour"] for m in marks]))
            self.images += 1
        seen = [m for m in marks if "world" in m]
        rec.log("map/seen", rr.Points2D(
            [_up(m["world"]) for m in seen], radii=[50.0] * len(seen),
            colors=[self.colours.get(m["colour"], [255, 255, 255]) for m in seen]))
        self.frames += 1

    def close(self) -> None:
        self.rec.flush()
        self.rec.disconnect()


def _jpeg(image: Any, quality: int) -> bytes:
    import cv2

    ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise ValueError("JPEG encoding failed")
    return bytes(data.tobytes())


def log_to_recording(log_path: Path, records: list[dict[str, Any]], *,
                     spawn: bool = False) -> RerunSink:
    """Feed a run log to Rerun (``marknav view RUN``): the same entities as a live run; camera
    images only where the run saved frames (``--frames``)."""
    from marknav.runs.records.runlog import Replay

    replay = Replay(records)
    info = replay.info
    colours = {k: _rgb(v) for k, v in info.get("mission", {}).get("colours", {}).items()}
    sink = RerunSink(None, None, spawn=spawn, colours=colours, frames_hz=None)
    if "world" in info:
        sink.static_world(info["world"])
    frames_by_t: dict[float, list[dict[str, Any]]] = {}
    for r in replay.records_of("frame"):
        frames_by_t.setdefault(float(r["t"]), []).append(r)
    for r in replay.records_of("safety"):
        sink.event(float(r["t"]), f"safety {r.get('event')}: {r.get('state')} {r.get('detail')}")
    for rec, state in replay.states():
        t = float(rec["t"])
        frames = []
        for fr in frames_by_t.pop(t, []):
            image = None
            if fr.get("image"):
                try:  # a frame file the log names: bounded, and only a regular file
                    image = read_bytes(log_path.parent / str(fr["image"]),
                                       limit=MAX_IMAGE_BYTES, what="a camera frame")
                except InputError as exc:
                    log.warning("frame left out: %s", exc)
                    image = None
            frames.append((fr, image))
        sink.tick(t, rec, frames, state)
    return sink
