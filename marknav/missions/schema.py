"""The mission file: its schema, its checks and loading it with line-numbered errors.

Implements the design brief's "Mission file" section (every key it lists, with its meaning),
plus optional keys with defaults so a minimal mission is ``name``, ``route`` and ``marks``.
Ranges come from the hardware and the paper:

- wheel speeds are limited to ±500 mm/s by the Create Open Interface (Drive/Drive Direct, both
  Create 1 and Create 2 specifications);
- ``camera.range`` is the paper's range model: ``power`` is eq. 19 (d = a·r^b, the fit of Table 1,
  a = 58958, b = −0.9434), ``pinhole`` is eq. 18 in the far-field form d = f·R / r;
- ``navigation.clearance_mm`` is the distance from the robot's centre to the mark's centre while
  passing it, so it must exceed the robot's radius plus the mark's radius.

Loading goes through :mod:`marknav.core.yamlio` (safe loader, duplicate keys rejected, positions of
every node kept). Every problem is reported, as ``FILE:LINE:COLUMN: field.path: message``;
cross-field problems point at the field the author most likely has to change: the one written in
the file, and among those the first listed in each check.
"""

from __future__ import annotations

import difflib
import math
import unicodedata
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PrivateAttr,
    ValidationError,
    ValidationInfo,
    ValidatorFunctionWrapHandler,
    field_validator,
    model_validator,
)
from pydantic_core import InitErrorDetails, PydanticCustomError

from marknav.core.errors import InputError, InputErrors
from marknav.core.yamlio import Loc, Position, YamlDocument, load_yaml_file, validation_errors
from marknav.missions.overrides import Override, apply_overrides, relabel
from marknav.missions.plugins import default_registry, registry_with_plugins
from marknav.missions.registry import UNKNOWN_KEY, NodeRegistry, TreeNode, model_problems
from marknav.missions.tree_checks import check_tree
from marknav.sim.camera_model import SIM_FOCAL_PX, SIM_HEIGHT, SIM_WIDTH
from marknav.vision.detect import DetectorConfig
from marknav.vision.palette import ColourRange, Palette

#: The Create's wheel speed limit (OI spec, Drive Direct: −500..500 mm/s).
CREATE_MAX_SPEED_MM_S = 500.0
#: Wheel base by model: Create 2 from the field notes (235 mm), Create 1 as libcreate uses it.
WHEEL_BASE_MM = {"create1": 258.0, "create2": 235.0}
#: The paper's eq. 19, fitted to its Table 1 (mark radius 100 mm).
PAPER_POWER_A = 58958.0
PAPER_POWER_B = -0.9434

#: Largest camera side, and largest image, a mission may ask for: the simulator renders and the
#: detector scans every pixel; measured peak memory of a simulated run grows by about
#: SIM_BYTES_PER_PIXEL bytes a pixel (185 MiB at 640 × 480, 790 MiB at 1920 × 1080, 2.9 GiB at
#: 3840 × 2160), so a 10000 × 10000 camera would need tens of GiB.
MAX_CAMERA_SIDE_PX = 4096
MAX_CAMERA_PIXELS = 1920 * 1080
SIM_BYTES_PER_PIXEL = 340

Hue = Annotated[int, Field(ge=0, le=179)]
ColourName = Annotated[str, Field(pattern=r"^[A-Za-z][A-Za-z0-9_-]*$")]


#: The robot's white-balance tint limit (``camera.detect.tint_limit``'s default): see
#: :attr:`DetectorConfig.tint_limit`.
ROBOT_TINT_LIMIT = 0.05

def _problem(kind: str, message: str, loc: Loc, value: Any) -> InitErrorDetails:
    return InitErrorDetails(type=PydanticCustomError(kind, message), loc=loc, input=value)


def _raise(title: str, problems: list[InitErrorDetails]) -> None:
    """Raise the problems (with their own locations) as one ValidationError, if there are any."""
    if problems:
        raise ValidationError.from_exception_data(title, problems)


def _hue_set(lo: int, hi: int) -> set[int]:
    return {(lo + i) % 180 for i in range((hi - lo) % 180 + 1)}


# --------------------------------------------------------------------------------------------
# Sections
# --------------------------------------------------------------------------------------------


class ColourSpec(BaseModel):
    """A mark colour: its hue range and on which side the robot passes it."""

    model_config = ConfigDict(extra="forbid")

    hue: tuple[Hue, Hue] = Field(
        description="Hue range [from, to] in OpenCV units 0..179, inclusive. It wraps past 179 "
        "when from > to: red is [170, 10].",
    )
    side: Literal["left", "right"] = Field(
        description="Side of the mark the robot passes on. left: the robot drives by with the "
        "mark on its right; right: with the mark on its left.",
    )
    sat_min: int = Field(
        default=100, ge=0, le=255,
        description="Lowest saturation (0..255) a pixel of this mark may have.",
    )
    val_min: int = Field(
        default=50, ge=0, le=255,
        description="Lowest value/brightness (0..255) a pixel of this mark may have.",
    )


class Marks(BaseModel):
    """The marks of the course."""

    model_config = ConfigDict(extra="forbid")

    radius_mm: float = Field(
        default=100.0, gt=0, allow_inf_nan=False,
        description="Physical radius of every mark, in mm (a disc at camera height).",
    )
    colours: dict[ColourName, ColourSpec] = Field(
        min_length=1,
        description="Mark colours by name: hue range and pass side. Hue ranges must not overlap.",
    )
    height_mm: tuple[Annotated[float, Field(ge=0, le=5000, allow_inf_nan=False)],
                     Annotated[float, Field(ge=0, le=5000, allow_inf_nan=False)]] | None = Field(
        default=None,
        description="[lo, hi]: the heights of the marks' centres above the floor, mm. With "
        "camera.height_mm it places the horizon prior's band (a mark above the camera is seen "
        "above the horizon, most at its nearest). null: the marks at the camera's height (the "
        "paper's set-up).",
    )

    @field_validator("height_mm")
    @classmethod
    def _ordered(cls, value: tuple[float, float] | None) -> tuple[float, float] | None:
        if value is not None and value[0] > value[1]:
            raise ValueError(f"[lo, hi] with lo ≤ hi, got [{value[0]:g}, {value[1]:g}]")
        return value

    @field_validator("colours")
    @classmethod
    def _no_overlap(cls, colours: dict[str, ColourSpec]) -> dict[str, ColourSpec]:
        problems: list[InitErrorDetails] = []
        seen: list[tuple[str, ColourSpec, set[int]]] = []
        for name, spec in colours.items():
            hues = _hue_set(*spec.hue)
            for other, other_spec, other_hues in seen:
                if hues & other_hues:
                    lo, hi = spec.hue
                    olo, ohi = other_spec.hue
                    problems.append(_problem(
                        "hue_overlap",
                        f"hue range {lo}..{hi} overlaps {other}'s {olo}..{ohi}: a mark in the "
                        "overlap could be either colour",
                        (name, "hue"), list(spec.hue),
                    ))
                    break
            seen.append((name, spec, hues))
        _raise("Marks", problems)
        return colours


def known_key(value: Any, table: Mapping[str, Any]) -> str | None:
    """``value`` if it is one of ``table``'s names, else None. A value from a file is checked
    for its type before it is used as a key (a list there is unhashable: ``TypeError``); what is
    wrong with it is the field's own validation error."""
    return value if isinstance(value, str) and value in table else None


class Robot(BaseModel):
    """The robot base."""

    model_config = ConfigDict(extra="forbid")

    model: Literal["create1", "create2"] = Field(
        default="create2",
        description="iRobot Create model: create1 (57600 baud) or create2 (115200 baud).",
    )
    wheel_base_mm: float = Field(
        default=WHEEL_BASE_MM["create2"], gt=0, allow_inf_nan=False,
        description="Distance between the wheels, in mm. Default: 235 (create2), 258 (create1).",
    )
    radius_mm: float = Field(
        default=165.0, gt=0, allow_inf_nan=False,
        description="Radius of the robot's round body, in mm (used for the clearance check).",
    )
    max_speed_mm_s: float = Field(
        default=300.0, gt=0, allow_inf_nan=False,
        description="Highest wheel speed the controller may command, in mm/s (the Create's limit "
        "is 500).",
        json_schema_extra={"maximum": CREATE_MAX_SPEED_MM_S},
    )
    odometry_scale: float = Field(
        default=1.0, ge=0.8, le=1.25, allow_inf_nan=False,
        description="Ground travel per millimetre the encoders report (worn tyres, a wheel off "
        "the nominal 72 mm); `marknav calibrate-odometry` measures it. 1: the encoders as they "
        "are.",
    )
    calibrate_wheels: bool = Field(
        default=True,
        description="Calibrate the right/left wheel ratio of odometry from mark sightings while "
        "driving (marks stand still, so their drift in the odometry frame is odometry's heading "
        "error). Turn off to keep the raw encoder odometry.",
    )

    @field_validator("max_speed_mm_s")
    @classmethod
    def _create_limit(cls, value: float) -> float:
        if value > CREATE_MAX_SPEED_MM_S:
            raise PydanticCustomError(
                "less_than_equal",
                "{value} mm/s is more than the Create's wheel speed limit of {limit} mm/s",
                {"value": f"{value:g}", "limit": f"{CREATE_MAX_SPEED_MM_S:g}"},
            )
        return value

    @model_validator(mode="before")
    @classmethod
    def _wheel_base_of_model(cls, data: Any) -> Any:
        if isinstance(data, dict) and "wheel_base_mm" not in data:
            model = known_key(data.get("model", "create2"), WHEEL_BASE_MM)
            if model is not None:  # else the model's own error says what is wrong
                return {**data, "wheel_base_mm": WHEEL_BASE_MM[model]}
        return data


class PowerRange(BaseModel):
    """Range from a mark's image radius by a power law (paper eq. 19): d_mm = a · r_px^b."""

    model_config = ConfigDict(extra="forbid")

    model: Literal["power"] = Field(description="power: d = a · r^b, fitted to measurements.")
    a: float = Field(gt=0, allow_inf_nan=False, description="Factor a (mm at r = 1 px).")
    b: float = Field(lt=0, allow_inf_nan=False, description="Exponent b (negative).")


class PinholeRange(BaseModel):
    """Range from a mark's image radius by the pinhole model (paper eq. 18, far field):
    d_mm = focal_px · R_mm / r_px."""

    model_config = ConfigDict(extra="forbid")

    model: Literal["pinhole"] = Field(description="pinhole: d = focal_px · R / r.")
    focal_px: float = Field(gt=0, allow_inf_nan=False, description="Focal length in pixels.")


RangeModel = Annotated[PowerRange | PinholeRange, Field(discriminator="model")]
_RANGE_MODELS: dict[str, type[PowerRange] | type[PinholeRange]] = {
    "power": PowerRange,
    "pinhole": PinholeRange,
}


class CameraIntrinsics(BaseModel):
    """A calibrated camera (``marknav calibrate-camera`` prints this block): camera matrix and
    lens distortion at the camera's width × height."""

    model_config = ConfigDict(extra="forbid")

    fx: float = Field(gt=0, allow_inf_nan=False, description="Focal length along u, px.")
    fy: float = Field(gt=0, allow_inf_nan=False, description="Focal length along v, px.")
    cx: float = Field(ge=0, allow_inf_nan=False, description="Principal point, column (px).")
    cy: float = Field(ge=0, allow_inf_nan=False, description="Principal point, row (px).")
    dist: list[Annotated[float, Field(allow_inf_nan=False)]] = Field(
        default_factory=list,
        description="Distortion coefficients in OpenCV's order: k1, k2, p1, p2[, k3[, k4, k5, "
        "k6]] (4, 5 or 8 values; empty: no distortion).",
    )

    @field_validator("dist")
    @classmethod
    def _dist_length(cls, dist: list[float]) -> list[float]:
        if len(dist) not in (0, 4, 5, 8):
            raise ValueError(f"needs 4, 5 or 8 coefficients (k1, k2, p1, p2[, k3...]), got "
                             f"{len(dist)}")
        return dist


class DetectSettings(BaseModel):
    """How the detector uses the camera model (``marknav.missions.detector``)."""

    model_config = ConfigDict(extra="forbid")

    max_range_mm: float | None = Field(
        default=None, gt=0, allow_inf_nan=False,
        description="Farthest mark range that matters, mm: marks smaller than one there "
        "(0.9·focal_px·marks.radius_mm / max_range_mm px, at least 5 px) are not searched "
        "for. null (default): the detector's fixed pixel minimum (5 px, more on frames over "
        "640 px wide); 6000 lost marks in long-course search turns.",
    )
    horizon_tolerance_deg: float | None = Field(
        default=3.0, ge=0, le=30, allow_inf_nan=False,
        description="The paper's camera-height prior (§3.1): mark centres lie on the principal "
        "point's row, within this camera pitch and roll, degrees (focal_px·tan t + width/2·tan t "
        "px, plus 4 px). null: marks anywhere in the frame.",
    )
    tint_limit: float | None = Field(
        default=ROBOT_TINT_LIMIT, ge=0, le=1, allow_inf_nan=False,
        description="Largest green–magenta part of the white balance (ln G − (ln B + ln R)/2 of "
        "the grey-world gains). Room lights differ along blue–amber; a strong green or magenta "
        "excess in the greys is a painted wall or carpet, and correcting it moved a yellow mark "
        "to orange. null: plain grey world (a camera with a green tint of its own: better fix "
        "it in the camera).",
    )
    min_chroma_contrast: float = Field(
        default=DetectorConfig.min_chroma_contrast, ge=0, le=255, allow_inf_nan=False,
        description="Least colour difference (white-balanced BGR units, grey removed) between a "
        "mark and a ring just outside it, scaled down in scenes darker than a grey level of "
        "100: fainter round blobs of a palette hue (out-of-focus clutter) are not marks. "
        "Painted marks measure 108 and more in the simulator, 49 and more composited into "
        "photographs. 0: off (pale or washed-out marks).",
    )
    max_readings: int = Field(
        default=DetectorConfig.max_readings, ge=1, le=100_000,
        description="Most blobs one frame is searched for marks in, the largest first: a "
        "crowded view (a poster of coloured squares, a rug) gives hundreds, each costing "
        "0.05–1 ms; the rest of that frame is left unread and a warning logged. The project's "
        "scenes and photographs need at most 258. Lower it on a slow computer.",
    )


class Camera(BaseModel):
    """The camera and how a mark's image size becomes its distance."""

    model_config = ConfigDict(extra="forbid")

    width: int = Field(default=SIM_WIDTH, gt=0, le=MAX_CAMERA_SIDE_PX,
                       description="Image width in pixels.")
    height: int = Field(default=SIM_HEIGHT, gt=0, le=MAX_CAMERA_SIDE_PX,
                        description="Image height in pixels.")
    focal_px: float = Field(
        default=SIM_FOCAL_PX, gt=0, allow_inf_nan=False,
        description="Focal length in pixels: the simulated camera's, and the horizontal field of "
        "view's (2·atan(width / (2·focal_px)), 57° by default). With intrinsics and no focal_px, "
        "the intrinsics' (fx + fy) / 2.",
    )
    range: RangeModel = Field(
        default=PowerRange(model="power", a=PAPER_POWER_A, b=PAPER_POWER_B),
        description="Range model: {model: power, a, b} or {model: pinhole, focal_px}. Without "
        "it: the pinhole law of the intrinsics' focal length if there are intrinsics, else in the "
        "simulator the simulated camera's own law (what `marknav calibrate --sim` measures), else "
        "the paper's eq. 19 (a = 58958, b = -0.9434).",
    )
    intrinsics: CameraIntrinsics | None = Field(
        default=None,
        description="Camera matrix and lens distortion from `marknav calibrate-camera`: "
        "detections are undistorted before their range and offset are estimated.",
    )
    detect: DetectSettings = Field(
        default=DetectSettings(),
        description="Detector settings from the camera model: farthest range, horizon prior.",
    )
    pitch_deg: float | None = Field(
        default=None, ge=-30, le=30, allow_inf_nan=False,
        description="The camera's tilt above the horizontal, degrees (positive: looking up; "
        "marks at camera height then lie focal_px·tan(pitch) rows below the principal point). "
        "With it the horizon prior's band is placed from the pose; null: level until the marks "
        "seen say otherwise (learnt while driving).",
    )
    roll_deg: float | None = Field(
        default=None, ge=-30, le=30, allow_inf_nan=False,
        description="The camera's turn about its optical axis, degrees (positive: the image "
        "turns clockwise): widens the horizon band by width/2·tan(roll) rows. null: 0.",
    )
    height_mm: float | None = Field(
        default=None, ge=0, le=5000, allow_inf_nan=False,
        description="Height of the camera's centre above the floor, mm; with marks.height_mm "
        "it places the horizon band. null: at the marks' height.",
    )
    latency_s: float = Field(
        default=0.0, ge=0.0, le=2.0, allow_inf_nan=False,
        description="Seconds from a frame's capture to its arrival that the camera does not "
        "report: a frame's capture time is its arrival minus this (for an MJPEG stream from "
        "`marknav serve-camera`, which sends each frame's age at sending, arrival minus that "
        "age minus this: then only the network's share). Marks are placed with the odometry "
        "pose at the capture time. The simulator stamps its frames itself.",
    )
    learn_range: bool = Field(
        default=True,
        description="Learn the range law while driving (odometry measures how far the robot "
        "drove toward a mark that stands still), starting from camera.range (or the "
        "intrinsics' pinhole law); the learnt law is in the report, ready to paste. On by "
        "default: a law 25 % off then does as well as a calibrated one "
        "(docs/how-to/calibrate.md). false keeps the law fixed.",
    )

    @model_validator(mode="before")
    @classmethod
    def _focal_from_intrinsics(cls, data: Any) -> Any:
        if isinstance(data, dict) and "focal_px" not in data:
            intr = data.get("intrinsics")
            if isinstance(intr, dict):
                fx, fy = intr.get("fx"), intr.get("fy")
                if (isinstance(fx, (int, float)) and isinstance(fy, (int, float))
                        and fx > 0 and fy > 0):
                    return {**data, "focal_px": 0.5 * (float(fx) + float(fy))}
        return data

    @field_validator("range", mode="wrap")
    @classmethod
    def _dispatch_range(cls, value: Any, handler: ValidatorFunctionWrapHandler) -> Any:
        # Validate by the 'model' key directly, so errors name the path the author wrote
        # (camera.range.a), without the union tag pydantic would insert.
        if isinstance(value, dict):
            model = value.get("model")
            known = known_key(model, _RANGE_MODELS)
            if known is not None:
                problems = model_problems(_RANGE_MODELS[known], value)
                _raise("Camera", problems)
                return _RANGE_MODELS[known].model_validate(value)
            if model is None:
                problem = _problem("missing", "missing 'model': power or pinhole", ("model",), None)
            else:
                close = difflib.get_close_matches(str(model), list(_RANGE_MODELS), n=1)
                hint = f"; did you mean {close[0]!r}?" if close else " (power or pinhole)"
                problem = _problem(
                    "range_model", f"unknown range model {model!r}{hint}", ("model",), model)
            raise ValidationError.from_exception_data("Camera", [problem])
        return handler(value)

    @model_validator(mode="after")
    def _pixel_budget(self) -> Camera:
        pixels = self.width * self.height
        if pixels > MAX_CAMERA_PIXELS:
            field = "height" if "height" in self.model_fields_set else "width"
            raise ValidationError.from_exception_data("Camera", [_problem(
                "camera_pixels",
                f"{self.width} × {self.height} = {pixels / 1e6:.1f} Mpx is more than the "
                f"{MAX_CAMERA_PIXELS / 1e6:.1f} Mpx (1920 × 1080) marknav handles: the "
                f"simulator needs about {SIM_BYTES_PER_PIXEL} bytes a pixel "
                f"({pixels * SIM_BYTES_PER_PIXEL / 2**30:.1f} GiB here); marks are found at "
                "640 × 480",
                (field,), getattr(self, field),
            )])
        return self

    @model_validator(mode="after")
    def _principal_point_in_image(self) -> Camera:
        i = self.intrinsics
        if i is not None:
            problems = [
                _problem("principal_point", f"{name} {value:g} lies outside the image (0..{size}): "
                         "were the intrinsics calibrated at another resolution?",
                         ("intrinsics", name), value)
                for name, value, size in (("cx", i.cx, self.width), ("cy", i.cy, self.height))
                if value >= size
            ]
            _raise("Camera", problems)
        return self

    @property
    def hfov_deg(self) -> float:
        """Horizontal field of view, degrees."""
        return math.degrees(2.0 * math.atan(self.width / (2.0 * self.focal_px)))

    @property
    def vfov_deg(self) -> float:
        """Vertical field of view, degrees (square pixels)."""
        return math.degrees(2.0 * math.atan(self.height / (2.0 * self.focal_px)))


class Search(BaseModel):
    """Turning on the spot to find a target that is not in view."""

    model_config = ConfigDict(extra="forbid")

    turn_speed_deg_s: float = Field(
        default=40.0, gt=0, allow_inf_nan=False, description="Turn rate while searching, degrees/s."
    )
    timeout_s: float = Field(
        default=15.0, gt=0, allow_inf_nan=False,
        description="Give up (the mission fails) after searching this long, seconds.",
    )


class Navigation(BaseModel):
    """Approach, bypass and search settings."""

    model_config = ConfigDict(extra="forbid")

    bypass_distance_mm: float = Field(
        default=800.0, gt=0, allow_inf_nan=False,
        description="Start the Bézier bypass when the target is this close, mm.",
    )
    clearance_mm: float = Field(
        default=300.0, gt=0, allow_inf_nan=False,
        description="Distance kept between the robot's centre and the mark's centre when passing "
        "it, mm. Must exceed robot.radius_mm + marks.radius_mm.",
    )
    approach_speed_mm_s: float = Field(
        default=250.0, gt=0, allow_inf_nan=False,
        description="Forward speed while approaching a mark, mm/s (at most robot.max_speed_mm_s).",
    )
    lost_after_s: float = Field(
        default=0.5, gt=0, allow_inf_nan=False,
        description="A target unseen this long, seconds, is lost: the robot searches for it.",
    )
    lookahead_mm: float = Field(
        default=150.0, gt=0, allow_inf_nan=False,
        description="Pure-pursuit lookahead along the bypass curve, mm.",
    )
    search: Search = Field(default=Search(), description="Searching for a lost target.")
    bypass_margin_mm: float = Field(
        default=40.0, ge=0, le=500, allow_inf_nan=False,
        description="Extra distance, mm, planned beyond clearance_mm. Once the mark leaves the "
        "camera's view the bypass is tracked from odometry alone, and unequal wheels (which "
        "the encoders cannot see) drift the robot a few centimetres over a bypass; the margin "
        "absorbs that. After each bump recovery the bypass widens by another 60 mm.",
    )
    approach_aim: Literal["centre", "side"] = Field(
        default="centre",
        description="What the approach keeps in the middle of the image: 'centre' — the mark "
        "itself (the paper's §4.6); 'side' — the point clearance_mm beside the mark on its pass "
        "side, so the robot heads for where it will pass. 'side' keeps clear of a mark just "
        "passed when the route turns back past it (a figure-eight).",
    )
    revisit_marks: bool = Field(
        default=False,
        description="The route passes the same physical marks more than once (a figure-eight "
        "around two marks). When false (the default), a mark already passed is never chosen "
        "again as a target, so a search turn that sweeps past an old mark of the route's next "
        "colour does not turn back to it; when true, only the mark passed last is excluded.",
    )


class Safety(BaseModel):
    """The safety layer between the tree and the wheels."""

    model_config = ConfigDict(extra="forbid")

    command_timeout_s: float = Field(
        default=0.3, gt=0, allow_inf_nan=False,
        description="Stop the wheels when no fresh wheel command came for this long, seconds "
        "(at least two control periods).",
    )
    sensor_timeout_s: float = Field(
        default=0.2, gt=0.015, allow_inf_nan=False,
        description="Stop the wheels when no valid sensor frame came for this long, seconds "
        "(the Create streams every 15 ms).",
    )
    max_bump_recoveries: int = Field(
        default=2, ge=0, description="Bumper contacts recovered from before the mission is aborted."
    )


class Control(BaseModel):
    """The fixed-rate control loop."""

    model_config = ConfigDict(extra="forbid")

    rate_hz: float = Field(
        default=20.0, ge=1, le=100, allow_inf_nan=False,
        description="Control loop rate, Hz (1..100).",
    )


class Sim(BaseModel):
    """Simulator settings (used when running with --robot sim)."""

    model_config = ConfigDict(extra="forbid")

    world: Path | None = Field(
        default=None,
        description="World file for the simulator, relative to this mission file. Without one, "
        "a world is generated from the route and the seed.",
    )
    seed: int = Field(
        default=0, ge=0,
        description="Random seed of the simulator (--seed overrides it).",
    )
    engine: Literal["builtin", "mujoco"] = Field(
        default="builtin",
        description="Simulator engine: builtin (marknav's own kinematics and renderer) or mujoco "
        "(MuJoCo physics, contacts and rendering; pip install 'marknav[mujoco]' and the system "
        "package libosmesa6). --engine overrides it. The same world files drive both.",
    )
    shadows: bool = Field(
        default=True,
        description="mujoco engine: the room's lamps cast shadows (about 1.5x the render time).",
    )
    conditions: dict[str, Any] = Field(
        default_factory=dict,
        description="World conditions that replace the world's own (its file's, a generated or "
        "randomised one's), e.g. {camera_latency_s: 0.4}: the keys of a world's conditions "
        "(marknav schema --world). With --set: --set sim.conditions.camera_latency_s=0.4.",
    )

    @field_validator("conditions")
    @classmethod
    def _known_conditions(cls, value: dict[str, Any]) -> dict[str, Any]:
        from marknav.sim.world import Conditions

        try:
            Conditions.model_validate(value)
        except ValidationError as exc:
            problems = "; ".join(
                f"{'.'.join(str(p) for p in e['loc']) or 'conditions'}: {e['msg']}"
                for e in exc.errors())
            raise ValueError(f"not world conditions ({problems})") from None
        return value


# --------------------------------------------------------------------------------------------
# The mission
# --------------------------------------------------------------------------------------------


class Mission(BaseModel):
    """A marknav mission: the route of coloured marks to pass, and how to drive it."""

    model_config = ConfigDict(extra="forbid", title="marknav mission")

    name: str = Field(min_length=1, description="Name of the mission (shown in reports).")
    marks: Marks = Field(description="The marks: their radius, colours and pass sides.")
    route: list[str] = Field(
        min_length=1, description="Marks to pass, in order, by colour name (from marks.colours)."
    )
    robot: Robot = Field(default=Robot(), description="The robot base.")
    camera: Camera = Field(default=Camera(), description="The camera and range model.")
    navigation: Navigation = Field(
        default=Navigation(), description="Approach, bypass and search settings."
    )
    safety: Safety = Field(default=Safety(), description="Safety layer timeouts and limits.")
    control: Control = Field(default=Control(), description="The control loop.")
    sim: Sim | None = Field(default=None, description="Simulator settings: world file and seed.")
    plugins: list[Annotated[str, Field(min_length=1)]] = Field(
        default_factory=list,
        description="Python modules that register node types for tree: (each provides "
        "register(registry)); found on sys.path or in this file's folder. Installed packages "
        "can also register node types through the entry-point group marknav.nodes.",
    )
    tree: TreeNode | None = Field(
        default=None,
        description="A custom behaviour tree built from py_trees composites, decorators and "
        "registered behaviours. Without it the default route tree is used.",
    )

    _document: YamlDocument | None = PrivateAttr(None)
    _source_path: Path | None = PrivateAttr(None)
    _registry: NodeRegistry | None = PrivateAttr(None)
    _overrides: tuple[str, ...] = PrivateAttr(())

    # validation -----------------------------------------------------------------------------

    @field_validator("name")
    @classmethod
    def _name_printable(cls, name: str) -> str:
        # The name is shown on the terminal and names the run folder (made safe there):
        # a NUL, newline or ESC would garble one and the other.
        bad = next((c for c in name if unicodedata.category(c) in ("Cc", "Cf", "Zl", "Zp")),
                   None)
        if bad is not None:
            raise ValueError(f"the name contains the control character U+{ord(bad):04X}; "
                             "use printable characters")
        if len(name) > 200:
            raise ValueError(f"the name is {len(name)} characters long; at most 200")
        return name

    @field_validator("route")
    @classmethod
    def _route_colours_exist(cls, route: list[str], info: ValidationInfo) -> list[str]:
        marks = info.data.get("marks")
        if not isinstance(marks, Marks):
            return route  # marks has its own errors
        known = list(marks.colours)
        problems: list[InitErrorDetails] = []
        for i, colour in enumerate(route):
            if colour in marks.colours:
                continue
            close = difflib.get_close_matches(colour, known, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else f" (colours: {', '.join(known)})"
            problems.append(_problem(
                "route_colour", f"colour {colour!r} is not defined in marks.colours{hint}",
                (i,), colour,
            ))
        _raise("Mission", problems)
        return route

    @field_validator("tree")
    @classmethod
    def _tree_against_route(cls, tree: TreeNode | None, info: ValidationInfo) -> TreeNode | None:
        marks, route = info.data.get("marks"), info.data.get("route")
        if tree is None or not isinstance(marks, Marks) or not isinstance(route, list):
            return tree  # marks or route have their own errors
        context = info.context if isinstance(info.context, dict) else {}
        registry = context.get("registry") or default_registry()
        _raise("Mission", check_tree(tree, marks.colours, route, registry))
        return tree

    @model_validator(mode="after")
    def _cross_checks(self) -> Mission:
        nav, robot, marks = self.navigation, self.robot, self.marks
        problems: list[InitErrorDetails] = []

        def blame(*candidates: Loc) -> Loc:
            # The first candidate written in the file; the first of all if none was written.
            return next((loc for loc in candidates if self._written(loc)), candidates[0])

        if nav.approach_speed_mm_s > robot.max_speed_mm_s:
            problems.append(_problem(
                "speed_order",
                f"approach_speed_mm_s {nav.approach_speed_mm_s:g} exceeds "
                f"robot.max_speed_mm_s {robot.max_speed_mm_s:g}",
                blame(("navigation", "approach_speed_mm_s"), ("robot", "max_speed_mm_s")),
                nav.approach_speed_mm_s,
            ))
        touch = robot.radius_mm + marks.radius_mm
        if nav.clearance_mm <= touch:
            problems.append(_problem(
                "clearance",
                f"clearance_mm {nav.clearance_mm:g} must exceed robot.radius_mm + "
                f"marks.radius_mm = {robot.radius_mm:g} + {marks.radius_mm:g} = {touch:g}: "
                "clearance is robot centre to mark centre, so with less the robot touches the mark",
                blame(("navigation", "clearance_mm"), ("robot", "radius_mm"),
                      ("marks", "radius_mm")),
                nav.clearance_mm,
            ))
        if nav.bypass_distance_mm <= nav.clearance_mm:
            problems.append(_problem(
                "bypass_distance",
                f"bypass_distance_mm {nav.bypass_distance_mm:g} must exceed clearance_mm "
                f"{nav.clearance_mm:g}: the bypass starts farther from the mark than it passes it",
                blame(("navigation", "bypass_distance_mm"), ("navigation", "clearance_mm")),
                nav.bypass_distance_mm,
            ))
        turn_wheel = math.radians(nav.search.turn_speed_deg_s) * robot.wheel_base_mm / 2.0
        if turn_wheel > robot.max_speed_mm_s:
            problems.append(_problem(
                "turn_speed",
                f"turn_speed_deg_s {nav.search.turn_speed_deg_s:g} needs wheel speeds of "
                f"{turn_wheel:.0f} mm/s (turn rate × wheel_base_mm / 2), more than "
                f"robot.max_speed_mm_s {robot.max_speed_mm_s:g}",
                blame(("navigation", "search", "turn_speed_deg_s"), ("robot", "max_speed_mm_s"),
                      ("robot", "wheel_base_mm")),
                nav.search.turn_speed_deg_s,
            ))
        min_timeout = 2.0 / self.control.rate_hz
        if self.safety.command_timeout_s < min_timeout:
            problems.append(_problem(
                "command_timeout",
                f"command_timeout_s {self.safety.command_timeout_s:g} must be at least two "
                f"control periods (2 / control.rate_hz = {min_timeout:g} s), or the watchdog "
                "stops the wheels between commands",
                blame(("safety", "command_timeout_s"), ("control", "rate_hz")),
                self.safety.command_timeout_s,
            ))
        _raise("Mission", problems)
        return self

    def _written(self, loc: Loc) -> bool:
        """Whether the field at ``loc`` was given explicitly (not left to its default)."""
        node: Any = self
        for key in loc:
            if not isinstance(node, BaseModel) or key not in node.model_fields_set:
                return False
            node = getattr(node, str(key))
        return True

    # use ------------------------------------------------------------------------------------

    def palette(self) -> Palette:
        """The mark colours as the detector's palette, in the order they are listed."""
        return tuple(
            ColourRange(name, spec.hue[0], spec.hue[1], sat_min=spec.sat_min, val_min=spec.val_min)
            for name, spec in self.marks.colours.items()
        )

    def side_of(self, colour: str) -> Literal["left", "right"]:
        """The side the robot passes a mark of ``colour`` on."""
        try:
            return self.marks.colours[colour].side
        except KeyError:
            raise KeyError(f"colour {colour!r} is not in the mission's marks.colours") from None

    def route_summary(self) -> str:
        """``red → green → red → blue, 4 waypoints``."""
        n = len(self.route)
        return f"{' → '.join(self.route)}, {n} waypoint{'s' if n != 1 else ''}"

    @property
    def registry(self) -> NodeRegistry:
        """The node types this mission's tree is built from: the default registry plus its
        ``plugins``."""
        return self._registry if self._registry is not None else default_registry()

    @property
    def overrides(self) -> tuple[str, ...]:
        """The ``--set KEY=VALUE`` settings applied on top of the file, as given."""
        return self._overrides

    @property
    def document(self) -> YamlDocument | None:
        """The YAML document the mission was loaded from (positions of every key), if any."""
        return self._document

    @property
    def source_path(self) -> Path | None:
        """The file the mission was loaded from, if any."""
        return self._source_path

    def position(self, loc: Iterable[str | int]) -> Position | None:
        """Where the field at ``loc`` (e.g. ``("route", 2)``) is written, or its nearest
        written ancestor; ``None`` when the mission did not come from a file."""
        return self._document.position(tuple(loc)) if self._document is not None else None

    def input_error(self, loc: Iterable[str | int], message: str) -> InputError:
        """An :class:`InputError` pointing at the field ``loc`` of the mission file."""
        path = tuple(loc)
        pos = self.position(path)
        return InputError(
            message,
            file=self._document.path if self._document is not None else None,
            line=pos.line if pos else None,
            column=pos.column if pos else None,
            field=_fmt(path) or None,
        )


def _fmt(loc: Loc) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else ("." if out else "") + str(part)
    return out


# --------------------------------------------------------------------------------------------
# Loading
# --------------------------------------------------------------------------------------------


def parse_mission(
    doc: YamlDocument,
    registry: NodeRegistry | None = None,
    overrides: Sequence[Override] = (),
) -> Mission:
    """Validate a parsed YAML document as a mission; raise :class:`InputErrors` with every
    problem. ``registry`` (default: :func:`default_registry`) decides which tree node types exist;
    the mission's own ``plugins`` modules are added to a copy of it. ``overrides`` (``--set``)
    are applied first; problems in them are reported at the setting. ``sim.world`` is resolved
    relative to the document's file."""
    if not isinstance(doc.data, dict):
        pos = doc.position(())
        raise InputError(
            "a mission is a mapping of keys (name: ..., route: [...], marks: {...}), "
            f"not {_kind(doc.data)}",
            file=doc.path, line=pos.line if pos else 1, column=pos.column if pos else 1,
        )
    doc = apply_overrides(doc, overrides)
    base = registry or default_registry()
    registry, plugin_errors = _with_plugins(doc, base)
    context = {"registry": registry}
    try:
        mission = Mission.model_validate(doc.data, context=context)
    except ValidationError as exc:
        errors = [*plugin_errors, *_mission_errors(exc, doc).errors]
        errors = relabel(errors, overrides)
        raise InputErrors(sorted(errors, key=_error_order)) from None
    if plugin_errors:
        raise InputErrors(relabel(plugin_errors, overrides))
    mission._document = doc
    mission._source_path = Path(doc.path)
    mission._registry = registry if registry is not base else None
    mission._overrides = tuple(o.text for o in overrides)
    if mission.sim is not None and mission.sim.world is not None:
        mission.sim.world = Path(doc.path).parent / mission.sim.world
    return mission


def _error_order(e: InputError) -> tuple[int, int, int]:
    # File errors by position; errors of --set settings (no line) after them.
    return (1 if e.line is None else 0, e.line or 0, e.column or 0)


def _with_plugins(doc: YamlDocument, base: NodeRegistry) -> tuple[NodeRegistry, list[InputError]]:
    """``base`` plus the mission's ``plugins`` (when it lists valid module names), and one error
    per plugin that failed, at its line."""
    modules = doc.data.get("plugins") if isinstance(doc.data, dict) else None
    if not isinstance(modules, list) or not modules:
        return base, []
    names = [m if isinstance(m, str) and m else "" for m in modules]
    registry, problems = registry_with_plugins(
        [n for n in names if n], Path(doc.path).resolve().parent, base)
    valid = [i for i, n in enumerate(names) if n]  # positions of the names tried
    errors: list[InputError] = []
    for j, message in problems:
        loc: Loc = ("plugins", valid[j])
        pos = doc.position(loc)
        errors.append(InputError(message, file=doc.path, line=pos.line if pos else None,
                                 column=pos.column if pos else None, field=_fmt(loc)))
    return registry, errors


def _kind(value: Any) -> str:
    if isinstance(value, list):
        return "a list"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, (int, float)):
        return "a number"
    return "null" if value is None else type(value).__name__


def load_mission(
    path: str | Path,
    registry: NodeRegistry | None = None,
    overrides: Sequence[Override] = (),
) -> Mission:
    """Load and check a mission file, with ``--set`` ``overrides`` applied. Bad input raises
    :class:`InputError` (one problem) or :class:`InputErrors` (all of them), each
    ``FILE:LINE:COLUMN: field: message``."""
    return parse_mission(load_yaml_file(path), registry, overrides)


def _mission_errors(exc: ValidationError, doc: YamlDocument) -> InputErrors:
    mapped = validation_errors(exc, doc, Mission)
    # Unknown keys found by model_problems: point at the key, as yamlio does for the others.
    for err in exc.errors(include_url=False):
        if err["type"] != UNKNOWN_KEY:
            continue
        loc = tuple(err["loc"])
        key_pos = doc.key_positions.get(loc)
        if key_pos is None:
            continue
        for e in mapped.errors:
            if e.field == _fmt(loc) and e.message == err["msg"]:
                e.line, e.column = key_pos.line, key_pos.column
    errors = sorted(mapped.errors, key=lambda e: (e.line or 0, e.column or 0))
    return InputErrors(errors)


def mission_json_schema(
    registry: NodeRegistry | None = None, plugins: Sequence[str] = ()
) -> dict[str, Any]:
    """JSON Schema of mission files, for editors: every key with its description, the tree node
    types of ``registry`` (plus the ``plugins`` modules) as suggestions, and each node type's
    params and required keys."""
    registry = registry or default_registry()
    if plugins:
        registry, problems = registry_with_plugins(plugins, Path.cwd(), registry)
        if problems:
            raise InputErrors([InputError(message, field=f"--plugin {plugins[i]}")
                               for i, message in problems])
    schema = Mission.model_json_schema()
    defs: dict[str, Any] = schema.setdefault("$defs", {})
    node = defs["TreeNode"]
    node["properties"]["type"]["examples"] = registry.names()
    node["allOf"] = registry.json_schema_conditions(defs)
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", **schema}
