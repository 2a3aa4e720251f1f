"""Stage 5, suppression: the marks that can be the course's, one per object.

A mark's centre stands at camera height (paper §3.1), so with a horizon band set only marks
centred in it are kept. Of two marks one of whose centres lies inside the other, the larger
stands: a visible
mark's centre cannot lie behind another mark's face, so the smaller is a piece of it (a
highlight's cut, a seam) or clutter in front of it. Largest (nearest) first.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from marknav.vision.detect.model import Mark
from marknav.vision.detect.scene import Scene

__all__ = ["SuppressConfig", "centre_inside", "suppress"]


@dataclass(frozen=True)
class SuppressConfig:
    """Where marks' centres lie (px, full resolution)."""

    #: The row marks' centres lie near (the principal point's row for a level camera), and how
    #: far from it they may lie (pitch, roll, uneven floors); ``None``: anywhere.
    horizon_row: float | None = None
    horizon_tolerance_px: float = 24.0


def centre_inside(a: Mark, b: Mark) -> bool:
    """Whether ``a``'s centre lies inside ``b``'s ellipse."""
    t = math.radians(b.angle_deg)
    dx, dy = a.x - b.x, a.y - b.y
    u = (dx * math.cos(t) + dy * math.sin(t)) / max(b.axes[0], 1e-9)
    v = (-dx * math.sin(t) + dy * math.cos(t)) / max(b.axes[1], 1e-9)
    return u * u + v * v < 1.0


def suppress(scene: Scene, config: SuppressConfig) -> Scene:
    """The scene's marks in the band, one per object, largest first."""
    row = config.horizon_row
    kept: list[Mark] = []
    for m in sorted(scene.marks, key=lambda m: -m.radius):
        if row is not None and abs(m.y - row) > config.horizon_tolerance_px:
            continue
        if any(centre_inside(m, k) or centre_inside(k, m) for k in kept):
            continue
        kept.append(m)
    return replace(scene, marks=tuple(kept))
