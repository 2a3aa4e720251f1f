"""The image and wheel conditions of a generated world (``conditions``): light, cast, noise,
blur, unequal wheels, slip, latency in frames — drawn from the world's main random stream, before
the course, from the ``camera.*`` and ``wheels.*`` ranges of :mod:`marknav.sim.randomisation`;
or the caller's own :class:`~marknav.sim.world.schema.Conditions`, or the defaults."""

from __future__ import annotations

import numpy as np

from marknav.sim.randomisation import bounds, counts
from marknav.sim.world.generators.registry import Draft, register
from marknav.sim.world.schema import Conditions

__all__ = ["RANDOM_CASTS", "random_conditions"]

#: The colour casts a randomised world draws from
#: (:data:`~marknav.sim.world.schema.CAST_GAINS_BGR`).
RANDOM_CASTS: tuple[str, ...] = ("none", "warm", "cool")


def random_conditions(rng: np.random.Generator) -> Conditions:
    """Conditions drawn uniformly from the table's ranges (what ``evaluate`` randomises)."""
    lo, hi = counts("camera.latency_frames")
    return Conditions(
        lighting_gain=float(rng.uniform(*bounds("camera.lighting_gain"))),
        cast=RANDOM_CASTS[int(rng.integers(len(RANDOM_CASTS)))],  # type: ignore[arg-type]
        noise_sigma=float(rng.uniform(*bounds("camera.noise_sigma"))),
        blur_sigma_px=float(rng.uniform(*bounds("camera.blur_sigma"))),
        wheel_mismatch=float(rng.uniform(*bounds("wheels.mismatch"))),
        wheel_slip=float(rng.uniform(*bounds("wheels.slip"))),
        latency_frames=int(rng.integers(lo, hi + 1)),
    )


@register("conditions")
def conditions(draft: Draft) -> None:
    """The caller's conditions, the defaults, or (``"randomised"``) :func:`random_conditions`."""
    wanted = draft.request.conditions
    if isinstance(wanted, Conditions):
        draft.conditions = wanted
    elif draft.request.randomised:
        draft.conditions = random_conditions(draft.rng)
    else:
        draft.conditions = Conditions()
