"""The generators' registry: each part of a generated world (its conditions, room, lens,
realism, course, MuJoCo room, friction patches) is drawn by a function registered here under a
name, one file per kind, as :func:`marknav.sim.world.generate.generate_world` runs them in its
fixed order (:data:`~marknav.sim.world.generate.STEPS`).

A generator takes the :class:`Draft` (the request, the main random stream and what earlier
steps drew) and fills in its part. Generators that draw from a stream of their own seed it from
the world's seed and a constant of their own, so adding one leaves every other draw of a seed
as it was; the main stream (``Draft.rng``) is shared, in order, by the image/wheel conditions
and the course.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from marknav.sim.mujoco.scene import MujocoScene
from marknav.sim.world.schema import Conditions, FrictionPatch, MarkSpec, RobotStart

__all__ = ["GENERATORS", "Draft", "Generator", "Request", "register"]


@dataclass(frozen=True)
class Request:
    """What :func:`~marknav.sim.world.generate.generate_world` was asked for (its arguments)."""

    route: Sequence[str]
    seed: int
    clearance_mm: float
    radius_mm: float
    conditions: Literal["randomised", "default"] | Conditions
    bypass_distance_mm: float
    sides: Sequence[Literal["left", "right"]] | None
    half_fov_deg: float
    start: RobotStart | None
    clutter: int
    engine: Literal["builtin", "mujoco"]
    patches: bool

    @property
    def randomised(self) -> bool:
        return isinstance(self.conditions, str) and self.conditions == "randomised"


@dataclass
class Draft:
    """A world being generated: the request, the main random stream, and the parts drawn."""

    request: Request
    rng: np.random.Generator
    robot: RobotStart
    conditions: Conditions = field(default_factory=Conditions)
    marks: list[MarkSpec] = field(default_factory=list)
    mujoco: MujocoScene | None = None
    patches: tuple[FrictionPatch, ...] = ()


Generator = Callable[[Draft], None]

#: name → generator, filled by :func:`register` as the generator modules are imported.
GENERATORS: dict[str, Generator] = {}


def register(name: str) -> Callable[[Generator], Generator]:
    """Register the decorated function as the generator ``name``."""
    def decorate(fn: Generator) -> Generator:
        known = GENERATORS.get(name)
        if known is not None and known.__qualname__ != fn.__qualname__:
            raise ValueError(f"a world generator named {name!r} is already registered")
        GENERATORS[name] = fn
        return fn
    return decorate
