"""Scoring detections against painted truth: which found marks are the marks that were drawn."""

from __future__ import annotations

import math
from collections.abc import Sequence

from marknav.sim.synthetic.scene import TruthMark
from marknav.vision.detect import Mark

__all__ = ["match_marks"]


def match_marks(found: Sequence[Mark], truth: Sequence[TruthMark],
                ) -> tuple[list[tuple[TruthMark, Mark]], list[TruthMark], list[Mark]]:
    """Pair detections with painted marks (same colour, centre within max(3 px, half the
    radius)), greedily by distance. Returns (pairs, missed truths, false detections)."""
    options = []
    for i, t in enumerate(truth):
        for j, f in enumerate(found):
            d = math.hypot(t.x - f.x, t.y - f.y)
            if f.colour == t.colour and d <= max(3.0, 0.5 * t.b):
                options.append((d, i, j))
    options.sort()
    used_t: set[int] = set()
    used_f: set[int] = set()
    pairs: list[tuple[TruthMark, Mark]] = []
    for _, i, j in options:
        if i in used_t or j in used_f:
            continue
        used_t.add(i)
        used_f.add(j)
        pairs.append((truth[i], found[j]))
    missed = [t for i, t in enumerate(truth) if i not in used_t]
    false = [f for j, f in enumerate(found) if j not in used_f]
    return pairs, missed, false
