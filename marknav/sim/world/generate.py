"""Generated worlds: :func:`generate_world` builds a world from a mission's route when no world
file is given, running the registered generators (:mod:`marknav.sim.world.generators`) in the
order of :data:`STEPS`. Deterministic for a seed: every generator draws either from the world's
main stream, in this order, or from a stream of its own seeded by the world's seed."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numpy as np

from marknav.sim.world.generators import GENERATORS, Draft, Request
from marknav.sim.world.generators.course import DEFAULT_HALF_FOV_DEG
from marknav.sim.world.schema import (
    DEFAULT_MARK_RADIUS_MM,
    Background,
    Conditions,
    RobotStart,
    World,
)

__all__ = ["STEPS", "generate_world"]

#: The generators, in the order they run. ``conditions`` and ``course`` share the main random
#: stream (in this order); the others draw from streams of their own.
STEPS: tuple[str, ...] = ("conditions", "room", "lens", "realism", "course", "mujoco", "patches")


def _check(route: Sequence[str], clearance_mm: float, radius_mm: float,
           bypass_distance_mm: float, sides: Sequence[str] | None, conditions: object) -> None:
    if clearance_mm <= 0 or radius_mm <= 0 or bypass_distance_mm <= 0:
        raise ValueError("clearance, radius and bypass distance must be positive")
    if sides is not None and len(sides) != len(route):
        raise ValueError(f"sides has {len(sides)} entries for a route of {len(route)}")
    if not isinstance(conditions, Conditions) and conditions not in ("randomised", "default"):
        raise ValueError(f"conditions must be 'randomised', 'default' or Conditions: {conditions}")


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

    The marks (:mod:`marknav.sim.world.generators.course`) go along the start's heading, each in
    view from where the previous bypass ends (``clearance_mm`` beside it, on ``sides`` or either
    side; the next mark at least ``bypass_distance_mm`` plus a margin away, within
    ``half_fov_deg`` plus a short search turn). With ``conditions="randomised"`` the image/wheel
    conditions (:func:`~marknav.sim.world.generators.conditions.random_conditions`) and every
    mark's yaw are drawn too, and from streams of their own the room
    (:func:`marknav.sim.scenery.random_room`), the lens, the realism conditions
    (:func:`~marknav.sim.world.generators.realism.random_realism`) and, with ``patches``,
    friction patches on the course (not drawn by default — a patch under one wheel during a
    bypass, with the mark out of view, turns the robot where odometry cannot see it; see
    docs/explanation/simulator-realism.md). For ``engine="mujoco"`` the yaw goes up to ±60° and
    the room gets MuJoCo's lights, textures, occluders and distractors
    (:func:`marknav.sim.mujoco.scene.random_scene`, its own stream: the course is the same).
    The ranges are those of :mod:`marknav.sim.randomisation`. Same arguments and seed → same
    world.
    """
    _check(route, clearance_mm, radius_mm, bypass_distance_mm, sides, conditions)
    request = Request(route=route, seed=int(seed), clearance_mm=clearance_mm,
                      radius_mm=radius_mm, conditions=conditions,
                      bypass_distance_mm=bypass_distance_mm, sides=sides,
                      half_fov_deg=half_fov_deg, start=start, clutter=clutter, engine=engine,
                      patches=patches)
    draft = Draft(request=request, rng=np.random.default_rng([int(seed), 0x5EED]),
                  robot=start if start is not None else RobotStart())
    for step in STEPS:
        GENERATORS[step](draft)
    return World(
        marks=tuple(draft.marks),
        robot=draft.robot,
        conditions=draft.conditions,
        background=Background(seed=int(seed), clutter=clutter),
        patches=draft.patches,
        course=tuple(range(len(draft.marks))),
        mujoco=draft.mujoco,
    )
