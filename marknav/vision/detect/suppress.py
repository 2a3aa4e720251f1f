"""Suppression: one mark per object when several readings of a blob overlap."""

from __future__ import annotations

import math

from marknav.vision.detect.model import Mark


def _centre_in(a: Mark, b: Mark) -> bool:
    """Whether ``a``'s centre lies inside ``b``'s ellipse."""
    t = math.radians(b.angle_deg)
    dx, dy = a.x - b.x, a.y - b.y
    u = (dx * math.cos(t) + dy * math.sin(t)) / max(b.axes[0], 1e-9)
    v = (-dx * math.sin(t) + dy * math.cos(t)) / max(b.axes[1], 1e-9)
    return u * u + v * v < 1.0


def _suppress_duplicates(marks: list[Mark]) -> list[Mark]:
    """Drop a mark whose centre lies inside a better-scoring mark of similar size, and a mark
    that holds the centres of two smaller marks apart from each other (an outline fitted
    across touching marks; not two readings of one piece).
    Of two marks one of whose centres lies inside the other, only the better-scoring one
    stands: a visible mark's centre cannot be behind another mark's face, so one of the two is
    an outline fitted across a mark and something touching it (clutter of the same colour)."""
    def inside(small: Mark, big: Mark) -> bool:
        return small.radius < 0.8 * big.radius and \
            math.hypot(small.x - big.x, small.y - big.y) < big.radius

    def apart(a: Mark, b: Mark) -> bool:
        # Two marks, not two readings of one (the same piece found twice, or the halves of
        # a mark cut by a pole, whose fits overlap).
        return math.hypot(a.x - b.x, a.y - b.y) >= 0.5 * (a.radius + b.radius)

    def spans_two(big: Mark) -> bool:
        held = [o for o in marks if o is not big and inside(o, big)]
        return any(apart(a, b) for i, a in enumerate(held) for b in held[i + 1:])
    marks = [m for m in marks if not spans_two(m)]
    kept: list[Mark] = []
    for mark in sorted(marks, key=lambda m: -m.score):
        duplicate = any(
            _near(mark, k) and (
                (math.hypot(mark.x - k.x, mark.y - k.y) < 0.5 * min(mark.radius, k.radius)
                 and 0.6 <= mark.radius / k.radius <= 1.67)
                or _centre_in(mark, k) or _centre_in(k, mark))
            for k in kept
        )
        if not duplicate:
            kept.append(mark)
    return kept


def _near(a: Mark, b: Mark) -> bool:
    """Whether two marks' centres are close enough for either test of a duplicate: each needs
    them closer than the larger semi-axis (a centre inside an ellipse is within its semi-major
    axis), so the pairs of a crowded frame's far-apart marks cost one comparison (with a
    margin: this only skips, never decides)."""
    dx, dy = a.x - b.x, a.y - b.y
    reach = 1.001 * max(a.radius, b.radius, a.axes[0], a.axes[1], b.axes[0], b.axes[1]) + 1e-6
    return not dx * dx + dy * dy >= reach * reach  # (NaN: near, the tests decide)
