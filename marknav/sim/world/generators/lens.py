"""The camera lens of a randomised world (``lens``): a webcam's distortion and principal point,
:func:`marknav.sim.lens.random_lens`, on its own stream."""

from __future__ import annotations

import numpy as np

from marknav.sim.lens import random_lens
from marknav.sim.world.generators.registry import Draft, register

__all__: list[str] = []


@register("lens")
def lens(draft: Draft) -> None:
    """A webcam's lens for randomised worlds, from its own stream so the other draws stay."""
    if draft.request.randomised:
        rng = np.random.default_rng([draft.request.seed, 0x1E45])
        draft.conditions = draft.conditions.model_copy(update={"lens": random_lens(rng)})
