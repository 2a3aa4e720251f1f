"""The room of a randomised built-in world as its renderer draws it (``room``): floor, wall,
wall tint, occluders, distractors — :func:`marknav.sim.scenery.random_room`, on its own stream."""

from __future__ import annotations

from marknav.sim.scenery import random_room
from marknav.sim.world.generators.registry import Draft, register

__all__: list[str] = []


@register("room")
def room(draft: Draft) -> None:
    """Harder rooms for randomised built-in worlds, drawn from the world's seed on their own
    stream (a MuJoCo world's room is its ``mujoco`` section, the ``mujoco`` step)."""
    if draft.request.randomised and draft.request.engine == "builtin":
        draft.conditions = draft.conditions.model_copy(update=random_room(draft.request.seed))
