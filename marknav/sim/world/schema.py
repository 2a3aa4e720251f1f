"""The world schema: marks, robot start, walls, boxes, conditions, patches, events; loading.

In the frames of ``docs/architecture.md``: world x east, y north, heading θ counter-clockwise from
+x, millimetres; degrees only in the file (keys ending in ``_deg``).

A **world file** (YAML, validated by the pydantic models below through :mod:`marknav.core.yamlio`,
unknown keys rejected everywhere) lists the marks, the robot's start pose, walls and boxes,
image/wheel conditions and the background seed. :func:`load_world` reads one; the course checks
are in :mod:`marknav.sim.world.course`, contacts in :mod:`marknav.sim.world.contacts`, generated
worlds in :mod:`marknav.sim.world.generate` and the JSON Schema in
:mod:`marknav.sim.world.json_schema`.

A mark's ``yaw_deg`` turns the disc's face about the vertical: 0 means its normal points along −y
(toward a robot at the origin facing +y); positive turns it counter-clockwise seen from above. Yaw
is absolute (world frame), not relative to the robot's start heading.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, PrivateAttr, field_validator, model_validator

from marknav.core.yamlio import Integer, Number, Position, load_yaml_file, parse_model
from marknav.planning.kinematics import Pose, wrap_angle
from marknav.sim.lens import Lens
from marknav.sim.mujoco.scene import MujocoScene
from marknav.sim.overlap import first_overlap

__all__ = [
    "CAST_GAINS_BGR",
    "CREATE_RADIUS_MM",
    "DEFAULT_MARK_RADIUS_MM",
    "Background",
    "Box",
    "Conditions",
    "FaultEvent",
    "FrictionPatch",
    "MarkSpec",
    "RobotStart",
    "Wall",
    "World",
    "load_world",
]

#: A mark's radius when neither the world file nor the caller gives one (the brief's example).
DEFAULT_MARK_RADIUS_MM = 100.0
#: The Create is a 330 mm disc.
CREATE_RADIUS_MM = 165.0
#: The most of a wheel's travel a world may lose to slip, a fraction: beyond it the tyres spin
#: on the spot (wet ice) and no course can be driven; the MuJoCo engine models slip as a tyre
#: that much smaller, and as slip nears 1 that tyre has no size or mass MuJoCo can simulate.
WHEEL_SLIP_LIMIT = 0.9

#: Per-channel gains (B, G, R) of the named casts: warm = incandescent-like, cool = shade-like.
CAST_GAINS_BGR: dict[str, tuple[float, float, float]] = {
    "none": (1.0, 1.0, 1.0),
    "warm": (0.80, 1.0, 1.20),
    "cool": (1.20, 1.0, 0.80),
}

_Finite = Annotated[Number, Field(allow_inf_nan=False)]
_Gain = Annotated[Number, Field(gt=0.0, le=4.0, allow_inf_nan=False)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class MarkSpec(_Strict):
    """One mark: a disc of ``colour`` standing at (x_mm, y_mm), its face turned by ``yaw_deg``."""

    colour: str = Field(min_length=1)
    x_mm: _Finite
    y_mm: _Finite
    yaw_deg: _Finite = 0.0
    radius_mm: Annotated[Number, Field(gt=0.0, le=2000.0, allow_inf_nan=False)] | None = None

    @property
    def xy(self) -> tuple[float, float]:
        return (self.x_mm, self.y_mm)

    @property
    def yaw_rad(self) -> float:
        return math.radians(self.yaw_deg)

    @property
    def normal(self) -> tuple[float, float]:
        """Unit normal of the disc's face in the world frame: (0, −1) at yaw 0."""
        a = self.yaw_rad
        return (math.sin(a), -math.cos(a))

    def radius(self, default: float = DEFAULT_MARK_RADIUS_MM) -> float:
        """The mark's radius, or ``default`` when the world file leaves it out."""
        return self.radius_mm if self.radius_mm is not None else default


class RobotStart(_Strict):
    """The robot's start pose; the default is the architecture's: origin, facing +y."""

    x_mm: _Finite = 0.0
    y_mm: _Finite = 0.0
    heading_deg: _Finite = 90.0

    def pose(self) -> Pose:
        return Pose(self.x_mm, self.y_mm, wrap_angle(math.radians(self.heading_deg)))


class Wall(_Strict):
    """A wall: the segment from (x1, y1) to (x2, y2), mm."""

    x1_mm: _Finite
    y1_mm: _Finite
    x2_mm: _Finite
    y2_mm: _Finite

    @model_validator(mode="after")
    def _not_a_point(self) -> Wall:
        if self.x1_mm == self.x2_mm and self.y1_mm == self.y2_mm:
            raise ValueError("a wall needs two different end points")
        return self

    def segment(self) -> tuple[tuple[float, float], tuple[float, float]]:
        return ((self.x1_mm, self.y1_mm), (self.x2_mm, self.y2_mm))


class Box(_Strict):
    """A rectangular obstacle centred at (x_mm, y_mm): width along x, depth along y, turned by
    ``yaw_deg`` counter-clockwise."""

    x_mm: _Finite
    y_mm: _Finite
    width_mm: Annotated[Number, Field(gt=0.0, allow_inf_nan=False)]
    depth_mm: Annotated[Number, Field(gt=0.0, allow_inf_nan=False)]
    yaw_deg: _Finite = 0.0

    def corners(self) -> list[tuple[float, float]]:
        """The four corners, counter-clockwise."""
        c, s = math.cos(math.radians(self.yaw_deg)), math.sin(math.radians(self.yaw_deg))
        hw, hd = self.width_mm / 2.0, self.depth_mm / 2.0
        out = []
        for lx, ly in ((-hw, -hd), (hw, -hd), (hw, hd), (-hw, hd)):
            out.append((self.x_mm + c * lx - s * ly, self.y_mm + s * lx + c * ly))
        return out

    def contains(self, x: float, y: float) -> bool:
        c, s = math.cos(math.radians(self.yaw_deg)), math.sin(math.radians(self.yaw_deg))
        dx, dy = x - self.x_mm, y - self.y_mm
        lx, ly = c * dx + s * dy, -s * dx + c * dy
        return abs(lx) <= self.width_mm / 2.0 and abs(ly) <= self.depth_mm / 2.0


class Conditions(_Strict):
    """Image and wheel conditions.

    - ``lighting_gain``: multiplies the whole image (0.5 dim, 1.5 bright).
    - ``cast``: ``none``, ``warm``, ``cool`` (see :data:`CAST_GAINS_BGR`) or explicit
      ``[b, g, r]`` channel gains.
    - ``noise_sigma``: σ of additive Gaussian image noise, grey levels.
    - ``blur_sigma_px``: σ of a Gaussian blur, pixels (0: none).
    - ``wheel_mismatch``: the right wheel's ground speed is ``(1 + wheel_mismatch)`` times the
      left's for the same command (e.g. unequal tyres); the encoders do not see it.
    - ``wheel_slip``: fraction of each wheel's travel lost to slip (at most
      :data:`WHEEL_SLIP_LIMIT`); the encoders do not see it.
    - ``latency_frames``: the camera delivers the frame taken this many reads earlier.
    - ``camera_latency_s``: the time from a frame's capture to its arrival at the computer
      (exposure, encoding, a Wi-Fi link: 0.13–0.3 s for MJPEG over Wi-Fi), in continuous time.
    - ``processing_s``: the time from a frame's arrival to the wheel command it leads to
      (detection, estimation, the tree). The simulated tick takes no simulated time, so the
      frame a tick processes is one captured ``camera_latency_s + processing_s`` before it.
    - ``camera_pitch_deg``, ``camera_roll_deg``: the camera's tilt above the horizontal
      (positive: looking up) and its turn about its optical axis (positive: the image turns
      clockwise), degrees. A mark at camera height then lies f·tan(pitch) rows below the
      principal point.
    - ``mark_height_offset_mm``: how far the marks' centres stand above the camera (negative:
      below), mm; 0 is the paper's set-up, marks at camera height.
    - The built-in engine's room (:mod:`marknav.sim.scenery`; MuJoCo's is the world's ``mujoco``
      section, and it refuses these): ``floor`` (``plain``, ``wood``, ``carpet``) at
      ``floor_saturation``; ``wall`` (``plain`` or ``photo``); ``wall_hue`` (a hue that dominates
      the scene, or none); ``occluders`` (thin poles in front of the marks); ``distractors``
      (round objects of near-mark colours on the horizon, off the course).
    - ``lens``: the camera's distortion and principal point (default a pinhole; randomised
      worlds draw a webcam's, :func:`marknav.sim.lens.random_lens`).
    - ``frame_rate_hz``: frames the camera takes per second, apart from the control rate (0: one
      frame per control cycle, taken when it is read). Webcams: 30, or 15 in dim light.
    - ``dropped_frames``: probability that a frame taken never arrives (0..1).
    - ``exposure_ms``: exposure time, ms: the robot turning during it smears the image
      sideways by the angle turned times the focal length (motion blur). 0: none.
    - ``exposure_drift``: amplitude of the auto-exposure's slow brightness swing (fraction of
      the brightness), a sine of period ``exposure_period_s``.
    - ``exposure_period_s``: period of the exposure drift, s.
    - ``mark_saturation``: saturation of the marks' paint relative to full (printed marks are
      not fully saturated: 0.75..1 on camera).
    - ``mark_saturation_spread``: each mark's saturation differs by up to ± this fraction.
    - ``mark_hue_spread``: each mark's hue differs from its colour's centre by up to ± this
      many OpenCV hue units.
    - ``encoder_scale``: encoder counts per nominal count of ground travel (odometry's scale
      error: worn tyres, a wheel diameter off 72 mm); ``marknav calibrate-odometry`` measures it.
    - ``encoder_noise_counts``: σ of noise on each encoder per 15 ms sensor tick, counts.
    - ``accel_mm_s2``: the wheels' largest acceleration, mm/s² (0: speed changes at once).
    - ``command_delay_ms``: delay from the host writing a command to the robot acting on it
      (serial adapter, Bluetooth), ms.
    - ``top_speed_mm_s``: the fastest a wheel turns with the battery's voltage under load
      (battery sag), mm/s; faster commands are clipped per wheel.
    """

    lighting_gain: _Gain = 1.0
    cast: Literal["none", "warm", "cool"] | tuple[_Gain, _Gain, _Gain] = "none"
    noise_sigma: Annotated[Number, Field(ge=0.0, le=64.0, allow_inf_nan=False)] = 2.0
    blur_sigma_px: Annotated[Number, Field(ge=0.0, le=10.0, allow_inf_nan=False)] = 0.0
    wheel_mismatch: Annotated[Number, Field(ge=-0.5, le=0.5, allow_inf_nan=False)] = 0.0
    wheel_slip: Annotated[Number, Field(ge=0.0, le=WHEEL_SLIP_LIMIT, allow_inf_nan=False)] = 0.0
    latency_frames: Annotated[Integer, Field(ge=0, le=30)] = 0
    camera_latency_s: Annotated[Number, Field(ge=0.0, le=2.0, allow_inf_nan=False)] = 0.0
    processing_s: Annotated[Number, Field(ge=0.0, le=1.0, allow_inf_nan=False)] = 0.0
    camera_pitch_deg: Annotated[Number, Field(ge=-30.0, le=30.0, allow_inf_nan=False)] = 0.0
    camera_roll_deg: Annotated[Number, Field(ge=-30.0, le=30.0, allow_inf_nan=False)] = 0.0
    mark_height_offset_mm: Annotated[Number, Field(ge=-1000.0, le=1000.0,
                                                  allow_inf_nan=False)] = 0.0
    floor: Literal["plain", "wood", "carpet"] = "plain"
    floor_saturation: Annotated[Number, Field(ge=0.0, le=255.0, allow_inf_nan=False)] = 120.0
    wall: Literal["plain", "photo"] = "plain"
    wall_hue: Annotated[Number, Field(ge=0.0, lt=180.0, allow_inf_nan=False)] | None = None
    occluders: Annotated[Integer, Field(ge=0, le=20)] = 0
    distractors: Annotated[Integer, Field(ge=0, le=40)] = 0
    #: The camera's lens (distortion, principal point): :class:`marknav.sim.lens.Lens`.
    lens: Lens = Lens()
    frame_rate_hz: Annotated[Number, Field(ge=0.0, le=240.0, allow_inf_nan=False)] = 0.0
    dropped_frames: Annotated[Number, Field(ge=0.0, le=0.9, allow_inf_nan=False)] = 0.0
    exposure_ms: Annotated[Number, Field(ge=0.0, le=200.0, allow_inf_nan=False)] = 0.0
    exposure_drift: Annotated[Number, Field(ge=0.0, le=0.9, allow_inf_nan=False)] = 0.0
    exposure_period_s: Annotated[Number, Field(gt=0.0, le=600.0, allow_inf_nan=False)] = 6.0
    mark_saturation: Annotated[Number, Field(gt=0.0, le=1.0, allow_inf_nan=False)] = 1.0
    mark_saturation_spread: Annotated[Number, Field(ge=0.0, le=0.5, allow_inf_nan=False)] = 0.0
    mark_hue_spread: Annotated[Number, Field(ge=0.0, le=30.0, allow_inf_nan=False)] = 0.0
    encoder_scale: Annotated[Number, Field(ge=0.5, le=1.5, allow_inf_nan=False)] = 1.0
    encoder_noise_counts: Annotated[Number, Field(ge=0.0, le=20.0, allow_inf_nan=False)] = 0.0
    accel_mm_s2: Annotated[Number, Field(ge=0.0, le=20000.0, allow_inf_nan=False)] = 0.0
    command_delay_ms: Annotated[Number, Field(ge=0.0, le=2000.0, allow_inf_nan=False)] = 0.0
    top_speed_mm_s: Annotated[Number, Field(gt=0.0, le=500.0, allow_inf_nan=False)] = 500.0

    @field_validator("cast", mode="before")
    @classmethod
    def _known_cast(cls, value: object) -> object:
        if isinstance(value, str) and value not in CAST_GAINS_BGR:
            raise ValueError(
                f"unknown cast {value!r}: use none, warm, cool or [b, g, r] channel gains"
            )
        if not isinstance(value, (str, list, tuple)):
            raise ValueError("cast must be none, warm, cool or [b, g, r] channel gains")
        return value

    def cast_gains_bgr(self) -> tuple[float, float, float]:
        """The cast as (B, G, R) gains."""
        if isinstance(self.cast, str):
            return CAST_GAINS_BGR[self.cast]
        return (float(self.cast[0]), float(self.cast[1]), float(self.cast[2]))

    def channel_gains_bgr(self) -> tuple[float, float, float]:
        """Lighting gain times the cast, per channel (B, G, R)."""
        b, g, r = self.cast_gains_bgr()
        k = self.lighting_gain
        return (k * b, k * g, k * r)


class FrictionPatch(_Strict):
    """A patch of floor where the wheels slip: a disc of ``radius_mm`` around (x_mm, y_mm) in
    which a wheel loses ``slip`` of its travel (a rug, a polished or dusty patch). Odometry does
    not see it; one wheel on the patch and one off turns the robot."""

    x_mm: _Finite
    y_mm: _Finite
    radius_mm: Annotated[Number, Field(gt=0.0, allow_inf_nan=False)]
    slip: Annotated[Number, Field(ge=0.0, lt=1.0, allow_inf_nan=False)]

    def contains(self, x: float, y: float) -> bool:
        return (x - self.x_mm) ** 2 + (y - self.y_mm) ** 2 <= self.radius_mm ** 2


#: The sides each fault can happen on.
_FAULT_SIDES: dict[str, tuple[str, ...]] = {
    "cliff": ("left", "front_left", "front_right", "right", "both"),
    "wheel_drop": ("left", "right", "both"),
    "overcurrent": ("left", "right", "both"),
    "bump": ("left", "right", "both"),
    "low_battery": ("both",),
}


class FaultEvent(_Strict):
    """A fault that happens at ``t_s`` seconds of the run, read by the robot's own sensors (the
    byte-level simulated Create's stream packets): ``cliff`` (packets 9–12; ``both``: the two
    front sensors), ``wheel_drop`` (packet 7 bits 2–3), ``overcurrent`` (packet 14),
    ``low_battery`` (charge, packet 25, down to 2 % of capacity, packet 26; voltage 12 V) or
    ``bump`` (packet 7 bits 0–1, the robot pinned). ``side`` says which sensor; it lasts
    ``duration_s`` seconds (``null``: to the end of the run)."""

    t_s: Annotated[Number, Field(ge=0.0, allow_inf_nan=False)]
    fault: Literal["cliff", "wheel_drop", "overcurrent", "low_battery", "bump"]
    side: Literal["left", "right", "both", "front_left", "front_right"] = "both"
    duration_s: Annotated[Number, Field(gt=0.0, allow_inf_nan=False)] | None = None

    @model_validator(mode="after")
    def _side_fits(self) -> FaultEvent:
        sides = _FAULT_SIDES[self.fault]
        if self.side not in sides:
            raise ValueError(f"a {self.fault} happens on side {', '.join(sides)}, "
                             f"not {self.side}")
        return self


class Background(_Strict):
    """What the camera sees behind the marks: a textured room drawn from ``seed``, with
    ``clutter`` non-circular coloured shapes (posters, tape stripes) on the far wall."""

    seed: Annotated[Integer, Field(ge=0)] = 0
    clutter: Annotated[Integer, Field(ge=0, le=200)] = 8


class World(_Strict):
    """A simulated world. Load one with :func:`load_world` or build one with
    :func:`~marknav.sim.world.generate.generate_world`; the model validates programmatic
    construction the same way."""

    marks: tuple[MarkSpec, ...] = ()
    robot: RobotStart = RobotStart()
    walls: tuple[Wall, ...] = ()
    boxes: tuple[Box, ...] = ()
    conditions: Conditions = Conditions()
    background: Background = Background()
    patches: tuple[FrictionPatch, ...] = ()
    events: tuple[FaultEvent, ...] = ()
    #: The course: the mark (index into ``marks``) each waypoint must pass, in route order; a mark
    #: may appear more than once. ``None``: the marks in file order, one per waypoint.
    course: tuple[Annotated[Integer, Field(ge=0)], ...] | None = None
    #: What only the MuJoCo engine draws (lights, textures, occluders, distractors:
    #: :class:`marknav.sim.mujoco.scene.MujocoScene`); the built-in engine ignores it.
    mujoco: MujocoScene | None = None

    # Where each mark's colour sits in the source file (for check_against_palette).
    _source: str | None = PrivateAttr(default=None)
    _colour_positions: dict[int, Position] = PrivateAttr(default_factory=dict)
    _course_position: Position | None = PrivateAttr(default=None)
    _course_item_positions: dict[int, Position] = PrivateAttr(default_factory=dict)

    @field_validator("marks")
    @classmethod
    def _marks_apart(cls, marks: tuple[MarkSpec, ...]) -> tuple[MarkSpec, ...]:
        pair = first_overlap([m.xy for m in marks], [m.radius() for m in marks])
        if pair is not None:
            (j, i), gap = pair, math.dist(marks[pair[0]].xy, marks[pair[1]].xy)
            a, b = marks[i], marks[j]
            raise ValueError(
                f"marks[{j}] ({b.colour} at {b.x_mm:g}, {b.y_mm:g}) overlaps marks[{i}] "
                f"({a.colour} at {a.x_mm:g}, {a.y_mm:g}): centres {gap:.0f} mm apart, "
                f"radii {a.radius():g} + {b.radius():g} mm"
            )
        return marks

    @model_validator(mode="after")
    def _course_in_range(self) -> World:
        for k, i in enumerate(self.course or ()):
            if i >= len(self.marks):
                raise ValueError(f"course[{k}] is mark {i}, but the world has {len(self.marks)} "
                                 f"marks (indices 0..{len(self.marks) - 1})")
        return self

    @property
    def source(self) -> str | None:
        """The file this world was loaded from, if any."""
        return self._source

    def course_for(self, waypoints: int) -> list[int]:
        """The mark index of each of ``waypoints`` waypoints: the world's ``course``, or by
        default the first ``waypoints`` marks in file order
        (:func:`~marknav.sim.world.course.check_course` validates)."""
        if self.course is not None:
            return list(self.course)
        return list(range(min(waypoints, len(self.marks))))

    def with_mark_radius(self, radius_mm: float) -> World:
        """A copy where marks without their own ``radius_mm`` get ``radius_mm`` (the mission's)."""
        marks = tuple(
            m if m.radius_mm is not None else m.model_copy(update={"radius_mm": float(radius_mm)})
            for m in self.marks
        )
        out = World.model_validate({**self._fields_dict(), "marks": marks})
        out._source = self._source
        out._colour_positions = dict(self._colour_positions)
        out._course_position = self._course_position
        out._course_item_positions = dict(self._course_item_positions)
        return out

    def with_conditions(self, conditions: Conditions) -> World:
        """A copy with other conditions."""
        out = self.model_copy(update={"conditions": conditions})
        out._colour_positions = dict(self._colour_positions)
        return out

    def _fields_dict(self) -> dict[str, Any]:
        return {name: getattr(self, name) for name in type(self).model_fields}


def load_world(path: str | Path) -> World:
    """Read and validate a world file; any problem is an :class:`~marknav.core.errors.InputError`
    naming the file, line, column and field (``FILE:LINE:COLUMN: field: message``)."""
    doc = load_yaml_file(path)
    world = parse_model(doc, World)
    world._source = str(path)
    for i in range(len(world.marks)):
        pos = doc.positions.get(("marks", i, "colour"))
        if pos is not None:
            world._colour_positions[i] = pos
    world._course_position = doc.positions.get(("course",)) or doc.positions.get(("marks",))
    for k in range(len(world.course or ())):
        item = doc.positions.get(("course", k))
        if item is not None:
            world._course_item_positions[k] = item
    return world

