"""The mission's sections on the robot and how it is driven: the robot base (``robot``: model,
wheel base, speed limit, odometry), approach, bypass and search (``navigation``), the safety
layer's timeouts (``safety``), the control loop (``control``) and the simulator's settings
(``sim``), each with the limits of the hardware it describes.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator
from pydantic_core import PydanticCustomError

from marknav.core.yamlio import Integer, Number
from marknav.missions.schema_problems import known_key

__all__ = [
    "CREATE_MAX_SPEED_MM_S",
    "WHEEL_BASE_MM",
    "Control",
    "Navigation",
    "Robot",
    "Safety",
    "Search",
    "Sim",
]

#: The Create's wheel speed limit (OI spec, Drive Direct: −500..500 mm/s).
CREATE_MAX_SPEED_MM_S = 500.0
#: Wheel base by model: Create 2 from the field notes (235 mm), Create 1 as libcreate uses it.
WHEEL_BASE_MM = {"create1": 258.0, "create2": 235.0}


class Robot(BaseModel):
    """The robot base."""

    model_config = ConfigDict(extra="forbid")

    model: Literal["create1", "create2"] = Field(
        default="create2",
        description="iRobot Create model: create1 (57600 baud) or create2 (115200 baud).",
    )
    wheel_base_mm: Number = Field(
        default=WHEEL_BASE_MM["create2"], gt=0, allow_inf_nan=False,
        description="Distance between the wheels, in mm. Default: 235 (create2), 258 (create1).",
    )
    radius_mm: Number = Field(
        default=165.0, gt=0, allow_inf_nan=False,
        description="Radius of the robot's round body, in mm (used for the clearance check).",
    )
    max_speed_mm_s: Number = Field(
        default=300.0, gt=0, allow_inf_nan=False,
        description="Highest wheel speed the controller may command, in mm/s (the Create's limit "
        "is 500).",
        json_schema_extra={"maximum": CREATE_MAX_SPEED_MM_S},
    )
    odometry_scale: Number = Field(
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


class Search(BaseModel):
    """Turning on the spot to find a target that is not in view."""

    model_config = ConfigDict(extra="forbid")

    turn_speed_deg_s: Number = Field(
        default=40.0, gt=0, allow_inf_nan=False, description="Turn rate while searching, degrees/s."
    )
    timeout_s: Number = Field(
        default=15.0, gt=0, allow_inf_nan=False,
        description="Give up (the mission fails) after searching this long, seconds.",
    )


class Navigation(BaseModel):
    """Approach, bypass and search settings."""

    model_config = ConfigDict(extra="forbid")

    bypass_distance_mm: Number = Field(
        default=800.0, gt=0, allow_inf_nan=False,
        description="Start the Bézier bypass when the target is this close, mm.",
    )
    clearance_mm: Number = Field(
        default=300.0, gt=0, allow_inf_nan=False,
        description="Distance kept between the robot's centre and the mark's centre when passing "
        "it, mm. Must exceed robot.radius_mm + marks.radius_mm.",
    )
    approach_speed_mm_s: Number = Field(
        default=250.0, gt=0, allow_inf_nan=False,
        description="Forward speed while approaching a mark, mm/s (at most robot.max_speed_mm_s).",
    )
    lost_after_s: Number = Field(
        default=0.5, gt=0, allow_inf_nan=False,
        description="A target unseen this long, seconds, is lost: the robot searches for it.",
    )
    lookahead_mm: Number = Field(
        default=150.0, gt=0, allow_inf_nan=False,
        description="Pure-pursuit lookahead along the bypass curve, mm.",
    )
    search: Search = Field(default=Search(), description="Searching for a lost target.")
    bypass_margin_mm: Number = Field(
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

    command_timeout_s: Number = Field(
        default=0.3, gt=0, allow_inf_nan=False,
        description="Stop the wheels when no fresh wheel command came for this long, seconds "
        "(at least two control periods).",
    )
    sensor_timeout_s: Number = Field(
        default=0.2, gt=0.015, allow_inf_nan=False,
        description="Stop the wheels when no valid sensor frame came for this long, seconds "
        "(the Create streams every 15 ms).",
    )
    max_bump_recoveries: Integer = Field(
        default=2, ge=0, description="Bumper contacts recovered from before the mission is aborted."
    )


class Control(BaseModel):
    """The fixed-rate control loop."""

    model_config = ConfigDict(extra="forbid")

    rate_hz: Number = Field(
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
    seed: Integer = Field(
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
        from marknav.sim.world.schema import Conditions

        try:
            Conditions.model_validate(value)
        except ValidationError as exc:
            problems = "; ".join(
                f"{'.'.join(str(p) for p in e['loc']) or 'conditions'}: {e['msg']}"
                for e in exc.errors())
            raise ValueError(f"not world conditions ({problems})") from None
        return value
