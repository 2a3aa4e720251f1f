"""Which discs on the floor overlap, in about linear time (a uniform grid).

A world's marks must not overlap. Checking every pair is quadratic: a 6,000-mark world (well
under the file-size limit) took over 20 s to validate. Here each disc is put in a square cell
of a grid as wide as the largest disc; a disc can only overlap discs in its own cell and the
eight around it, so each is compared with its neighbours only. The pair reported is the one the
all-pairs loop would report first: the lowest index that overlaps an earlier disc, and the
earliest disc it overlaps.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Sequence

__all__ = ["first_overlap"]

_NEIGHBOURS = tuple((dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1))


def first_overlap(centres: Sequence[tuple[float, float]], radii: Sequence[float]
                  ) -> tuple[int, int] | None:
    """``(j, i)`` with ``i < j`` for the first disc ``j`` (centre mm, radius mm) that overlaps
    an earlier disc ``i`` (centres closer than the sum of the radii; touching is not
    overlapping), or ``None``. Radii must be positive and every number finite."""
    if not centres:
        return None
    cell = 2.0 * max(radii)  # any overlapping pair is closer than this: adjacent cells
    grid: dict[tuple[int, int], list[int]] = defaultdict(list)
    for j, ((x, y), r) in enumerate(zip(centres, radii, strict=True)):
        cx, cy = math.floor(x / cell), math.floor(y / cell)
        hits = [i for dx, dy in _NEIGHBOURS for i in grid.get((cx + dx, cy + dy), ())
                if math.dist(centres[i], (x, y)) < radii[i] + r]
        if hits:
            return j, min(hits)
        grid[(cx, cy)].append(j)
    return None
