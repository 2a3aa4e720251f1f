"""The target's track: a small state machine over :class:`~marknav.behaviours.keys.Target`, and
the association gate derived from the errors of a range estimate.

States (:class:`TrackState`, read off a target by :func:`state_of`):

============  ==========================================  =====================================
state         what is known                               a frame's sighting of it is
============  ==========================================  =====================================
UNSEEN        its colour only (never seen)                the nearest unpassed mark of the colour
FOLLOWING     a sighting and a world estimate; no bypass  the same, unless its own mark is
              yet                                         remembered out of view and clearly
                                                          nearer (then none)
REMEMBERED    a world position from the mark memory; out  the mark of its colour nearest that
              of view                                     position within a widened gate, once
                                                          the position is near the heading
LOCKED        the bypass has started                      the mark of its colour nearest its
                                                          world estimate, within the gate
============  ==========================================  =====================================

Transitions (who makes them):

- UNSEEN/FOLLOWING → FOLLOWING: a sighting (:func:`~marknav.behaviours.target.with_sighting`,
  Perception every frame);
- UNSEEN/FOLLOWING → REMEMBERED: ``SelectTarget`` or a re-selection takes a remembered mark that
  is clearly nearer than any in view (:func:`~marknav.behaviours.target.choose_target`);
- REMEMBERED → FOLLOWING: a sighting (the memory is confirmed);
- REMEMBERED → any but LOCKED: the memory is gone (looked at where it should be and not seen),
  the target is chosen again (:func:`~marknav.behaviours.target.reselect`; the search drops it);
- FOLLOWING/REMEMBERED → LOCKED: the bypass starts (``Bypass``, :func:`lock`);
- LOCKED stays LOCKED until the waypoint is passed and the next waypoint selects a new target.

The **gate** (:class:`RangeGate`) is how far apart two estimates of one mark's world position may
lie. A monocular range d read from an image radius r by d = a·r^b is off by the law's own
relative error plus |b|·δr/r for a radius off by δr px (δd ≈ d·δr/r for a pinhole, b = −1;
field notes: δd ≈ d²·δr/(f·R)); near the mark the scatter of a partly seen disc and odometry's
drift dominate, a floor.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from marknav.behaviours import keys

__all__ = ["DEFAULT_GATE", "RangeGate", "TrackState", "lock", "state_of"]


class TrackState(enum.Enum):
    """Where the target's track stands (see the module docstring)."""

    UNSEEN = "unseen"
    FOLLOWING = "following"
    REMEMBERED = "remembered"
    LOCKED = "locked"


def state_of(target: keys.Target) -> TrackState:
    """The state of ``target``'s track (its ``locked``/``remembered`` flags and world estimate)."""
    if target.locked and target.world is not None:
        return TrackState.LOCKED
    if target.world is None:
        return TrackState.UNSEEN
    if target.remembered:
        return TrackState.REMEMBERED
    return TrackState.FOLLOWING


def lock(target: keys.Target) -> keys.Target:
    """The transition FOLLOWING/REMEMBERED → LOCKED (the bypass starts). A target never seen
    cannot be locked."""
    if target.world is None:
        raise ValueError(f"{target.label}: a target never seen cannot be locked")
    return keys.Target(target.waypoint, target.waypoint_id, target.colour, target.side,
                       target.sighting, target.world_x, target.world_y, True, False)


@dataclass(frozen=True)
class RangeGate:
    """How far apart (mm) two estimates of one mark's world position may lie, from the errors of
    a range estimate: max(``floor_mm``, d·(``law_error`` + |``law_exponent``|·``radius_error_px``
    / r)) for a sighting at range d with image radius r (px; unknown: the law's error only)."""

    #: Relative error of the range law (−): a camera's law as written may be off by a fifth
    #: until the robot has learnt its own (``camera.learn_range``).
    law_error: float = 0.2
    #: Exponent of the range law d ∝ r^b (−): −1 for a pinhole (eq. 2), −0.94 the paper's eq. 19.
    law_exponent: float = -1.0
    #: Error of a measured image radius (px): the contour fit's bias, about ±0.5 px (field notes),
    #: which grows relative to the radius as the mark shrinks with range.
    radius_error_px: float = 0.5
    #: Smallest gate (mm): near a mark its estimates scatter by about its diameter (200 mm for
    #: the 100 mm marks: a disc half hidden or cut by the image edge) plus odometry's drift over
    #: a bypass; beyond 1.25 m the law's error is the larger.
    floor_mm: float = 250.0

    def __post_init__(self) -> None:
        if not (0.0 <= self.law_error < 1.0 and self.radius_error_px >= 0.0
                and self.floor_mm >= 0.0 and self.law_exponent < 0.0):
            raise ValueError(f"invalid range gate {self}")

    def gate_mm(self, range_mm: float, radius_px: float | None = None) -> float:
        """The gate for an estimate ``range_mm`` away (``radius_px``: its image radius)."""
        relative = self.law_error
        if radius_px is not None and radius_px > 0.0:
            relative += abs(self.law_exponent) * self.radius_error_px / radius_px
        return max(self.floor_mm, relative * range_mm)


#: The gate the behaviours use.
DEFAULT_GATE = RangeGate()
