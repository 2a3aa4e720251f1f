"""The simulated world: marks, robot start, walls, conditions; contacts.

Implements the world part of issue 5 (the simulator), in the frames of ``docs/architecture.md``:
world x east, y north, heading θ counter-clockwise from +x, millimetres; degrees only in the file
(keys ending in ``_deg``).

- A **world file** (YAML, validated by the pydantic models below through :mod:`marknav.core.yamlio`,
  unknown keys rejected everywhere) lists the marks, the robot's start pose, walls and boxes,
  image/wheel conditions and the background seed. :func:`load_world` reads one;
  :func:`check_against_palette` checks its colours against a mission's palette.
- :func:`generate_world` builds a world from a mission's route when no file is given: marks in
  route order along +y, spacing and lateral offsets within the module constants below, so that
  every mark can be bypassed with the mission's clearance and the next one is in view (or a short
  search turn away) from where the previous bypass ends. Deterministic for a seed.
- **Contacts**: the robot is a disc (Create: 330 mm); a mark is a thin disc standing on the floor,
  treated in the top view as a circle of its radius around its centre (conservative); walls are
  segments, boxes rectangles. :func:`contacts` gives each touching obstacle with the contact angle
  relative to the heading and the bumper bits it presses (left half of the front, right half, both
  when nearly straight ahead; no bit behind the bumper's arc).
- **Run-report measures from ground truth** live in :mod:`marknav.runs.metrics` (passes, truth).

A mark's ``yaw_deg`` turns the disc's face about the vertical: 0 means its normal points along −y
(toward a robot at the origin facing +y); positive turns it counter-clockwise seen from above. Yaw
is absolute (world frame), not relative to the robot's start heading.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, PrivateAttr, field_validator, model_validator

from marknav.core.errors import InputError, InputErrors
from marknav.core.yamlio import Position, load_yaml_file, parse_model
from marknav.planning.kinematics import Pose, wrap_angle
from marknav.sim.lens import Lens, random_lens
from marknav.sim.mujoco.scene import MARK_YAW_MAX_DEG as MUJOCO_MARK_YAW_MAX_DEG
from marknav.sim.mujoco.scene import MujocoScene, random_scene
from marknav.sim.overlap import first_overlap
from marknav.sim.scenery import random_room
from marknav.vision.palette import ColourRange

__all__ = [
    "BOTH_BUMPS_HALF_ANGLE_DEG",
    "BUMPER_HALF_ARC_DEG",
    "CAST_GAINS_BGR",
    "CREATE_RADIUS_MM",
    "DEFAULT_HALF_FOV_DEG",
    "DEFAULT_MARK_RADIUS_MM",
    "Background",
    "Box",
    "Bumps",
    "ClutterItem",
    "Conditions",
    "Contact",
    "FaultEvent",
    "FrictionPatch",
    "MarkSpec",
    "RobotStart",
    "Wall",
    "World",
    "bumper_sides",
    "bumps",
    "check_against_palette",
    "check_course",
    "clutter_items",
    "contacts",
    "generate_world",
    "load_world",
    "push_out",
    "random_conditions",
    "random_patches",
    "random_realism",
]

#: A mark's radius when neither the world file nor the caller gives one (the brief's example).
DEFAULT_MARK_RADIUS_MM = 100.0
#: The Create is a 330 mm disc.
CREATE_RADIUS_MM = 165.0
#: Half the horizontal field of view of the default camera (640 px wide, f = 590 px).
DEFAULT_HALF_FOV_DEG = math.degrees(math.atan(320.0 / 590.0))

# --- bumper model -----------------------------------------------------------------------------
#: The bumper covers the front half of the robot: contacts within ±90° of the heading press it.
BUMPER_HALF_ARC_DEG = 90.0
#: A contact within ±10° of straight ahead presses both halves.
BOTH_BUMPS_HALF_ANGLE_DEG = 10.0

# --- colour casts -----------------------------------------------------------------------------
#: Per-channel gains (B, G, R) of the named casts: warm = incandescent-like, cool = shade-like.
CAST_GAINS_BGR: dict[str, tuple[float, float, float]] = {
    "none": (1.0, 1.0, 1.0),
    "warm": (0.80, 1.0, 1.20),
    "cool": (1.20, 1.0, 0.80),
}

# --- randomised conditions (the evaluation draws from these) --------------------------------
LIGHTING_GAIN_RANGE = (0.5, 1.5)
RANDOM_CASTS: tuple[str, ...] = ("none", "warm", "cool")
NOISE_SIGMA_RANGE = (1.0, 6.0)  # grey levels
BLUR_SIGMA_RANGE_PX = (0.0, 1.2)  # Gaussian σ
WHEEL_MISMATCH_MAX = 0.05  # |right/left − 1|
WHEEL_SLIP_MAX = 0.02
LATENCY_FRAMES_RANGE = (0, 2)
MARK_YAW_MAX_DEG = 45.0

# --- randomised realism (docs/explanation/simulator-realism.md: each range's source) ------
#: Camera frame rate, Hz: UVC webcams deliver 30 fps, and 15 fps when auto-exposure lengthens
#: the exposure in dim indoor light.
FRAME_RATE_RANGE_HZ = (15.0, 30.0)
#: Fraction of frames that never arrive (a busy USB bus, MJPEG over Wi-Fi).
DROPPED_FRAMES_RANGE = (0.0, 0.05)
#: Exposure time, ms: indoor auto-exposure runs 5 ms up to a whole frame period (33 ms at 30 fps).
EXPOSURE_RANGE_MS = (5.0, 33.0)
#: Amplitude of auto-exposure's slow brightness swing (fraction), and its period, s.
EXPOSURE_DRIFT_RANGE = (0.0, 0.15)
EXPOSURE_PERIOD_RANGE_S = (3.0, 10.0)
#: Saturation of printed marks relative to full (inkjet and laser primaries on paper, as a
#: camera sees them), and the spread of saturation and hue from mark to mark.
MARK_SATURATION_RANGE = (0.75, 1.0)
MARK_SATURATION_SPREAD_MAX = 0.08
MARK_HUE_SPREAD_MAX = 3.0
#: Encoder counts per nominal count (worn tyres, a wheel off the spec's 72 mm diameter).
ENCODER_SCALE_RANGE = (0.98, 1.02)
#: σ of encoder noise per wheel and 15 ms tick, counts (0.44 mm per count, Create 2).
ENCODER_NOISE_RANGE_COUNTS = (0.0, 1.0)
#: Wheel acceleration, mm/s² (not in the OI spec; see the realism page).
ACCEL_RANGE_MM_S2 = (400.0, 1000.0)
#: Delay from a host write to the robot acting on it, ms: a USB-serial adapter 1–16 ms (FTDI
#: latency timer), Bluetooth serial up to ~40 ms.
COMMAND_DELAY_RANGE_MS = (1.0, 40.0)
#: Top wheel speed with the battery's voltage under load, mm/s (users report 330 for 500 commanded).
TOP_SPEED_RANGE_MM_S = (330.0, 500.0)
#: Friction patches (rugs, polished or dusty floor) per generated world, their radius and slip.
PATCHES_RANGE = (0, 2)
PATCH_RADIUS_RANGE_MM = (300.0, 600.0)
PATCH_SLIP_RANGE = (0.02, 0.15)

# --- generated courses ------------------------------------------------------------------------
#: Distance along the course between consecutive marks.
SPACING_RANGE_MM = (1200.0, 2000.0)
#: Distance from the start to the first mark.
FIRST_MARK_RANGE_MM = (1300.0, 2000.0)
#: Lateral offset of a mark from the course's axis; signs alternate mark to mark.
LATERAL_OFFSET_RANGE_MM = (100.0, 450.0)
#: After a bypass, the next mark must be at least ``bypass_distance_mm`` plus this far away,
#: so the robot sees it and approaches before its own bypass starts.
REACQUIRE_MARGIN_MM = 300.0
#: The next mark may lie this far outside the field of view at the end of a bypass (a short
#: search turn finds it).
MAX_SEARCH_TURN_DEG = 15.0
#: The first mark is this far inside the field of view from the start pose.
FIRST_MARK_FOV_MARGIN_DEG = 8.0
#: Random draws per mark on the alternating side (then as many on the other side) before falling
#: back to a mark on the course's axis.
GENERATION_TRIES = 200

# --- background clutter -----------------------------------------------------------------------
#: Clutter stays this far above or below the horizon, where the marks' centres are: a mark
#: farther than ~1.2 m (radius < 50 px at f = 590) never touches it.
CLUTTER_CLEAR_DEG = 5.0
CLUTTER_MAX_ELEVATION_DEG = 21.0
#: Hues of common mark colours (OpenCV units): half of the clutter is drawn near one of them.
_LOOKALIKE_HUES = (0.0, 15.0, 28.0, 62.0, 112.0, 150.0)

_Finite = Annotated[float, Field(allow_inf_nan=False)]
_Gain = Annotated[float, Field(gt=0.0, le=4.0, allow_inf_nan=False)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class MarkSpec(_Strict):
    """One mark: a disc of ``colour`` standing at (x_mm, y_mm), its face turned by ``yaw_deg``."""

    colour: str = Field(min_length=1)
    x_mm: _Finite
    y_mm: _Finite
    yaw_deg: _Finite = 0.0
    radius_mm: Annotated[float, Field(gt=0.0, le=2000.0, allow_inf_nan=False)] | None = None

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
    width_mm: Annotated[float, Field(gt=0.0, allow_inf_nan=False)]
    depth_mm: Annotated[float, Field(gt=0.0, allow_inf_nan=False)]
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
    - ``wheel_slip``: fraction of each wheel's travel lost to slip; the encoders do not see it.
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
    - Room (:mod:`marknav.sim.scenery`): ``floor`` (``plain``, ``wood``, ``carpet``) at
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
    noise_sigma: Annotated[float, Field(ge=0.0, le=64.0, allow_inf_nan=False)] = 2.0
    blur_sigma_px: Annotated[float, Field(ge=0.0, le=10.0, allow_inf_nan=False)] = 0.0
    wheel_mismatch: Annotated[float, Field(ge=-0.5, le=0.5, allow_inf_nan=False)] = 0.0
    wheel_slip: Annotated[float, Field(ge=0.0, lt=1.0, allow_inf_nan=False)] = 0.0
    latency_frames: Annotated[int, Field(ge=0, le=30)] = 0
    camera_latency_s: Annotated[float, Field(ge=0.0, le=2.0, allow_inf_nan=False)] = 0.0
    processing_s: Annotated[float, Field(ge=0.0, le=1.0, allow_inf_nan=False)] = 0.0
    camera_pitch_deg: Annotated[float, Field(ge=-30.0, le=30.0, allow_inf_nan=False)] = 0.0
    camera_roll_deg: Annotated[float, Field(ge=-30.0, le=30.0, allow_inf_nan=False)] = 0.0
    mark_height_offset_mm: Annotated[float, Field(ge=-1000.0, le=1000.0,
                                                  allow_inf_nan=False)] = 0.0
    floor: Literal["plain", "wood", "carpet"] = "plain"
    floor_saturation: Annotated[float, Field(ge=0.0, le=255.0, allow_inf_nan=False)] = 120.0
    wall: Literal["plain", "photo"] = "plain"
    wall_hue: Annotated[float, Field(ge=0.0, lt=180.0, allow_inf_nan=False)] | None = None
    occluders: Annotated[int, Field(ge=0, le=20)] = 0
    distractors: Annotated[int, Field(ge=0, le=40)] = 0
    #: The camera's lens (distortion, principal point): :class:`marknav.sim.lens.Lens`.
    lens: Lens = Lens()
    frame_rate_hz: Annotated[float, Field(ge=0.0, le=240.0, allow_inf_nan=False)] = 0.0
    dropped_frames: Annotated[float, Field(ge=0.0, le=0.9, allow_inf_nan=False)] = 0.0
    exposure_ms: Annotated[float, Field(ge=0.0, le=200.0, allow_inf_nan=False)] = 0.0
    exposure_drift: Annotated[float, Field(ge=0.0, le=0.9, allow_inf_nan=False)] = 0.0
    exposure_period_s: Annotated[float, Field(gt=0.0, le=600.0, allow_inf_nan=False)] = 6.0
    mark_saturation: Annotated[float, Field(gt=0.0, le=1.0, allow_inf_nan=False)] = 1.0
    mark_saturation_spread: Annotated[float, Field(ge=0.0, le=0.5, allow_inf_nan=False)] = 0.0
    mark_hue_spread: Annotated[float, Field(ge=0.0, le=30.0, allow_inf_nan=False)] = 0.0
    encoder_scale: Annotated[float, Field(ge=0.5, le=1.5, allow_inf_nan=False)] = 1.0
    encoder_noise_counts: Annotated[float, Field(ge=0.0, le=20.0, allow_inf_nan=False)] = 0.0
    accel_mm_s2: Annotated[float, Field(ge=0.0, le=20000.0, allow_inf_nan=False)] = 0.0
    command_delay_ms: Annotated[float, Field(ge=0.0, le=2000.0, allow_inf_nan=False)] = 0.0
    top_speed_mm_s: Annotated[float, Field(gt=0.0, le=500.0, allow_inf_nan=False)] = 500.0

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
    radius_mm: Annotated[float, Field(gt=0.0, allow_inf_nan=False)]
    slip: Annotated[float, Field(ge=0.0, lt=1.0, allow_inf_nan=False)]

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

    t_s: Annotated[float, Field(ge=0.0, allow_inf_nan=False)]
    fault: Literal["cliff", "wheel_drop", "overcurrent", "low_battery", "bump"]
    side: Literal["left", "right", "both", "front_left", "front_right"] = "both"
    duration_s: Annotated[float, Field(gt=0.0, allow_inf_nan=False)] | None = None

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

    seed: Annotated[int, Field(ge=0)] = 0
    clutter: Annotated[int, Field(ge=0, le=200)] = 8


class World(_Strict):
    """A simulated world. Load one with :func:`load_world` or build one with
    :func:`generate_world`; the model validates programmatic construction the same way."""

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
    course: tuple[Annotated[int, Field(ge=0)], ...] | None = None
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
        default the first ``waypoints`` marks in file order (:func:`check_course` validates)."""
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
    """Read and validate a world file; any problem is an :class:`InputError` naming the file,
    line, column and field (``FILE:LINE:COLUMN: field: message``)."""
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


def check_course(world: World, route: Sequence[str], file: str | Path | None = None) -> None:
    """Raise :class:`InputError` if the world's course does not fit the route: one mark per
    waypoint, each of the waypoint's colour (errors name the file and the ``course`` line — the
    ``marks`` line when the world has no ``course`` — or the mark's line for a colour)."""
    where = str(file) if file is not None else world.source
    pos = world._course_position
    errors: list[InputError] = []
    if world.course is None:
        if len(world.marks) < len(route):
            errors.append(InputError(
                f"the route has {len(route)} waypoints but the world only {len(world.marks)} "
                f"marks: say which mark each waypoint passes with course: [i, ...] (mark "
                f"indices, repeats allowed)", file=where, line=pos.line if pos else None,
                column=pos.column if pos else None, field="course"))
    elif len(world.course) != len(route):
        errors.append(InputError(
            f"{len(world.course)} entries for a route of {len(route)} waypoints (one mark index "
            f"per waypoint)", file=where, line=pos.line if pos else None,
            column=pos.column if pos else None, field="course"))
    if not errors:
        course = world.course_for(len(route))
        for w, (colour, i) in enumerate(zip(route, course, strict=True)):
            mark = world.marks[i]
            if mark.colour == colour:
                continue
            if world.course is None:
                mpos = world._colour_positions.get(i)
                line, column, fld = (mpos.line if mpos else None, mpos.column if mpos else None,
                                     f"marks[{i}].colour")
                hint = " (the default course is the marks in file order; or give course:)"
            else:
                ipos = world._course_item_positions.get(w, pos)
                line, column, fld = (ipos.line if ipos else None, ipos.column if ipos else None,
                                     f"course[{w}]")
                hint = ""
            errors.append(InputError(
                f"waypoint {w + 1} of the route is {colour!r} but its mark {i} is "
                f"{mark.colour!r}{hint}", file=where, line=line, column=column, field=fld))
    if errors:
        raise InputErrors(errors)


def check_against_palette(
    world: World, palette: Sequence[ColourRange], file: str | Path | None = None
) -> None:
    """Raise :class:`InputError` (one per offending mark, with the mark's line when the world
    came from a file) if a mark's colour is not in the mission's palette."""
    import difflib

    names = [c.name for c in palette]
    where = str(file) if file is not None else world.source
    errors: list[InputError] = []
    for i, mark in enumerate(world.marks):
        if mark.colour in names:
            continue
        close = difflib.get_close_matches(mark.colour, names, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        pos = world._colour_positions.get(i)
        errors.append(
            InputError(
                f"colour {mark.colour!r} is not in the mission's palette "
                f"({', '.join(sorted(names)) or 'empty'}){hint}",
                file=where,
                line=pos.line if pos else None,
                column=pos.column if pos else None,
                field=f"marks[{i}].colour",
            )
        )
    if errors:
        raise InputErrors(errors)


# --- generated worlds -------------------------------------------------------------------------


def random_conditions(rng: np.random.Generator) -> Conditions:
    """Conditions drawn uniformly from the module's ranges (what ``evaluate`` randomises)."""
    lo, hi = LATENCY_FRAMES_RANGE
    return Conditions(
        lighting_gain=float(rng.uniform(*LIGHTING_GAIN_RANGE)),
        cast=RANDOM_CASTS[int(rng.integers(len(RANDOM_CASTS)))],  # type: ignore[arg-type]
        noise_sigma=float(rng.uniform(*NOISE_SIGMA_RANGE)),
        blur_sigma_px=float(rng.uniform(*BLUR_SIGMA_RANGE_PX)),
        wheel_mismatch=float(rng.uniform(-WHEEL_MISMATCH_MAX, WHEEL_MISMATCH_MAX)),
        wheel_slip=float(rng.uniform(0.0, WHEEL_SLIP_MAX)),
        latency_frames=int(rng.integers(lo, hi + 1)),
    )


def random_realism(rng: np.random.Generator) -> dict[str, float]:
    """The realism conditions (camera timing and exposure, printed marks, encoders, wheels,
    command link, battery) drawn uniformly from the module's ranges, as updates to
    :class:`Conditions`. From its own random stream, so the other draws of a world stay put."""
    def draw(lo_hi: tuple[float, float]) -> float:
        return float(rng.uniform(*lo_hi))

    return {
        "frame_rate_hz": round(draw(FRAME_RATE_RANGE_HZ), 1),
        "dropped_frames": draw(DROPPED_FRAMES_RANGE),
        "exposure_ms": draw(EXPOSURE_RANGE_MS),
        "exposure_drift": draw(EXPOSURE_DRIFT_RANGE),
        "exposure_period_s": draw(EXPOSURE_PERIOD_RANGE_S),
        "mark_saturation": draw(MARK_SATURATION_RANGE),
        "mark_saturation_spread": draw((0.0, MARK_SATURATION_SPREAD_MAX)),
        "mark_hue_spread": draw((0.0, MARK_HUE_SPREAD_MAX)),
        "encoder_scale": draw(ENCODER_SCALE_RANGE),
        "encoder_noise_counts": draw(ENCODER_NOISE_RANGE_COUNTS),
        "accel_mm_s2": draw(ACCEL_RANGE_MM_S2),
        "command_delay_ms": draw(COMMAND_DELAY_RANGE_MS),
        "top_speed_mm_s": draw(TOP_SPEED_RANGE_MM_S),
    }


def random_patches(
    rng: np.random.Generator, course: Sequence[tuple[float, float]], start: tuple[float, float]
) -> tuple[FrictionPatch, ...]:
    """Friction patches on the way: each centred at a random point of a random leg of the course
    (start → first mark, mark → mark), its radius and slip drawn from the module's ranges."""
    lo, hi = PATCHES_RANGE
    n = int(rng.integers(lo, hi + 1))
    points = [start, *course]
    out: list[FrictionPatch] = []
    for _ in range(n if len(points) > 1 else 0):
        leg = int(rng.integers(len(points) - 1))
        f = float(rng.uniform(0.2, 0.8))
        a, b = points[leg], points[leg + 1]
        out.append(FrictionPatch(
            x_mm=round(a[0] + f * (b[0] - a[0]), 1), y_mm=round(a[1] + f * (b[1] - a[1]), 1),
            radius_mm=round(float(rng.uniform(*PATCH_RADIUS_RANGE_MM)), 1),
            slip=round(float(rng.uniform(*PATCH_SLIP_RANGE)), 3)))
    return tuple(out)


def _bearing(frm: tuple[float, float], heading: float, to: tuple[float, float]) -> float:
    return wrap_angle(math.atan2(to[1] - frm[1], to[0] - frm[0]) - heading)


def generate_world(
    route: Sequence[str],
    *,
    seed: int,
    clearance_mm: float,
    radius_mm: float = DEFAULT_MARK_RADIUS_MM,
    conditions: Literal["randomised", "default"] | Conditions = "default",
    bypass_distance_mm: float = 800.0,
    sides: Sequence[Literal["left", "right"]] | None = None,
    half_fov_deg: float = DEFAULT_HALF_FOV_DEG,
    start: RobotStart | None = None,
    clutter: int = Background().clutter,
    engine: Literal["builtin", "mujoco"] = "builtin",
    patches: bool = False,
) -> World:
    """A world for ``route`` (colours in order) that the route can be driven through.

    Marks go along +y from the start (default pose), each ``SPACING_RANGE_MM`` after the previous
    one (``FIRST_MARK_RANGE_MM`` for the first), offset sideways by ``LATERAL_OFFSET_RANGE_MM`` with
    alternating signs. A draw is kept only if (a) the first mark is in full view from the start,
    (b) from where each bypass ends — beside the mark at ``clearance_mm`` on the side to pass
    (both sides when ``sides`` is not given), heading as when the bypass began — the next mark is
    at least ``bypass_distance_mm + REACQUIRE_MARGIN_MM`` away and within the field of view plus
    ``MAX_SEARCH_TURN_DEG``. After ``GENERATION_TRIES`` failed draws the offset's side flips; after
    as many again the mark goes on the axis, at the longest spacing. With
    ``conditions="randomised"`` the image/wheel conditions (:func:`random_conditions`) and every
    mark's yaw (±``MARK_YAW_MAX_DEG``) are drawn too, and from streams of their own the
    realism conditions (:func:`random_realism`) and, with ``patches``, friction patches on the
    course (:func:`random_patches`: not drawn by default — a patch under one wheel during a
    bypass, with the mark out of view, turns the robot where odometry cannot see it; see
    docs/explanation/simulator-realism.md). For ``engine="mujoco"`` the yaw goes up to ±60° and
    the room gets MuJoCo's lights, textures, occluders and distractors
    (:func:`marknav.sim.mujoco.scene.random_scene`, its own stream: the course is the same).
    Same arguments and seed → same world.
    """
    if clearance_mm <= 0 or radius_mm <= 0 or bypass_distance_mm <= 0:
        raise ValueError("clearance, radius and bypass distance must be positive")
    if sides is not None and len(sides) != len(route):
        raise ValueError(f"sides has {len(sides)} entries for a route of {len(route)}")
    rng = np.random.default_rng([int(seed), 0x5EED])
    robot = start if start is not None else RobotStart()
    randomised = conditions == "randomised"
    if isinstance(conditions, Conditions):
        cond = conditions
    elif randomised:
        cond = random_conditions(rng)
        cond = cond.model_copy(update=random_room(int(seed)))  # harder rooms, own stream
        # The lens from its own stream, so the other draws stay what they were.
        cond = cond.model_copy(update={"lens": random_lens(np.random.default_rng([int(seed),
                                                                                0x1E45]))})
        realism = np.random.default_rng([int(seed), 0x4EA1])
        cond = cond.model_copy(update=random_realism(realism))
    elif conditions == "default":
        cond = Conditions()
    else:
        raise ValueError(f"conditions must be 'randomised', 'default' or Conditions: {conditions}")

    # One draw in [-1, 1) scaled by the engine's limit: both engines' courses are the same.
    yaw_max = MUJOCO_MARK_YAW_MAX_DEG if engine == "mujoco" else MARK_YAW_MAX_DEG
    half_fov = math.radians(half_fov_deg)
    reacquire = bypass_distance_mm + REACQUIRE_MARGIN_MM
    spacing_lo = max(SPACING_RANGE_MM[0], reacquire + clearance_mm)
    spacing_hi = max(SPACING_RANGE_MM[1], spacing_lo + 200.0)
    first_lo = max(FIRST_MARK_RANGE_MM[0], reacquire)
    first_hi = max(FIRST_MARK_RANGE_MM[1], first_lo + 200.0)

    p0 = robot.pose()
    fwd = (math.cos(p0.theta), math.sin(p0.theta))
    left = (-fwd[1], fwd[0])
    sign = 1.0 if rng.random() < 0.5 else -1.0

    marks: list[MarkSpec] = []
    # Where the robot can be when it starts looking for the next mark, with its heading then.
    origins: list[tuple[tuple[float, float], float]] = [((p0.x, p0.y), p0.theta)]
    along = 0.0
    for i, colour in enumerate(route):
        first = i == 0
        lo, hi = (first_lo, first_hi) if first else (spacing_lo, spacing_hi)
        chosen: tuple[float, float, float] | None = None
        for attempt in range(2 * GENERATION_TRIES):
            # The alternating side first; then the other side, before giving up.
            side_sign = sign if attempt < GENERATION_TRIES else -sign
            step = round(float(rng.uniform(lo, hi)), 1)
            off = round(side_sign * float(rng.uniform(*LATERAL_OFFSET_RANGE_MM)), 1)
            a = along + step
            m = (p0.x + a * fwd[0] + off * left[0], p0.y + a * fwd[1] + off * left[1])
            ok = True
            for o_xy, o_heading in origins:
                dist = math.dist(o_xy, m)
                angular_r = math.asin(min(1.0, radius_mm / dist))
                limit = (half_fov - math.radians(FIRST_MARK_FOV_MARGIN_DEG) - angular_r if first
                         else half_fov + math.radians(MAX_SEARCH_TURN_DEG))
                if dist < reacquire or abs(_bearing(o_xy, o_heading, m)) > limit:
                    ok = False
                    break
            if ok:
                chosen = (a, off, step)
                break
        if chosen is None:
            # Straight down the axis: in view from the previous origins by construction.
            chosen = (along + hi, 0.0, hi)
        a, off, _ = chosen
        along = a
        if off != 0.0:
            sign = math.copysign(1.0, off)
        m = (p0.x + a * fwd[0] + off * left[0], p0.y + a * fwd[1] + off * left[1])
        yaw = float(rng.uniform(-1.0, 1.0)) * yaw_max if randomised else 0.0
        if first or not randomised:
            yaw += math.degrees(p0.theta - math.pi / 2.0)  # face the course's start direction
        else:
            # Turned relative to the line of sight from where the robot will look for it (the
            # previous bypass ends), so ±MARK_YAW_MAX_DEG is the angle the camera sees it at: a
            # yaw drawn against the course could leave the mark edge-on, a sliver no camera finds.
            sx = sum(m[0] - o[0][0] for o in origins)
            sy = sum(m[1] - o[0][1] for o in origins)
            yaw += math.degrees(math.atan2(-sx, sy))  # normal (sin yaw, -cos yaw) toward them
        marks.append(MarkSpec(colour=colour, x_mm=round(m[0], 1), y_mm=round(m[1], 1),
                              yaw_deg=round(yaw, 2), radius_mm=radius_mm))
        # The bypass of this mark begins where the robot, coming from the previous origins,
        # heads at the mark; it ends beside the mark at the clearance, heading unchanged.
        new_origins: list[tuple[tuple[float, float], float]] = []
        wanted = [sides[i]] if sides is not None else ["left", "right"]
        for o_xy, _o_heading in origins:
            h = math.atan2(m[1] - o_xy[1], m[0] - o_xy[0])
            n = (-math.sin(h), math.cos(h))
            for side in wanted:
                s = 1.0 if side == "left" else -1.0  # pass on the mark's left: robot on its left
                w = (m[0] + s * clearance_mm * n[0], m[1] + s * clearance_mm * n[1])
                new_origins.append((w, h))
        # Keep the set small: the extreme ends are the binding ones.
        origins = new_origins[:4] if len(new_origins) <= 4 else [
            new_origins[0], new_origins[1], new_origins[-2], new_origins[-1]]
        sign = -sign
    scene = None
    if engine == "mujoco" and randomised:
        scene = random_scene(int(seed), [(m.x_mm - p0.x, m.y_mm - p0.y) for m in marks],
                             list(route), clearance_mm=clearance_mm)
    drawn = (random_patches(np.random.default_rng([int(seed), 0xF41C]),
                            [m.xy for m in marks], (p0.x, p0.y)) if randomised and patches
             else ())
    return World(
        marks=tuple(marks),
        robot=robot,
        conditions=cond,
        background=Background(seed=int(seed), clutter=clutter),
        patches=drawn,
        course=tuple(range(len(marks))),
        mujoco=scene,
    )


# --- background clutter -----------------------------------------------------------------------


@dataclass(frozen=True)
class ClutterItem:
    """A non-circular coloured shape on the far wall, in angular coordinates around the robot.

    ``kind`` is ``"rect"`` (a poster, aspect ≥ 2) or ``"stripes"`` (``bars`` parallel bars).
    Azimuth is in the world frame (CCW from +x); elevation is above the horizon (negative below).
    """

    kind: Literal["rect", "stripes"]
    azimuth_deg: float
    elevation_deg: float
    width_deg: float
    height_deg: float
    hue: float  # OpenCV units 0..179
    sat: int
    val: int
    bars: int = 1


def clutter_items(world: World | Background) -> tuple[ClutterItem, ...]:
    """The world's background clutter, drawn from ``background.seed`` (deterministic)."""
    background = world.background if isinstance(world, World) else world
    rng = np.random.default_rng([background.seed, 0xC1077E5])
    items: list[ClutterItem] = []
    for _ in range(background.clutter):
        kind: Literal["rect", "stripes"] = "rect" if rng.random() < 0.6 else "stripes"
        long_side = float(rng.uniform(4.0, 14.0))
        short_side = long_side / float(rng.uniform(2.2, 5.0))
        if rng.random() < 0.5:
            w, h = long_side, short_side
        else:
            w, h = short_side, long_side
        if kind == "stripes":
            w, h = max(w, h), max(w, h) * float(rng.uniform(0.4, 0.9))
        h = min(h, CLUTTER_MAX_ELEVATION_DEG - CLUTTER_CLEAR_DEG - 0.5)
        lo = CLUTTER_CLEAR_DEG + h / 2.0
        hi = CLUTTER_MAX_ELEVATION_DEG - h / 2.0
        elev = float(rng.uniform(lo, max(lo, hi)))
        if rng.random() < 0.3:
            elev = -elev
        if rng.random() < 0.5:
            hue = float(_LOOKALIKE_HUES[int(rng.integers(len(_LOOKALIKE_HUES)))]
                        + rng.uniform(-6.0, 6.0)) % 180.0
        else:
            hue = float(rng.uniform(0.0, 180.0))
        items.append(
            ClutterItem(
                kind=kind,
                azimuth_deg=float(rng.uniform(0.0, 360.0)),
                elevation_deg=elev,
                width_deg=w,
                height_deg=h,
                hue=hue,
                sat=int(rng.integers(140, 256)),
                val=int(rng.integers(110, 231)),
                bars=int(rng.integers(3, 6)) if kind == "stripes" else 1,
            )
        )
    return tuple(items)


# --- contacts ---------------------------------------------------------------------------------


def bumper_sides(angle_rad: float) -> tuple[bool, bool]:
    """(left, right): which bumper switches a contact at ``angle_rad`` from the heading (left
    positive) presses: each side's arc of :data:`BUMPER_HALF_ARC_DEG`, both within
    :data:`BOTH_BUMPS_HALF_ANGLE_DEG` of straight ahead."""
    a = math.degrees(angle_rad)
    return (-BOTH_BUMPS_HALF_ANGLE_DEG <= a <= BUMPER_HALF_ARC_DEG,
            -BUMPER_HALF_ARC_DEG <= a <= BOTH_BUMPS_HALF_ANGLE_DEG)


@dataclass(frozen=True)
class Contact:
    """The robot touching an obstacle.

    ``kind`` and ``index`` name it (``world.marks[index]``, ``walls[index]``, ``boxes[index]``);
    (x_mm, y_mm) is the contact point on the robot's rim; ``angle_rad`` is its direction from the
    robot's centre relative to the heading, positive to the left, in (−π, π]; ``depth_mm`` is how
    far the obstacle reaches inside the robot's disc (0 when just touching).
    """

    kind: Literal["mark", "wall", "box"]
    index: int
    x_mm: float
    y_mm: float
    angle_rad: float
    depth_mm: float

    @property
    def bump_left(self) -> bool:
        return bumper_sides(self.angle_rad)[0]

    @property
    def bump_right(self) -> bool:
        return bumper_sides(self.angle_rad)[1]


@dataclass(frozen=True)
class Bumps:
    """The bumper bits a set of contacts presses (OI packet 7 bits 1 and 0)."""

    left: bool
    right: bool


def _closest_on_segment(
    p: tuple[float, float], a: tuple[float, float], b: tuple[float, float]
) -> tuple[float, float]:
    abx, aby = b[0] - a[0], b[1] - a[1]
    t = ((p[0] - a[0]) * abx + (p[1] - a[1]) * aby) / (abx * abx + aby * aby)
    t = min(1.0, max(0.0, t))
    return (a[0] + t * abx, a[1] + t * aby)


def _contact(
    pose: Pose, kind: Literal["mark", "wall", "box"], index: int, towards: tuple[float, float],
    depth: float, robot_radius_mm: float,
) -> Contact:
    dx, dy = towards[0] - pose.x, towards[1] - pose.y
    direction = math.atan2(dy, dx) if (dx or dy) else pose.theta
    return Contact(
        kind=kind,
        index=index,
        x_mm=pose.x + robot_radius_mm * math.cos(direction),
        y_mm=pose.y + robot_radius_mm * math.sin(direction),
        angle_rad=wrap_angle(direction - pose.theta),
        depth_mm=max(0.0, depth),
    )


def contacts(
    world: World, pose: Pose, *, robot_radius_mm: float = CREATE_RADIUS_MM
) -> list[Contact]:
    """Every mark, wall and box the robot (a disc of ``robot_radius_mm`` at ``pose``) touches."""
    out: list[Contact] = []
    p = (pose.x, pose.y)
    for i, m in enumerate(world.marks):
        reach = robot_radius_mm + m.radius()
        d = math.dist(p, m.xy)
        if d <= reach:
            out.append(_contact(pose, "mark", i, m.xy, reach - d, robot_radius_mm))
    for i, w in enumerate(world.walls):
        q = _closest_on_segment(p, *w.segment())
        d = math.dist(p, q)
        if d <= robot_radius_mm:
            out.append(_contact(pose, "wall", i, q, robot_radius_mm - d, robot_radius_mm))
    for i, box in enumerate(world.boxes):
        corners = box.corners()
        best: tuple[float, float] | None = None
        for k in range(4):
            q = _closest_on_segment(p, corners[k], corners[(k + 1) % 4])
            if best is None or math.dist(p, q) < math.dist(p, best):
                best = q
        assert best is not None
        inside = box.contains(*p)
        d = math.dist(p, best)
        if inside or d <= robot_radius_mm:
            towards = (box.x_mm, box.y_mm) if inside else best
            depth = robot_radius_mm + d if inside else robot_radius_mm - d
            out.append(_contact(pose, "box", i, towards, depth, robot_radius_mm))
    return out


def bumps(found: Sequence[Contact]) -> Bumps:
    """The bumper bits pressed by ``found`` (contacts behind the bumper's arc press none)."""
    return Bumps(left=any(c.bump_left for c in found), right=any(c.bump_right for c in found))


def push_out(
    world: World, pose: Pose, *, robot_radius_mm: float = CREATE_RADIUS_MM, iterations: int = 8
) -> Pose:
    """The nearest pose (same heading) where the robot no longer overlaps anything: each contact
    pushes the centre away from it by its depth; a few rounds settle corners."""
    x, y = pose.x, pose.y
    for _ in range(iterations):
        found = contacts(world, Pose(x, y, pose.theta), robot_radius_mm=robot_radius_mm)
        moved = False
        for c in found:
            if c.depth_mm <= 1e-9:
                continue
            direction = pose.theta + c.angle_rad
            x -= (c.depth_mm + 1e-6) * math.cos(direction)
            y -= (c.depth_mm + 1e-6) * math.sin(direction)
            moved = True
        if not moved:
            break
    return Pose(x, y, pose.theta)
