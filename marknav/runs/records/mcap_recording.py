"""A run as ROS 2 messages: an MCAP file in a rosbag2 folder, and the same channels live.

:class:`Ros2Recording` is a sink of the run recorder (:class:`~marknav.runs.records.runlog.
Recorder`): after every tick it gets the tick's record (odometry, true pose, panel, blackboard
additions), the camera frames the detector processed and the tree's state, turns them into ROS 2
messages (:data:`TOPICS`, docs/reference/recording.md) and hands their CDR bytes to its outputs:
:class:`McapFile` (the recording, with the ``metadata.yaml`` that makes its folder a rosbag2
bag) and, with ``--foxglove``, the live server of :mod:`marknav.runs.views.foxglove_live`.

The conversion, the JPEG encoding and the writing run in a process of their own, so the control
loop only hands over the tick (and a copy of each frame kept for the recording). Units are
ROS's (REP 103): metres, radians, seconds; frames ``world`` (the simulator's world; the start
pose's frame on a real robot), ``odom``, ``base_link``, ``base_link_truth`` (the simulator's
true pose), ``camera_link`` and ``camera_optical``.
"""

from __future__ import annotations

import json
import logging
import math
import queue
import time
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from marknav.runs.records.ros2_types import definition, encoder

if TYPE_CHECKING:  # py_trees loads with it: not when the command line only builds its help
    from marknav.runs.records.tree_state import TreeState

log = logging.getLogger(__name__)

#: Camera images per second of run time kept unless ``--record-hz`` says otherwise: enough to
#: follow a mark through a bypass (the search turns at 40 °/s: 8 ° between images); the 41 s
#: slalom then records under 5 MB.
RECORD_HZ = 5.0
#: JPEG quality (0..100): a noisy simulated 640×480 frame is ~20 kB at 70, ~34 kB at 80; a
#: mark's rim stays clear to the eye at 70.
JPEG_QUALITY = 70
JPEG_QUALITY_MAX = 100
#: Distortion coefficients of the plumb-bob model (k1 k2 p1 p2 k3); more: rational polynomial.
PLUMB_BOB_COEFFICIENTS = 5
#: Static messages (``/tf_static``, the world's marks) are sent again this often (run seconds),
#: so a viewer that connects late or seeks into the file has them.
STATIC_REPEAT_S = 1.0
#: Height of a drawn mark, m: a flat disc on the floor plan.
MARK_DRAWN_HEIGHT_M = 0.02
#: Points on a drawn clearance circle.
CIRCLE_POINTS = 48
#: Line width of drawn paths and walls, m.
LINE_WIDTH_M = 0.02
#: Height of text labels, m.
TEXT_HEIGHT_M = 0.12
MM = 0.001  # metres per millimetre
MM_PER_M = 1000.0
#: Line width of the circles drawn on the image, px; label size, px.
ANNOTATION_LINE_PX = 2.0
ANNOTATION_FONT_PX = 14.0
#: Foxglove's image coordinates start at the top-left corner of the top-left pixel; OpenCV's
#: at that pixel's centre.
PIXEL_CENTRE = 0.5
#: Version of the tree message's JSON (``schema`` in every message).
TREE_SCHEMA = "marknav.tree/1"

# Marker constants (visualization_msgs/msg/Marker).
CYLINDER, LINE_STRIP, LINE_LIST, TEXT = 3, 4, 5, 9
ADD, DELETEALL = 0, 3

#: topic -> (message type, what it holds). docs/reference/recording.md is the long form.
TOPICS: dict[str, tuple[str, str]] = {
    "/camera/image/compressed": ("sensor_msgs/msg/CompressedImage",
                                 "the frames the detector processed, JPEG, at most --record-hz"),
    "/camera/camera_info": ("sensor_msgs/msg/CameraInfo", "the mission's intrinsics, with "
                            "every image"),
    "/camera/annotations": ("foxglove_msgs/msg/ImageAnnotations", "the marks detected in "
                            "each image: a circle and a label, image pixels"),
    "/tf": ("tf2_msgs/msg/TFMessage", "odom -> base_link (odometry) and world -> "
            "base_link_truth (simulator), every tick"),
    "/tf_static": ("tf2_msgs/msg/TFMessage", "world -> odom, base_link -> camera_link -> "
                   "camera_optical"),
    "/odom": ("nav_msgs/msg/Odometry", "odometry pose and velocity, every tick"),
    "/cmd_vel": ("geometry_msgs/msg/TwistStamped", "the wheel command as a body velocity, "
                 "every tick"),
    "/marknav/safety": ("std_msgs/msg/String", "the safety state, every tick"),
    "/marknav/tree": ("std_msgs/msg/String", "the behaviour tree and status panel as JSON "
                      f"({TREE_SCHEMA}), every tick"),
    "/marknav/marks/detected": ("visualization_msgs/msg/MarkerArray",
                                "marks found in each processed frame, base_link"),
    "/marknav/marks/world": ("visualization_msgs/msg/MarkerArray",
                             "the world's marks, walls and boxes (simulator), world"),
    "/marknav/plans": ("visualization_msgs/msg/MarkerArray",
                       "every Bézier bypass planned so far and its clearance circle, odom"),
}


class ChannelOutput(Protocol):
    """Where encoded messages go: a file, a live server."""

    def write(self, topic: str, type_name: str, data: bytes, log_time_ns: int) -> None: ...

    def close(self) -> None: ...


# -- small message builders ------------------------------------------------------------------

def _stamp(ns: int) -> dict[str, int]:
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def _header(ns: int, frame: str) -> dict[str, Any]:
    return {"stamp": _stamp(ns), "frame_id": frame}


def _yaw(theta: float) -> dict[str, float]:
    return {"x": 0.0, "y": 0.0, "z": math.sin(theta / 2.0), "w": math.cos(theta / 2.0)}


def _transform(ns: int, parent: str, child: str, xyz: Sequence[float],
               rotation: dict[str, float]) -> dict[str, Any]:
    return {"header": _header(ns, parent), "child_frame_id": child,
            "transform": {"translation": {"x": xyz[0], "y": xyz[1], "z": xyz[2]},
                          "rotation": rotation}}


def _point(x_mm: float, y_mm: float, z_m: float = 0.0) -> dict[str, float]:
    return {"x": float(x_mm) * MM, "y": float(y_mm) * MM, "z": z_m}


def _colour(rgb: Sequence[int], alpha: float = 1.0) -> dict[str, float]:
    return {"r": rgb[0] / 255.0, "g": rgb[1] / 255.0, "b": rgb[2] / 255.0, "a": alpha}


def _marker(ns_time: int, frame: str, ns: str, ident: int, kind: int, **fields: Any) -> dict[
        str, Any]:
    m: dict[str, Any] = {"header": _header(ns_time, frame), "ns": ns, "id": ident,
                         "type": kind, "action": ADD,
                         "pose": {"position": {"x": 0.0, "y": 0.0, "z": 0.0},
                                  "orientation": _yaw(0.0)},
                         "scale": {"x": 1.0, "y": 1.0, "z": 1.0},
                         "color": _colour((255, 255, 255))}
    m.update(fields)
    return m


def _disc(ns_time: int, frame: str, ns: str, ident: int, xy_mm: Sequence[float],
          radius_mm: float, rgb: Sequence[int]) -> dict[str, Any]:
    d = 2.0 * radius_mm * MM
    return _marker(ns_time, frame, ns, ident, CYLINDER,
                   pose={"position": _point(xy_mm[0], xy_mm[1], MARK_DRAWN_HEIGHT_M / 2.0),
                         "orientation": _yaw(0.0)},
                   scale={"x": d, "y": d, "z": MARK_DRAWN_HEIGHT_M}, color=_colour(rgb))


def _label(ns_time: int, frame: str, ns: str, ident: int, xy_mm: Sequence[float],
           text: str) -> dict[str, Any]:
    return _marker(ns_time, frame, ns, ident, TEXT, text=text,
                   pose={"position": _point(xy_mm[0], xy_mm[1], 2.0 * TEXT_HEIGHT_M),
                         "orientation": _yaw(0.0)},
                   scale={"x": 0.0, "y": 0.0, "z": TEXT_HEIGHT_M})


def _lines(ns_time: int, frame: str, ns: str, ident: int, kind: int,
           points_mm: Iterable[Sequence[float]], rgb: Sequence[int]) -> dict[str, Any]:
    return _marker(ns_time, frame, ns, ident, kind,
                   points=[_point(p[0], p[1]) for p in points_mm],
                   scale={"x": LINE_WIDTH_M, "y": 0.0, "z": 0.0}, color=_colour(rgb))


def _circle(xy_mm: Sequence[float], radius_mm: float) -> list[tuple[float, float]]:
    return [(xy_mm[0] + radius_mm * math.cos(a), xy_mm[1] + radius_mm * math.sin(a))
            for a in (2.0 * math.pi * k / CIRCLE_POINTS for k in range(CIRCLE_POINTS + 1))]


def _rgb(bgr: Sequence[float]) -> list[int]:
    b, g, r = (int(v) for v in list(bgr)[:3])
    return [r, g, b]


@dataclass
class CameraModel:
    """What ``CameraInfo`` and the camera's transforms say: intrinsics (px), mount."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    dist: list[float] = field(default_factory=list)
    height_m: float = 0.0  # camera centre above base_link (the floor), m
    pitch_rad: float = 0.0  # positive: looking up

    @classmethod
    def of_mission(cls, mission: Any) -> CameraModel:
        cam = mission.camera
        intr = cam.intrinsics
        if intr is not None:
            fx, fy, cx, cy, dist = intr.fx, intr.fy, intr.cx, intr.cy, list(intr.dist)
        else:  # marknav's pinhole: principal point at the image centre
            fx = fy = cam.focal_px
            cx, cy, dist = (cam.width - 1) / 2.0, (cam.height - 1) / 2.0, []
        return cls(width=cam.width, height=cam.height, fx=fx, fy=fy, cx=cx, cy=cy, dist=dist,
                   height_m=(cam.height_mm or 0.0) * MM,
                   pitch_rad=math.radians(cam.pitch_deg or 0.0))

    def info(self, ns: int, size: Sequence[int] | None = None) -> dict[str, Any]:
        w, h = (int(size[0]), int(size[1])) if size else (self.width, self.height)
        sx, sy = w / self.width, h / self.height  # a frame at another size than the mission's
        fx, fy, cx, cy = self.fx * sx, self.fy * sy, self.cx * sx, self.cy * sy
        return {"header": _header(ns, "camera_optical"), "height": h, "width": w,
                "distortion_model": "plumb_bob" if len(self.dist) <= PLUMB_BOB_COEFFICIENTS else
                "rational_polynomial",
                "d": [float(v) for v in self.dist] or [0.0] * PLUMB_BOB_COEFFICIENTS,
                "k": [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0],
                "r": [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
                "p": [fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0]}

    def static_transforms(self, ns: int) -> list[dict[str, Any]]:
        # ROS pitch is about +y (left): a positive angle tips x down, so looking up is -pitch.
        half = -self.pitch_rad / 2.0
        optical = {"x": -0.5, "y": 0.5, "z": -0.5, "w": 0.5}  # z forward, x right, y down
        return [_transform(ns, "world", "odom", (0.0, 0.0, 0.0), _yaw(0.0)),
                _transform(ns, "base_link", "camera_link", (0.0, 0.0, self.height_m),
                           {"x": 0.0, "y": math.sin(half), "z": 0.0, "w": math.cos(half)}),
                _transform(ns, "camera_link", "camera_optical", (0.0, 0.0, 0.0), optical)]


@dataclass
class _Tick:
    """What the control loop hands the recording's thread for one tick."""

    now: float
    record: dict[str, Any]
    frames: list[tuple[dict[str, Any], Any]]  # (frame record, image to encode or None)
    status: list[str]
    message: list[str]


class Ros2Messages:
    """Turns ticks into ROS 2 messages (dicts), topic by topic; pure, no I/O."""

    def __init__(self, *, camera: CameraModel | None, colours: dict[str, list[int]],
                 world: dict[str, Any] | None, tree: TreeState, start_ns: int,
                 wheel_base_mm: float | None, jpeg_quality: int = JPEG_QUALITY) -> None:
        self.camera = camera
        self.colours = colours
        self.world = world
        self.tree = tree
        self.start_ns = start_ns
        self.wheel_base_mm = wheel_base_mm
        self.jpeg_quality = jpeg_quality
        self._last_static: float | None = None
        self._plans: list[dict[str, Any]] = []
        self._last_pose: tuple[float, list[float]] | None = None

    def ns(self, t: float) -> int:
        return self.start_ns + round(t * 1e9)

    def tick(self, tick: _Tick) -> list[tuple[str, int, dict[str, Any]]]:
        now, record = tick.now, tick.record
        ns = self.ns(now)
        out: list[tuple[str, int, dict[str, Any]]] = []
        if self._last_static is None or now - self._last_static >= STATIC_REPEAT_S - 1e-9:
            self._last_static = now
            out.extend(self._static(ns))
        for fr, image in tick.frames:
            out.extend(self._frame(now, fr, image))
        out.extend(self._pose(ns, now, record))
        panel = record.get("panel", {})
        out.append(("/cmd_vel", ns, self._cmd_vel(ns, panel.get("wheels_mm_s"))))
        out.append(("/marknav/safety", ns, {"data": str(panel.get("safety", ""))}))
        out.append(("/marknav/tree", ns, {"data": self.tree_json(tick)}))
        plans = record.get("bb", {}).get("/marknav/plans", [])
        if plans:
            self._plans.extend(p for p in plans if p.get("plan", {}).get("points"))
            out.append(("/marknav/plans", ns, self._plan_markers(ns)))
        return out

    def tree_json(self, tick: _Tick) -> str:
        from marknav.runs.records.tree_state import TreeState

        st = self.tree
        nodes = [{"id": i, "name": st.names[i], "kind": st.kinds[i], "parent": st.parents[i],
                  "status": tick.status[i], "message": tick.message[i]}
                 for i in range(len(st.names))]
        shown = TreeState(names=st.names, kinds=st.kinds, parents=st.parents,
                          status=tick.status, message=tick.message)
        return json.dumps({"schema": TREE_SCHEMA, "tick": int(tick.record.get("n", 0)),
                           "t": round(tick.now, 3),
                           "status": tick.status[0] if tick.status else "INVALID",
                           "active": shown.active_path(), "nodes": nodes,
                           "panel": tick.record.get("panel", {})},
                          separators=(",", ":"), ensure_ascii=False)

    # -- parts -------------------------------------------------------------------------------
    def _static(self, ns: int) -> list[tuple[str, int, dict[str, Any]]]:
        out: list[tuple[str, int, dict[str, Any]]] = []
        if self.camera is not None:
            out.append(("/tf_static", ns, {"transforms": self.camera.static_transforms(ns)}))
        if self.world is not None:
            out.append(("/marknav/marks/world", ns, self._world_markers(ns)))
        return out

    def _world_markers(self, ns: int) -> dict[str, Any]:
        world = self.world or {}
        markers = []
        for i, m in enumerate(world.get("marks", [])):
            rgb = self.colours.get(m["colour"], [128, 128, 128])
            markers.append(_disc(ns, "world", "marks", i, m["xy"], m["radius_mm"], rgb))
            markers.append(_label(ns, "world", "labels", i, m["xy"], f"{i + 1}: {m['colour']}"))
        walls = [p for w in world.get("walls", []) for p in (w[:2], w[2:])]
        if walls:
            markers.append(_lines(ns, "world", "walls", 0, LINE_LIST, walls, (90, 90, 90)))
        for i, box in enumerate(world.get("boxes", [])):
            markers.append(_lines(ns, "world", "boxes", i, LINE_STRIP, [*box, box[0]],
                                  (160, 160, 160)))
        return {"markers": markers}

    def _plan_markers(self, ns: int) -> dict[str, Any]:
        markers = []
        for i, p in enumerate(self._plans):
            plan = p["plan"]
            markers.append(_lines(ns, "odom", "bypass", i, LINE_STRIP, plan["points"],
                                  (148, 0, 211)))
            if plan.get("mark_xy") is not None and plan.get("clearance_mm") is not None:
                markers.append(_lines(ns, "odom", "clearance", i, LINE_STRIP,
                                      _circle(plan["mark_xy"], plan["clearance_mm"]),
                                      (255, 140, 0)))
        return {"markers": markers}

    def _frame(self, now: float, fr: dict[str, Any],
               image: bytes | None) -> list[tuple[str, int, dict[str, Any]]]:
        shot = self.ns(float(fr.get("captured_t", now)))
        out: list[tuple[str, int, dict[str, Any]]] = []
        log_ns = self.ns(now)
        if image is not None:
            out.append(("/camera/image/compressed", log_ns,
                        {"header": _header(shot, "camera_optical"), "format": "jpeg",
                         "data": image}))
            if self.camera is not None:
                out.append(("/camera/camera_info", log_ns, self.camera.info(shot,
                                                                            fr.get("size"))))
            out.append(("/camera/annotations", log_ns, self._annotations(shot, fr)))
        markers: list[dict[str, Any]] = [_marker(shot, "base_link", "", 0, CYLINDER,
                                                 action=DELETEALL)]
        for k, m in enumerate(fr.get("marks", [])):
            if "forward_mm" not in m:
                continue
            rgb = self.colours.get(m["colour"], [255, 255, 255])
            xy = (m["forward_mm"], m["left_mm"])
            radius = (self.world or {}).get("mark_radius_mm", 100.0)
            markers.append(_disc(shot, "base_link", "detected", k, xy, radius, rgb))
            markers.append(_label(shot, "base_link", "range", k, xy,
                                  f"{m['colour']} {m['range_mm'] / MM_PER_M:.2f} m"))
        out.append(("/marknav/marks/detected", log_ns, {"markers": markers}))
        return out

    def _annotations(self, shot: int, fr: dict[str, Any]) -> dict[str, Any]:
        """Each detection in the image: a circle (the ellipse's mean diameter) in its colour,
        and its colour and range as a label above it."""
        circles, texts = [], []
        for m in fr.get("marks", []):
            colour = {k: float(v) for k, v in
                      _colour(self.colours.get(m["colour"], [255, 255, 255])).items()}
            x, y = m["x_px"] + PIXEL_CENTRE, m["y_px"] + PIXEL_CENTRE
            half = (float(m["axes_px"][0]) + float(m["axes_px"][1])) / 2.0  # semi-axes
            circles.append({"timestamp": _stamp(shot), "position": {"x": x, "y": y},
                            "diameter": 2.0 * half, "thickness": ANNOTATION_LINE_PX,
                            "fill_color": {**colour, "a": 0.0}, "outline_color": colour})
            label = (f"{m['colour']} {m['range_mm'] / MM_PER_M:.2f} m" if "range_mm" in m
                     else m["colour"])
            texts.append({"timestamp": _stamp(shot),
                          "position": {"x": x - half, "y": y - half - ANNOTATION_FONT_PX},
                          "text": label, "font_size": ANNOTATION_FONT_PX,
                          "text_color": colour,
                          "background_color": {"r": 0.0, "g": 0.0, "b": 0.0, "a": 0.6}})
        return {"circles": circles, "points": [], "texts": texts}

    def _pose(self, ns: int, now: float,
              record: dict[str, Any]) -> list[tuple[str, int, dict[str, Any]]]:
        transforms = []
        odom: dict[str, Any] | None = None
        pose = record.get("pose")
        if pose is not None:
            x, y, th = (float(v) for v in pose)
            transforms.append(_transform(ns, "odom", "base_link", (x * MM, y * MM, 0.0),
                                         _yaw(th)))
            odom = {"header": _header(ns, "odom"), "child_frame_id": "base_link",
                    "pose": {"pose": {"position": _point(x, y), "orientation": _yaw(th)}},
                    "twist": {"twist": self._velocity(now, [x, y, th])}}
        truth = record.get("truth")
        if truth is not None:
            tx, ty, tth = (float(v) for v in truth)
            transforms.append(_transform(ns, "world", "base_link_truth",
                                         (tx * MM, ty * MM, 0.0), _yaw(tth)))
        out = [("/tf", ns, {"transforms": transforms})]
        if odom is not None:
            out.append(("/odom", ns, odom))
        return out

    def _velocity(self, now: float, pose: list[float]) -> dict[str, Any]:
        """The body velocity since the last tick (base_link: forward m/s, yaw rad/s)."""
        last, self._last_pose = self._last_pose, (now, pose)
        zero = {"x": 0.0, "y": 0.0, "z": 0.0}
        if last is None or now <= last[0]:
            return {"linear": zero, "angular": zero}
        dt = now - last[0]
        dx, dy = pose[0] - last[1][0], pose[1] - last[1][1]
        dth = math.remainder(pose[2] - last[1][2], 2.0 * math.pi)
        c, s = math.cos(pose[2]), math.sin(pose[2])
        return {"linear": {"x": (c * dx + s * dy) * MM / dt, "y": (-s * dx + c * dy) * MM / dt,
                           "z": 0.0},
                "angular": {"x": 0.0, "y": 0.0, "z": dth / dt}}

    def _cmd_vel(self, ns: int, wheels: Sequence[float] | None) -> dict[str, Any]:
        left, right = (float(wheels[0]), float(wheels[1])) if wheels else (0.0, 0.0)
        turn = ((right - left) / self.wheel_base_mm) if self.wheel_base_mm else 0.0
        return {"header": _header(ns, "base_link"),
                "twist": {"linear": {"x": (left + right) / 2.0 * MM, "y": 0.0, "z": 0.0},
                          "angular": {"x": 0.0, "y": 0.0, "z": turn}}}


class McapFile:
    """An MCAP file of ROS 2 messages (profile ``ros2``, zstd chunks) and, beside it, the
    rosbag2 ``metadata.yaml`` that ``ros2 bag`` wants (its folder is then a bag)."""

    def __init__(self, path: Path) -> None:
        from mcap.writer import CompressionType, Writer

        self.path = Path(path)
        self.metadata_path = self.path.with_name("metadata.yaml")
        self._fh = open(self.path, "wb")  # noqa: SIM115 - closed by close()
        self._writer = Writer(self._fh, compression=CompressionType.ZSTD)
        self._writer.start(profile="ros2", library="marknav")
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self.counts: Counter[str] = Counter()
        self.types: dict[str, str] = {}
        self.first_ns: int | None = None
        self.last_ns = 0

    def write(self, topic: str, type_name: str, data: bytes, log_time_ns: int) -> None:
        channel = self._channels.get(topic)
        if channel is None:
            schema = self._schemas.get(type_name)
            if schema is None:
                schema = self._writer.register_schema(type_name, "ros2msg",
                                                      definition(type_name).encode())
                self._schemas[type_name] = schema
            channel = self._writer.register_channel(topic, "cdr", schema)
            self._channels[topic] = channel
            self.types[topic] = type_name
        self._writer.add_message(channel, log_time=log_time_ns, data=data,
                                 publish_time=log_time_ns, sequence=self.counts[topic])
        self.counts[topic] += 1
        if self.first_ns is None:
            self.first_ns = log_time_ns
        self.last_ns = max(self.last_ns, log_time_ns)

    def close(self) -> None:
        if self._fh.closed:
            return
        try:
            self._writer.finish()
        finally:
            self._fh.close()
        self.metadata_path.write_text(self.metadata(), encoding="utf-8")

    def metadata(self) -> str:
        """rosbag2's ``metadata.yaml`` (format version 5: Humble and later read it)."""
        import yaml

        start = self.first_ns or 0
        duration = max(0, self.last_ns - start)
        total = sum(self.counts.values())
        info = {"rosbag2_bagfile_information": {
            "version": 5, "storage_identifier": "mcap",
            "duration": {"nanoseconds": duration},
            "starting_time": {"nanoseconds_since_epoch": start},
            "message_count": total,
            "topics_with_message_count": [
                {"topic_metadata": {"name": t, "type": self.types[t],
                                    "serialization_format": "cdr",
                                    "offered_qos_profiles": ""},
                 "message_count": n} for t, n in sorted(self.counts.items())],
            "compression_format": "", "compression_mode": "",
            "relative_file_paths": [self.path.name],
            "files": [{"path": self.path.name,
                       "starting_time": {"nanoseconds_since_epoch": start},
                       "duration": {"nanoseconds": duration}, "message_count": total}],
        }}
        return str(yaml.safe_dump(info, sort_keys=False))


#: An output of the recording, made in its process: a class or function and its keywords.
OutputSpec = tuple[Callable[..., ChannelOutput], dict[str, Any]]
#: How long the recording's process may take to start (spawn: a fresh interpreter importing
#: numpy, OpenCV and mcap; seconds on a loaded 2-core machine), s.
START_TIMEOUT_S = 120.0
#: How long closing may wait for the queued ticks to be written, s.
CLOSE_TIMEOUT_S = 300.0
#: How often the recording's process checks that marknav is still there, s.
PARENT_POLL_S = 0.5
#: Ticks go to the recording's process in batches of this much run time, s: each hand-over
#: (a queue put, a thread woken, a pipe write) costs the loop more than the tick's data, and a
#: live viewer lags by at most this.
BATCH_S = 0.25


@dataclass
class _Setup:
    """Everything the recording's process needs, as plain data."""

    outputs: list[OutputSpec]
    camera: CameraModel | None
    colours: dict[str, list[int]]
    scene: dict[str, Any] | None
    tree: dict[str, Any]  # TreeState.structure()
    start_ns: int
    wheel_base_mm: float | None
    jpeg_quality: int
    log_level: int
    parent_pid: int


class Ros2Recording:
    """A sink of the run recorder: every tick as ROS 2 messages to its outputs (made from
    ``outputs``: :class:`McapFile`, a live server), in a process of its own.

    The conversion, the CDR and JPEG encoding and the writing take a few milliseconds a tick of
    pure Python; on a thread they would hold the interpreter's lock against the control loop,
    so they run in a spawned process fed through a queue: the loop pays for a copy of each kept
    frame and the queue's pickling. An output that cannot start (a port in use) raises
    :class:`~marknav.core.errors.InputError` from here, before the run starts. ``port``: the
    live server's, if there is one.
    """

    def __init__(self, mission: Any, world: Any, outputs: Sequence[OutputSpec], *,
                 tree: TreeState, record_hz: float = RECORD_HZ,
                 jpeg_quality: int = JPEG_QUALITY, start_ns: int | None = None) -> None:
        import multiprocessing
        import os

        from marknav.core.errors import InputError

        if not record_hz > 0:
            raise ValueError(f"record_hz must be positive, got {record_hz}")
        if not 0 <= jpeg_quality <= JPEG_QUALITY_MAX:
            raise ValueError(f"jpeg_quality must be in 0..100, got {jpeg_quality}")
        self.record_hz = record_hz
        self._last_image_t: float | None = None
        self.ticks = self.frames = self.images = 0
        self.port: int | None = None
        self._closed = False
        self._batch: list[_Tick] = []
        self._batch_t: float | None = None
        self._last_n: int | None = None
        setup = _setup(mission, world, list(outputs), tree, jpeg_quality,
                       time.time_ns() if start_ns is None else start_ns)
        setup.parent_pid = os.getpid()
        ctx = multiprocessing.get_context("spawn")
        self._inbox: Any = ctx.Queue()
        self._outbox: Any = ctx.Queue()
        self._process = ctx.Process(target=_serve, args=(setup, self._inbox, self._outbox),
                                    name="marknav-recording", daemon=True)
        self._process.start()
        try:
            reply = self._reply(START_TIMEOUT_S, "start")
        except BaseException:  # Ctrl-C while it starts: it closes what it opened and ends
            self._process.terminate()
            self._process.join(CLOSE_TIMEOUT_S)
            raise
        if reply[0] == "error":
            self._process.join(PARENT_POLL_S * 4)
            raise InputError(reply[1], field=reply[2])
        self.port = reply[1]

    # -- the sink interface (called by the recorder on the loop's thread) --------------------
    def tick(self, now: float, record: dict[str, Any], frames: list[tuple[dict[str, Any], Any]],
             state: TreeState) -> None:
        """Take one tick (whole: a signal is raised once it is taken, so a tick is never half
        in a batch, nor a batch handed over twice)."""
        from marknav.core import signals

        with signals.deferred():
            self._take(now, record, frames, state)

    def _take(self, now: float, record: dict[str, Any],
              frames: list[tuple[dict[str, Any], Any]], state: TreeState) -> None:
        n = record.get("n")
        if n is not None and n == self._last_n:
            return  # given again after a signal cut its first hand-over short
        kept = []
        for fr, image in frames:
            keep = image is not None and (
                self._last_image_t is None
                or now - self._last_image_t >= 1.0 / self.record_hz - 1e-9)
            if keep:
                self._last_image_t = now
                self.images += 1
            # the queue pickles later, on its own thread: the recording keeps its own copy
            kept.append((fr, image.copy() if keep and not isinstance(image, bytes)
                         else image if keep else None))
        self.frames += len(frames)
        self.ticks += 1
        self._batch.append(_Tick(now, record, kept, list(state.status), list(state.message)))
        self._last_n = n
        if self._batch_t is None:
            self._batch_t = now
        if now - self._batch_t >= BATCH_S - 1e-9:
            self._flush()

    def _flush(self) -> None:
        batch, self._batch, self._batch_t = self._batch, [], None
        if batch:
            self._inbox.put(batch)

    def close(self) -> None:
        """Write what is queued and close the outputs (the file's summary, metadata.yaml)."""
        if self._closed:
            return
        self._closed = True
        from marknav.core import signals

        with signals.deferred():
            self._flush()
            self._inbox.put(None)
        try:
            reply = self._reply(CLOSE_TIMEOUT_S, "finish")
        finally:
            self._process.join(CLOSE_TIMEOUT_S)
            if self._process.is_alive():
                self._process.kill()
        if reply[1] is not None:
            raise RuntimeError(f"the recording failed: {reply[1]}")

    def _reply(self, timeout_s: float, what: str) -> tuple[Any, ...]:
        try:
            reply: tuple[Any, ...] = self._outbox.get(timeout=timeout_s)
        except queue.Empty:
            self._process.kill()
            raise RuntimeError(f"the recording's process did not {what} within "
                               f"{timeout_s:g} s") from None
        return reply


def _setup(mission: Any, world: Any, outputs: list[OutputSpec], tree: TreeState,
           jpeg_quality: int, start_ns: int) -> _Setup:
    colours: dict[str, list[int]] = {}
    camera = None
    wheel_base = None
    if mission is not None:
        from marknav.sim.builtin_camera import mark_bgr

        colours = {c.name: _rgb(mark_bgr(c)) for c in mission.palette()}
        camera = CameraModel.of_mission(mission)
        wheel_base = float(mission.robot.wheel_base_mm)
    scene = None
    radius = mission.marks.radius_mm if mission is not None else None
    if world is not None:
        r = radius if radius is not None else 100.0
        scene = {"marks": [{"colour": m.colour, "xy": [float(v) for v in m.xy],
                            "radius_mm": float(m.radius(r))} for m in world.marks],
                 "walls": [[float(v) for v in (*w.segment()[0], *w.segment()[1])]
                           for w in world.walls],
                 "boxes": [[[float(v) for v in c] for c in b.corners()] for b in world.boxes],
                 "mark_radius_mm": r}
    elif radius is not None:
        scene = {"mark_radius_mm": radius}
    return _Setup(outputs=outputs, camera=camera, colours=colours, scene=scene,
                  tree=tree.structure(), start_ns=start_ns, wheel_base_mm=wheel_base,
                  jpeg_quality=jpeg_quality,
                  log_level=logging.getLogger().getEffectiveLevel(), parent_pid=0)


def _serve(setup: _Setup, inbox: Any, outbox: Any) -> None:
    """The recording's process: make the outputs, then write each tick until told to stop (or
    until marknav is gone: what was written is closed properly)."""
    import os
    import signal

    from marknav.core.errors import InputError
    from marknav.runs.records.tree_state import TreeState

    # marknav decides what a Ctrl-C means: it closes the recording when it stops. SIGTERM (from
    # marknav's own exit, or a kill) stops at the next tick with the file closed properly.
    stopping: list[int] = []
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, lambda signum, frame: stopping.append(signum))
    logging.basicConfig(level=setup.log_level, format="%(levelname)s %(name)s: %(message)s")
    outputs: list[ChannelOutput] = []
    try:
        for factory, kwargs in setup.outputs:
            outputs.append(factory(**kwargs))
    except (InputError, OSError) as exc:
        for out in outputs:
            out.close()
        field = exc.field if isinstance(exc, InputError) else "--record"
        text = exc.message if isinstance(exc, InputError) else (
            f"cannot write the recording: {exc.strerror or exc}")
        outbox.put(("error", text, field))
        return
    outbox.put(("ready", next((o.port for o in outputs if hasattr(o, "port")), None)))
    messages = Ros2Messages(camera=setup.camera, colours=setup.colours, world=setup.scene,
                            tree=TreeState.from_structure(setup.tree),
                            start_ns=setup.start_ns, wheel_base_mm=setup.wheel_base_mm,
                            jpeg_quality=setup.jpeg_quality)
    error: str | None = None
    while not stopping:
        try:
            item = inbox.get(timeout=PARENT_POLL_S)
        except queue.Empty:
            if os.getppid() != setup.parent_pid:
                break  # marknav is gone: close the file properly
            continue
        if item is None:
            break
        if error is not None:
            continue  # drain: marknav must not wait on a broken recording
        try:
            for tick in item:
                _write(messages, outputs, tick, setup.jpeg_quality)
        except Exception as exc:  # a full disk, a bug: the run goes on, close() says so
            log.exception("the recording failed")
            error = str(exc) or type(exc).__name__
    for out in outputs:
        try:
            out.close()
        except Exception as exc:
            log.exception("closing %s failed", out)
            error = error or str(exc)
    outbox.put(("done", error))


def _write(messages: Ros2Messages, outputs: Sequence[ChannelOutput], item: _Tick,
           quality: int) -> None:
    item.frames = [(fr, _jpeg(image, quality) if image is not None else None)
                   for fr, image in item.frames]
    for topic, ns, message in messages.tick(item):
        type_name = TOPICS[topic][0]
        data = encoder(type_name)(message)
        for out in outputs:
            out.write(topic, type_name, data, ns)


def _jpeg(image: Any, quality: int) -> bytes:
    if isinstance(image, bytes):
        return image
    import cv2

    ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise ValueError("JPEG encoding failed")
    return bytes(data.tobytes())


def recording_folder_problem(path: Path) -> str | None:
    """Why ``path`` cannot be a recording (its folder holds another rosbag2 bag), or None."""
    meta = Path(path).with_name("metadata.yaml")
    if not meta.is_file():
        return None
    try:
        text = meta.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        return f"cannot read {meta}: {exc.strerror or exc}"
    if Path(path).name in text:
        return None  # the same recording, written again
    return (f"{meta} belongs to another recording (a rosbag2 folder holds one bag): give "
            "the recording a folder of its own")
