"""The mission's ``marks`` section: the marks' radius and height, and each colour's hue range
and pass side, with the check that no two colours' hue ranges overlap (a mark in the overlap
could be either colour).
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator
from pydantic_core import InitErrorDetails

from marknav.core.yamlio import Integer, Number
from marknav.missions.schema_problems import problem_detail, raise_problems

__all__ = ["ColourName", "ColourSpec", "Hue", "Marks"]

Hue = Annotated[Integer, Field(ge=0, le=179)]
ColourName = Annotated[str, Field(pattern=r"^[A-Za-z][A-Za-z0-9_-]*$")]


def _hue_set(lo: int, hi: int) -> set[int]:
    return {(lo + i) % 180 for i in range((hi - lo) % 180 + 1)}


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
    sat_min: Integer = Field(
        default=100, ge=0, le=255,
        description="Lowest saturation (0..255) a pixel of this mark may have.",
    )
    val_min: Integer = Field(
        default=50, ge=0, le=255,
        description="Lowest value/brightness (0..255) a pixel of this mark may have.",
    )


class Marks(BaseModel):
    """The marks of the course."""

    model_config = ConfigDict(extra="forbid")

    radius_mm: Number = Field(
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
                    problems.append(problem_detail(
                        "hue_overlap",
                        f"hue range {lo}..{hi} overlaps {other}'s {olo}..{ohi}: a mark in the "
                        "overlap could be either colour",
                        (name, "hue"), list(spec.hue),
                    ))
                    break
            seen.append((name, spec, hues))
        raise_problems("Marks", problems)
        return colours
