"""Colour palettes: which hue range is which mark colour.

Hue is in OpenCV units (0..179, degrees / 2). A range may wrap past 179: red is ``170..10``.
Saturation and value floors reject grey background and shadows; their defaults suit marks
painted in strong colours.
"""

from __future__ import annotations

from dataclasses import dataclass

HUE_MAX = 180  # OpenCV 8-bit hue is 0..179


@dataclass(frozen=True)
class ColourRange:
    """One named colour: a hue interval (inclusive, may wrap) plus saturation/value floors."""

    name: str
    hue_lo: int
    hue_hi: int
    sat_min: int = 100
    val_min: int = 50

    def __post_init__(self) -> None:
        for label, value in (("hue_lo", self.hue_lo), ("hue_hi", self.hue_hi)):
            if not 0 <= value < HUE_MAX:
                raise ValueError(f"{self.name}: {label}={value} outside 0..179")
        for label, value in (("sat_min", self.sat_min), ("val_min", self.val_min)):
            if not 0 <= value <= 255:
                raise ValueError(f"{self.name}: {label}={value} outside 0..255")

    @property
    def wraps(self) -> bool:
        """True when the range crosses 179 → 0 (like red's 170..10)."""
        return self.hue_lo > self.hue_hi

    @property
    def width(self) -> int:
        """Number of hue steps in the range (inclusive)."""
        return (self.hue_hi - self.hue_lo) % HUE_MAX + 1

    def contains(self, hue: float) -> bool:
        """Whether hue (0..180, may be fractional) falls in the range, honouring the wrap."""
        h = hue % HUE_MAX
        if self.wraps:
            return h >= self.hue_lo or h <= self.hue_hi
        return self.hue_lo <= h <= self.hue_hi

    @property
    def centre_hue(self) -> float:
        """The middle of the range, wrapped into 0..180 (the simulator paints marks this hue)."""
        return (self.hue_lo + (self.width - 1) / 2.0) % HUE_MAX

    def distance(self, hue: float) -> float:
        """Circular distance (hue units) from ``hue`` to the nearest edge of the range; 0 inside."""
        if self.contains(hue):
            return 0.0
        h = hue % HUE_MAX
        d_lo = min(abs(h - self.hue_lo), HUE_MAX - abs(h - self.hue_lo))
        d_hi = min(abs(h - self.hue_hi), HUE_MAX - abs(h - self.hue_hi))
        return min(d_lo, d_hi)


Palette = tuple[ColourRange, ...]

#: Used by ``marknav detect`` when no mission is given.
#: Red is narrow around 179 (where the simulator paints it) so that orange starts at 4: orange
#: sweets in OpenCV's smarties.png have mean hues 6.7-8.7 (red ones 179.2-179.8), and a red range
#: up to 8 called them red.
DEFAULT_PALETTE: Palette = (
    ColourRange("red", 175, 3),
    ColourRange("orange", 4, 20),
    ColourRange("yellow", 21, 35),
    ColourRange("green", 40, 85),
    ColourRange("blue", 95, 130),
)
