"""Friction patches of a randomised world (``patches``; only when asked for, see
``docs/explanation/simulator-realism.md``): rugs, polished or dusty floor on the course's legs,
from their own stream and the ``patches.*`` ranges of :mod:`marknav.sim.randomisation`."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from marknav.sim.randomisation import bounds, counts
from marknav.sim.world.generators.registry import Draft, register
from marknav.sim.world.schema import FrictionPatch

__all__ = ["random_patches"]


def random_patches(
    rng: np.random.Generator, course: Sequence[tuple[float, float]], start: tuple[float, float]
) -> tuple[FrictionPatch, ...]:
    """Friction patches on the way: each centred at a random point of a random leg of the course
    (start → first mark, mark → mark), its radius and slip drawn from the table's ranges."""
    lo, hi = counts("patches.count")
    n = int(rng.integers(lo, hi + 1))
    points = [start, *course]
    out: list[FrictionPatch] = []
    for _ in range(n if len(points) > 1 else 0):
        leg = int(rng.integers(len(points) - 1))
        f = float(rng.uniform(*bounds("patches.along_leg")))
        a, b = points[leg], points[leg + 1]
        out.append(FrictionPatch(
            x_mm=round(a[0] + f * (b[0] - a[0]), 1), y_mm=round(a[1] + f * (b[1] - a[1]), 1),
            radius_mm=round(float(rng.uniform(*bounds("patches.radius"))), 1),
            slip=round(float(rng.uniform(*bounds("patches.slip"))), 3)))
    return tuple(out)


@register("patches")
def patches(draft: Draft) -> None:
    """Patches on the course of a randomised world when the request asks for them."""
    if draft.request.randomised and draft.request.patches:
        start = draft.robot.pose()
        rng = np.random.default_rng([draft.request.seed, 0xF41C])
        draft.patches = random_patches(rng, [m.xy for m in draft.marks], (start.x, start.y))
