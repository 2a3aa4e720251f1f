"""MuJoCo's room for a randomised world run with ``engine="mujoco"`` (``mujoco``): lights,
textures, occluders, distractors — :func:`marknav.sim.mujoco.scene.random_scene`, on its own
stream (the course is the same in both engines)."""

from __future__ import annotations

from marknav.sim.mujoco.scene import random_scene
from marknav.sim.world.generators.registry import Draft, register

__all__: list[str] = []


@register("mujoco")
def mujoco_room(draft: Draft) -> None:
    """A randomised MuJoCo room around the drawn course (marks relative to the start)."""
    req = draft.request
    if req.engine == "mujoco" and req.randomised:
        p0 = draft.robot.pose()
        draft.mujoco = random_scene(req.seed, [(m.x_mm - p0.x, m.y_mm - p0.y) for m in draft.marks],
                                    list(req.route), clearance_mm=req.clearance_mm)
