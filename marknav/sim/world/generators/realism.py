"""The realism conditions of a randomised world (``realism``): camera timing and exposure,
printed marks, encoders, wheels, command link, battery — from their own stream, the ranges of
:mod:`marknav.sim.randomisation` (``docs/explanation/simulator-realism.md`` has the sources)."""

from __future__ import annotations

import numpy as np

from marknav.sim.randomisation import bounds
from marknav.sim.world.generators.registry import Draft, register

__all__ = ["REALISM_RANGES", "random_realism"]

#: Condition key → the table's range it is drawn from, in the order drawn.
REALISM_RANGES: dict[str, str] = {
    "frame_rate_hz": "camera.frame_rate",
    "dropped_frames": "camera.dropped_frames",
    "exposure_ms": "camera.exposure",
    "exposure_drift": "camera.exposure_drift",
    "exposure_period_s": "camera.exposure_period",
    "mark_saturation": "marks.saturation",
    "mark_saturation_spread": "marks.saturation_spread",
    "mark_hue_spread": "marks.hue_spread",
    "encoder_scale": "encoders.scale",
    "encoder_noise_counts": "encoders.noise",
    "accel_mm_s2": "wheels.accel",
    "command_delay_ms": "link.command_delay",
    "top_speed_mm_s": "wheels.top_speed",
}


def random_realism(rng: np.random.Generator) -> dict[str, float]:
    """The realism conditions drawn uniformly from the table's ranges, as updates to
    :class:`~marknav.sim.world.schema.Conditions`. From its own random stream, so the other
    draws of a world stay put."""
    out = {key: float(rng.uniform(*bounds(name))) for key, name in REALISM_RANGES.items()}
    out["frame_rate_hz"] = round(out["frame_rate_hz"], 1)
    return out


@register("realism")
def realism(draft: Draft) -> None:
    """Realism conditions for randomised worlds, from their own stream."""
    if draft.request.randomised:
        rng = np.random.default_rng([draft.request.seed, 0x4EA1])
        draft.conditions = draft.conditions.model_copy(update=random_realism(rng))
