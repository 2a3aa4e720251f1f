"""World generators, one file per kind, registered by name (:mod:`.registry`).

Importing this package registers them all: ``conditions`` (image and wheel conditions),
``room`` (the built-in renderer's room), ``lens``, ``realism`` (camera timing, printed marks,
encoders, wheels, link, battery), ``course`` (the marks), ``mujoco`` (MuJoCo's room) and
``patches`` (friction patches). Their ranges are in :mod:`marknav.sim.randomisation`.
"""

from __future__ import annotations

from marknav.sim.world.generators import (  # noqa: F401  (each registers its generator)
    conditions,
    course,
    lens,
    mujoco_room,
    patches,
    realism,
    room,
)
from marknav.sim.world.generators.registry import GENERATORS, Draft, Generator, Request, register

__all__ = ["GENERATORS", "Draft", "Generator", "Request", "register"]
