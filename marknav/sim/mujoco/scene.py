"""What MuJoCo can draw beyond the built-in renderer: lights, textures, occluders, distractors.

A world's optional ``mujoco:`` section (:class:`MujocoScene`); the built-in engine ignores it.
:func:`random_scene` draws one for the randomised worlds ``marknav evaluate --engine mujoco``
runs. The ranges are entries of the one table, :mod:`marknav.sim.randomisation`; with their
physical reasons:

- **Lights** (:data:`LIGHT_COUNT` 1-3) hang at :data:`LIGHT_HEIGHT_MM` (2.2-2.8 m, a room's
  ceiling lamps) within :data:`LIGHT_SPREAD_MM` of the course, each casting shadows; their
  colour is a tint of up to :data:`TINT_MAX` per channel about white (incandescent amber to
  overcast blue), their diffuse intensity :data:`LIGHT_DIFFUSE` (0.25-0.6 of MuJoCo's full
  scale, so two overlapping lamps do not saturate a white wall).
- **Dim rooms**: with probability :data:`DIM_PROBABILITY` every light and the ambient term are
  scaled by :data:`DIM_FACTOR` (0.3-0.5: an evening room lit by one lamp is 3-10× darker than
  an office, and a webcam's auto-exposure recovers only part of it).
- **Ambient** light :data:`AMBIENT` (0.1-0.35 of full scale): light scattered by walls.
- **Textures**: the floor ``plain``, ``checker`` (tiles or a rug, 150-400 mm squares) or a
  ``photo`` (marknav's room photographs, palette colours desaturated as the built-in renderer
  does), the walls ``plain``, ``gradient`` or ``photo``.
- **Occluders**: 0-4 poles (table legs, lamp stands: radius :data:`OCCLUDER_RADIUS_MM` 10-30 mm,
  0.5-2 m high) and **distractors**: 0-5 balls or boxes (:data:`DISTRACTOR_SIZE_MM` 80-250 mm,
  hue 8-10 units past a route colour's range, as the built-in renderer's distractors), both
  off the course: at least :data:`CORRIDOR_MARGIN_MM` beyond the lane the robot drives (the
  marks' lateral extent plus the clearance and the robot's radius), at most 1.5 m beyond it,
  where they cross the camera's view when it turns to search or bypass.
- Marks turn up to :data:`MARK_YAW_MAX_DEG` (60°) from the line of sight in MuJoCo's randomised
  worlds (45° in the built-in engine's).

Nothing here imports ``mujoco``: the world schema uses these models.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from marknav.core.yamlio import Integer, Number
from marknav.sim.randomisation import bounds, counts

__all__ = [
    "AMBIENT",
    "CORRIDOR_MARGIN_MM",
    "DIM_FACTOR",
    "DIM_PROBABILITY",
    "DISTRACTOR_SIZE_MM",
    "LIGHT_COUNT",
    "LIGHT_DIFFUSE",
    "LIGHT_HEIGHT_MM",
    "LIGHT_SPREAD_MM",
    "MARK_YAW_MAX_DEG",
    "OCCLUDER_RADIUS_MM",
    "TINT_MAX",
    "Distractor",
    "Light",
    "MujocoScene",
    "Occluder",
    "random_scene",
]

# The ranges are entries of the one table, marknav.sim.randomisation (``mujoco.*``, ``room.*``);
# these names are kept for the docstring above and existing callers.
LIGHT_COUNT = counts("mujoco.light_count")
LIGHT_HEIGHT_MM = bounds("mujoco.light_height")
#: Lamps hang within this of the course (a geometric margin, not a drawn range).
LIGHT_SPREAD_MM = 2000.0
LIGHT_DIFFUSE = bounds("mujoco.light_diffuse")
TINT_MAX = bounds("mujoco.light_tint")[1]
DIM_PROBABILITY = 0.25
DIM_FACTOR = bounds("mujoco.dim_factor")
AMBIENT = bounds("mujoco.ambient")
CHECKER_MM = bounds("mujoco.checker")
OCCLUDER_COUNT = counts("room.occluders")
OCCLUDER_RADIUS_MM = bounds("mujoco.occluder_radius")
OCCLUDER_HEIGHT_MM = bounds("mujoco.occluder_height")
DISTRACTOR_COUNT = counts("room.distractors")
DISTRACTOR_SIZE_MM = bounds("mujoco.distractor_size")
NEAR_HUE_OFFSET = bounds("room.near_hue_offset")
#: Occluders and distractors stand at least this far beyond the lane the robot drives.
CORRIDOR_MARGIN_MM = 300.0
CORRIDOR_SPAN_MM = bounds("mujoco.corridor_offset")[1]
MARK_YAW_MAX_DEG = bounds("mujoco.mark_yaw")[1]

_Finite = Annotated[Number, Field(allow_inf_nan=False)]
_Unit = Annotated[Number, Field(ge=0.0, le=2.0, allow_inf_nan=False)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Light(_Strict):
    """A ceiling lamp: a spotlight pointing down at (x_mm, y_mm, z_mm); ``rgb`` its diffuse
    colour and intensity (1 = MuJoCo's full scale per channel)."""

    x_mm: _Finite
    y_mm: _Finite
    z_mm: Annotated[Number, Field(gt=0.0, le=10_000.0, allow_inf_nan=False)] = 2500.0
    rgb: tuple[_Unit, _Unit, _Unit] = (0.5, 0.5, 0.5)
    shadows: bool = True


class Occluder(_Strict):
    """A pole standing on the floor (a table leg, a lamp stand)."""

    x_mm: _Finite
    y_mm: _Finite
    radius_mm: Annotated[Number, Field(gt=0.0, le=500.0, allow_inf_nan=False)] = 20.0
    height_mm: Annotated[Number, Field(gt=0.0, le=5000.0, allow_inf_nan=False)] = 1000.0
    grey: Annotated[Number, Field(ge=0.0, le=1.0, allow_inf_nan=False)] = 0.35


class Distractor(_Strict):
    """A ball or box of a colour near a mark colour's: ``near`` names the palette colour, and
    the hue is ``hue_offset`` units past its range (positive: past its upper end)."""

    x_mm: _Finite
    y_mm: _Finite
    z_mm: Annotated[Number, Field(ge=0.0, le=3000.0, allow_inf_nan=False)] = 300.0
    shape: Literal["ball", "box"] = "ball"
    size_mm: Annotated[Number, Field(gt=0.0, le=1000.0, allow_inf_nan=False)] = 150.0
    near: str = Field(min_length=1)
    hue_offset: Annotated[Number, Field(ge=-30.0, le=30.0, allow_inf_nan=False)] = 9.0


class MujocoScene(_Strict):
    """The MuJoCo engine's room (see the module docstring); the built-in engine ignores it."""

    lights: tuple[Light, ...] | None = None  # None: one white lamp above the course
    ambient: Annotated[Number, Field(ge=0.0, le=1.0, allow_inf_nan=False)] = 0.3
    floor: Literal["plain", "checker", "photo"] = "plain"
    wall: Literal["plain", "gradient", "photo"] = "plain"
    checker_mm: Annotated[Number, Field(gt=10.0, le=2000.0, allow_inf_nan=False)] = 300.0
    texture_seed: Annotated[Integer, Field(ge=0)] = 0
    occluders: tuple[Occluder, ...] = ()
    distractors: tuple[Distractor, ...] = ()


def _off_course(rng: np.random.Generator, marks: Sequence[tuple[float, float]],
                lane_half_mm: float) -> tuple[float, float]:
    """A point beside the lane the robot drives (x across, y along the course from the
    origin): at least ``CORRIDOR_MARGIN_MM`` and at most that plus ``CORRIDOR_SPAN_MM``
    outside it, anywhere along the course."""
    ys = [y for _, y in marks] or [2000.0]
    y = float(rng.uniform(0.0, max(ys) + 1000.0))
    side = 1.0 if rng.random() < 0.5 else -1.0
    xs = [x for x, _ in marks] or [0.0]
    centre = 0.5 * (min(xs) + max(xs))
    x = centre + side * (lane_half_mm + CORRIDOR_MARGIN_MM
                         + float(rng.uniform(*bounds("mujoco.corridor_offset"))))
    return x, y


def random_scene(seed: int, marks: Sequence[tuple[float, float]], colours: Sequence[str], *,
                 clearance_mm: float, robot_radius_mm: float = 165.0) -> MujocoScene:
    """A randomised MuJoCo room for a course of ``marks`` ((x, y) mm, course along +y from the
    origin) of ``colours``, drawn from ``seed`` on its own stream (see the module docstring)."""
    rng = np.random.default_rng([int(seed), 0x3D5CE])
    xs = [x for x, _ in marks] or [0.0]
    ys = [y for _, y in marks] or [2000.0]
    lane_half = 0.5 * (max(xs) - min(xs)) + clearance_mm + robot_radius_mm
    dim = (float(rng.uniform(*DIM_FACTOR)) if rng.random() < DIM_PROBABILITY else 1.0)
    lights = []
    for _ in range(int(rng.integers(LIGHT_COUNT[0], LIGHT_COUNT[1] + 1))):
        tint = 1.0 + rng.uniform(*bounds("mujoco.light_tint"), size=3)
        level = float(rng.uniform(*LIGHT_DIFFUSE)) * dim
        lights.append(Light(
            x_mm=round(float(rng.uniform(min(xs) - LIGHT_SPREAD_MM, max(xs) + LIGHT_SPREAD_MM)),
                       1),
            y_mm=round(float(rng.uniform(-LIGHT_SPREAD_MM / 2, max(ys) + LIGHT_SPREAD_MM / 2)),
                       1),
            z_mm=round(float(rng.uniform(*LIGHT_HEIGHT_MM)), 1),
            rgb=(round(level * float(tint[0]), 3), round(level * float(tint[1]), 3),
                 round(level * float(tint[2]), 3)),
        ))
    occluders = []
    for _ in range(int(rng.integers(OCCLUDER_COUNT[0], OCCLUDER_COUNT[1] + 1))):
        x, y = _off_course(rng, marks, lane_half)
        occluders.append(Occluder(
            x_mm=round(x, 1), y_mm=round(y, 1),
            radius_mm=round(float(rng.uniform(*OCCLUDER_RADIUS_MM)), 1),
            height_mm=round(float(rng.uniform(*OCCLUDER_HEIGHT_MM)), 1),
            grey=round(float(rng.uniform(*bounds("mujoco.occluder_grey"))), 2)))
    distractors = []
    palette = sorted(set(colours))
    for _ in range(int(rng.integers(DISTRACTOR_COUNT[0], DISTRACTOR_COUNT[1] + 1))):
        if not palette:
            break
        x, y = _off_course(rng, marks, lane_half)
        size = float(rng.uniform(*DISTRACTOR_SIZE_MM))
        offset = float(rng.uniform(*NEAR_HUE_OFFSET)) * (1.0 if rng.random() < 0.5 else -1.0)
        distractors.append(Distractor(
            x_mm=round(x, 1), y_mm=round(y, 1),
            z_mm=round(float(rng.uniform(size / 2.0, 500.0)), 1),
            shape="ball" if rng.random() < 0.6 else "box", size_mm=round(size, 1),
            near=palette[int(rng.integers(len(palette)))], hue_offset=round(offset, 2)))
    return MujocoScene(
        lights=tuple(lights),
        ambient=round(float(rng.uniform(*AMBIENT)) * dim, 3),
        floor=("plain", "checker", "photo")[int(rng.integers(3))],
        wall=("plain", "gradient", "photo")[int(rng.integers(3))],
        checker_mm=round(float(rng.uniform(*CHECKER_MM)), 1),
        texture_seed=int(seed),
        occluders=tuple(occluders),
        distractors=tuple(distractors),
    )


def near_hue(lo: int, hi: int, offset: float) -> float:
    """The hue ``offset`` units past the range ``lo``..``hi`` (OpenCV units; the range may wrap):
    past ``hi`` for a positive offset, before ``lo`` for a negative one."""
    hue = hi + offset if offset >= 0 else lo + offset
    return math.fmod(hue + 180.0, 180.0)
