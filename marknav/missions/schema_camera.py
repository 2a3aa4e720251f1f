"""The mission's ``camera`` section: image size and focal length, the range law that turns a
mark's image radius into its distance (the paper's eq. 19 power law or eq. 18 pinhole law),
calibrated intrinsics, the camera's pose and latency, and the detector settings that follow
from the camera model; with the limits a camera must keep (its pixel budget, a principal point
inside the image).
"""

from __future__ import annotations

import difflib
import math
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    ValidatorFunctionWrapHandler,
    field_validator,
    model_validator,
)

from marknav.core.yamlio import Integer, Number
from marknav.missions.registry import model_problems
from marknav.missions.schema_problems import known_key, problem_detail, raise_problems
from marknav.sim.camera_model import SIM_FOCAL_PX, SIM_HEIGHT, SIM_WIDTH
from marknav.vision.detect.shape import ShapeConfig

__all__ = [
    "MAX_CAMERA_PIXELS",
    "MAX_CAMERA_SIDE_PX",
    "PAPER_POWER_A",
    "PAPER_POWER_B",
    "ROBOT_TINT_LIMIT",
    "SIM_BYTES_PER_PIXEL",
    "Camera",
    "CameraIntrinsics",
    "DetectSettings",
    "PinholeRange",
    "PowerRange",
    "RangeModel",
]

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

#: The robot's white-balance tint limit (``camera.detect.tint_limit``'s default): see
#: :attr:`~marknav.vision.detect.photometry.PhotometryConfig.tint_limit`.
ROBOT_TINT_LIMIT = 0.05


class PowerRange(BaseModel):
    """Range from a mark's image radius by a power law (paper eq. 19): d_mm = a · r_px^b."""

    model_config = ConfigDict(extra="forbid")

    model: Literal["power"] = Field(description="power: d = a · r^b, fitted to measurements.")
    a: Number = Field(gt=0, allow_inf_nan=False, description="Factor a (mm at r = 1 px).")
    b: Number = Field(lt=0, allow_inf_nan=False, description="Exponent b (negative).")


class PinholeRange(BaseModel):
    """Range from a mark's image radius by the pinhole model (paper eq. 18, far field):
    d_mm = focal_px · R_mm / r_px."""

    model_config = ConfigDict(extra="forbid")

    model: Literal["pinhole"] = Field(description="pinhole: d = focal_px · R / r.")
    focal_px: Number = Field(gt=0, allow_inf_nan=False, description="Focal length in pixels.")


RangeModel = Annotated[PowerRange | PinholeRange, Field(discriminator="model")]
_RANGE_MODELS: dict[str, type[PowerRange] | type[PinholeRange]] = {
    "power": PowerRange,
    "pinhole": PinholeRange,
}


class CameraIntrinsics(BaseModel):
    """A calibrated camera (``marknav calibrate-camera`` prints this block): camera matrix and
    lens distortion at the camera's width × height."""

    model_config = ConfigDict(extra="forbid")

    fx: Number = Field(gt=0, allow_inf_nan=False, description="Focal length along u, px.")
    fy: Number = Field(gt=0, allow_inf_nan=False, description="Focal length along v, px.")
    cx: Number = Field(ge=0, allow_inf_nan=False, description="Principal point, column (px).")
    cy: Number = Field(ge=0, allow_inf_nan=False, description="Principal point, row (px).")
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
    """How the detector uses the camera model (``marknav.missions.mission_detector``)."""

    model_config = ConfigDict(extra="forbid")

    max_range_mm: Number | None = Field(
        default=None, gt=0, allow_inf_nan=False,
        description="Farthest mark range that matters, mm: marks smaller than one there "
        "(0.9·focal_px·marks.radius_mm / max_range_mm px, at least 5 px) are not searched "
        "for. null (default): the detector's fixed pixel minimum (5 px, more on frames over "
        "640 px wide); 6000 lost marks in long-course search turns.",
    )
    horizon_tolerance_deg: Number | None = Field(
        default=3.0, ge=0, le=30, allow_inf_nan=False,
        description="The paper's camera-height prior (§3.1): mark centres lie on the principal "
        "point's row, within this camera pitch and roll, degrees (focal_px·tan t + width/2·tan t "
        "px, plus 4 px). null: marks anywhere in the frame.",
    )
    tint_limit: Number | None = Field(
        default=ROBOT_TINT_LIMIT, ge=0, le=1, allow_inf_nan=False,
        description="Largest green–magenta part of the white balance (ln G − (ln B + ln R)/2 of "
        "the grey-world gains). Room lights differ along blue–amber; a strong green or magenta "
        "excess in the greys is a painted wall or carpet, and correcting it moved a yellow mark "
        "to orange. null: plain grey world (a camera with a green tint of its own: better fix "
        "it in the camera).",
    )
    min_chroma_contrast: Number = Field(
        default=ShapeConfig.min_contrast, ge=0, le=255, allow_inf_nan=False,
        description="Least colour difference (BGR levels after the detector's exposure and "
        "light-colour correction, grey removed) between a mark's paint and its surroundings: "
        "fainter round blobs of a palette hue (out-of-focus clutter) are not marks. Painted "
        "marks measure 88 and more on the project's rendered and photographed corpora. "
        "0: off.",
    )
    max_readings: Integer = Field(
        default=ShapeConfig.max_blobs, ge=1, le=100_000,
        description="Most mark-shaped blobs one frame's marks are measured from, the largest "
        "first: a crowded view (a poster of coloured squares, a rug) gives hundreds, each "
        "costing about 0.1 ms; the rest of that frame is left unmeasured and a warning logged. "
        "The project's scenes and photographs need at most 120. Lower it on a slow computer.",
    )


class Camera(BaseModel):
    """The camera and how a mark's image size becomes its distance."""

    model_config = ConfigDict(extra="forbid")

    width: Integer = Field(default=SIM_WIDTH, gt=0, le=MAX_CAMERA_SIDE_PX,
                       description="Image width in pixels.")
    height: Integer = Field(default=SIM_HEIGHT, gt=0, le=MAX_CAMERA_SIDE_PX,
                        description="Image height in pixels.")
    focal_px: Number = Field(
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
    pitch_deg: Number | None = Field(
        default=None, ge=-30, le=30, allow_inf_nan=False,
        description="The camera's tilt above the horizontal, degrees (positive: looking up; "
        "marks at camera height then lie focal_px·tan(pitch) rows below the principal point). "
        "With it the horizon prior's band is placed from the pose; null: level until the marks "
        "seen say otherwise (learnt while driving).",
    )
    roll_deg: Number | None = Field(
        default=None, ge=-30, le=30, allow_inf_nan=False,
        description="The camera's turn about its optical axis, degrees (positive: the image "
        "turns clockwise): widens the horizon band by width/2·tan(roll) rows. null: 0.",
    )
    height_mm: Number | None = Field(
        default=None, ge=0, le=5000, allow_inf_nan=False,
        description="Height of the camera's centre above the floor, mm; with marks.height_mm "
        "it places the horizon band. null: at the marks' height.",
    )
    latency_s: Number = Field(
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
                raise_problems("Camera", problems)
                return _RANGE_MODELS[known].model_validate(value)
            if model is None:
                problem = problem_detail("missing", "missing 'model': power or pinhole",
                                         ("model",), None)
            else:
                close = difflib.get_close_matches(str(model), list(_RANGE_MODELS), n=1)
                hint = f"; did you mean {close[0]!r}?" if close else " (power or pinhole)"
                problem = problem_detail(
                    "range_model", f"unknown range model {model!r}{hint}", ("model",), model)
            raise ValidationError.from_exception_data("Camera", [problem])
        return handler(value)

    @model_validator(mode="after")
    def _pixel_budget(self) -> Camera:
        pixels = self.width * self.height
        if pixels > MAX_CAMERA_PIXELS:
            field = "height" if "height" in self.model_fields_set else "width"
            raise ValidationError.from_exception_data("Camera", [problem_detail(
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
                problem_detail("principal_point",
                               f"{name} {value:g} lies outside the image (0..{size}): "
                               "were the intrinsics calibrated at another resolution?",
                               ("intrinsics", name), value)
                for name, value, size in (("cx", i.cx, self.width), ("cy", i.cy, self.height))
                if value >= size
            ]
            raise_problems("Camera", problems)
        return self

    @property
    def hfov_deg(self) -> float:
        """Horizontal field of view, degrees."""
        return math.degrees(2.0 * math.atan(self.width / (2.0 * self.focal_px)))

    @property
    def vfov_deg(self) -> float:
        """Vertical field of view, degrees (square pixels)."""
        return math.degrees(2.0 * math.atan(self.height / (2.0 * self.focal_px)))
