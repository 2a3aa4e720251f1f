"""Background clutter: the non-circular coloured shapes (posters, tape stripes) on the built-in
renderer's far wall, drawn from the world's background seed (:func:`clutter_items`). Their sizes
and colours are the ``clutter.*`` ranges of :mod:`marknav.sim.randomisation`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from marknav.sim.randomisation import bounds, counts
from marknav.sim.world.schema import Background, World

__all__ = ["CLUTTER_CLEAR_DEG", "CLUTTER_MAX_ELEVATION_DEG", "ClutterItem", "clutter_items"]

#: Clutter stays this far above or below the horizon, where the marks' centres are: a mark
#: farther than ~1.2 m (radius < 50 px at f = 590) never touches it.
CLUTTER_CLEAR_DEG = 5.0
CLUTTER_MAX_ELEVATION_DEG = 21.0
#: Hues of common mark colours (OpenCV units): half of the clutter is drawn near one of them.
_LOOKALIKE_HUES = (0.0, 15.0, 28.0, 62.0, 112.0, 150.0)


@dataclass(frozen=True)
class ClutterItem:
    """A non-circular coloured shape on the far wall, in angular coordinates around the robot.

    ``kind`` is ``"rect"`` (a poster, aspect ≥ 2) or ``"stripes"`` (``bars`` parallel bars).
    Azimuth is in the world frame (CCW from +x); elevation is above the horizon (negative below).
    """

    kind: Literal["rect", "stripes"]
    azimuth_deg: float
    elevation_deg: float
    width_deg: float
    height_deg: float
    hue: float  # OpenCV units 0..179
    sat: int
    val: int
    bars: int = 1


def _size(rng: np.random.Generator, kind: str) -> tuple[float, float]:
    """Width and height of a shape, degrees."""
    long_side = float(rng.uniform(*bounds("clutter.long_side")))
    short_side = long_side / float(rng.uniform(*bounds("clutter.aspect")))
    if rng.random() < 0.5:
        w, h = long_side, short_side
    else:
        w, h = short_side, long_side
    if kind == "stripes":
        w, h = max(w, h), max(w, h) * float(rng.uniform(*bounds("clutter.stripes_aspect")))
    return w, min(h, CLUTTER_MAX_ELEVATION_DEG - CLUTTER_CLEAR_DEG - 0.5)


def _item(rng: np.random.Generator) -> ClutterItem:
    kind: Literal["rect", "stripes"] = "rect" if rng.random() < 0.6 else "stripes"
    w, h = _size(rng, kind)
    lo = CLUTTER_CLEAR_DEG + h / 2.0
    hi = CLUTTER_MAX_ELEVATION_DEG - h / 2.0
    elev = float(rng.uniform(lo, max(lo, hi)))
    if rng.random() < 0.3:
        elev = -elev
    if rng.random() < 0.5:
        hue = float(_LOOKALIKE_HUES[int(rng.integers(len(_LOOKALIKE_HUES)))]
                    + rng.uniform(*bounds("clutter.hue_jitter"))) % 180.0
    else:
        hue = float(rng.uniform(0.0, 180.0))
    sat_lo, sat_hi = counts("clutter.saturation")
    val_lo, val_hi = counts("clutter.value")
    bars_lo, bars_hi = counts("clutter.stripe_bars")
    return ClutterItem(
        kind=kind,
        azimuth_deg=float(rng.uniform(0.0, 360.0)),
        elevation_deg=elev,
        width_deg=w,
        height_deg=h,
        hue=hue,
        sat=int(rng.integers(sat_lo, sat_hi + 1)),
        val=int(rng.integers(val_lo, val_hi + 1)),
        bars=int(rng.integers(bars_lo, bars_hi + 1)) if kind == "stripes" else 1,
    )


def clutter_items(world: World | Background) -> tuple[ClutterItem, ...]:
    """The world's background clutter, drawn from ``background.seed`` (deterministic)."""
    background = world.background if isinstance(world, World) else world
    rng = np.random.default_rng([background.seed, 0xC1077E5])
    return tuple(_item(rng) for _ in range(background.clutter))
