"""What the detector returns: :class:`Mark`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

__all__ = ["MIN_RADIUS_FLOOR_PX", "Mark", "Shape"]

#: The smallest mark radius the pipeline measures reliably (px): below it a disc is a few
#: blurred pixels whose shape says nothing.
MIN_RADIUS_FLOOR_PX = 2.5

Shape = Literal["circle", "ellipse"]


@dataclass(frozen=True)
class Mark:
    """One detected mark, in pixels (u right, v down; pixel centres at integer coordinates).

    ``radius`` is the semi-major axis; ``axes`` is (semi-major, semi-minor); ``angle_deg`` is the
    direction of the major axis, degrees in [0, 180) from +u towards +v, as fitted also for
    circles (it says which axis stands upright, which the range needs:
    :func:`marknav.vision.estimate.estimate_disc`; it means nothing when the axes are equal).
    ``score`` in [0, 1] grows with the share of the outline seen, the fit quality and the colour
    purity.
    """

    colour: str
    x: float
    y: float
    radius: float
    axes: tuple[float, float]
    angle_deg: float
    shape: Shape
    score: float

    def to_dict(self) -> dict[str, object]:
        """The JSON form: ``{colour, x, y, radius, axes, angle, shape, score}`` (angle: deg)."""
        return {
            "colour": self.colour,
            "x": round(self.x, 2),
            "y": round(self.y, 2),
            "radius": round(self.radius, 2),
            "axes": [round(self.axes[0], 2), round(self.axes[1], 2)],
            "angle": round(self.angle_deg, 1),
            "shape": self.shape,
            "score": round(self.score, 3),
        }
