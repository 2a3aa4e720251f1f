"""What the detector returns (:class:`Mark`) and how it is tuned (:class:`DetectorConfig`)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Literal

__all__ = ["MIN_RADIUS_FLOOR_PX", "DetectorConfig", "Mark", "Shape"]

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


@dataclass(frozen=True)
class DetectorConfig:
    """Tuning of :class:`Detector`. The defaults suit 320×240 to 1280×720 frames.

    The saturation/value floors come from the palette (:class:`ColourRange`); the mask uses the
    lowest floors of the palette and each colour's own floors are checked on its blobs.
    """

    #: Grey-world white balance before classification (fixes warm/cool casts).
    white_balance: bool = True
    #: Lowest and highest white-balance gain per channel.
    gain_limits: tuple[float, float] = (0.6, 1.6)
    #: Largest green–magenta part of the white balance (natural log of G over the mean of B and
    #: R), or ``None`` for none: a room's lights differ along blue–amber, and a strong green or
    #: magenta excess in its greys is a painted wall or carpet. The robot's detector sets it
    #: (``camera.detect.tint_limit``); photographs from unknown cameras need plain grey world.
    tint_limit: float | None = None
    #: The palette's value floors hold for scenes whose grey level is at least this (0..255);
    #: in darker scenes (an under-exposed camera, dim light) they scale down with it.
    val_ref_grey: float = 100.0
    #: A blob's value floor is also at least this fraction of the scene's grey level.
    val_rel_min: float = 0.35
    #: Blob search at 1/downscale resolution (1 or 2); marks are measured at full resolution,
    #: whole ones of ``fine_radius`` or more in the search image.
    downscale: int = 2
    #: Search at half resolution only around the pixels of a quarter-resolution sample that
    #: pass the search mask (:mod:`.gate`; frames at least 128 px high, ``min_radius`` >= 4).
    coarse_gate: bool = True
    #: Search only pixels whose hue is a palette colour's (within ``hue_margin``): saturated
    #: surfaces of other hues stay out of the marks' blobs.
    hue_gate: bool = True
    #: A blob that gives no mark and holds several palette colours is read once more per
    #: colour (a mark against a large region of another palette colour: sky, foliage).
    split_colours: bool = True
    #: Widest thin occluder (pole, wire, seam; full-resolution px) a whole mark is joined
    #: across when its pieces give no mark on their own. 0: never joined.
    bridge_px: float = 8.0
    #: The horizon prior (paper §3.1: marks stand at camera height, so their centres lie near
    #: the horizon row): with ``horizon_row`` set (px, full resolution; the principal point's row
    #: for a level camera) only marks whose centre lies within ``horizon_tolerance_px`` of it are
    #: searched and reported. The tolerance covers pitch, roll and uneven floors.
    horizon_row: float | None = None
    horizon_tolerance_px: float = 24.0
    #: ``min_radius`` and ``min_partial_radius`` hold for frames this wide; wider frames scale
    #: them up in proportion (a 1280-px frame of the same scene has marks twice as large, and
    #: clutter twice as many pixels to look round in). ``None``: fixed pixels.
    reference_width: int | None = 640
    #: Side of the square opening applied to the search mask (odd, 1 = none).
    open_size: int = 3
    #: Smallest and largest semi-major axis reported (px); ``None`` = no upper limit.
    min_radius: float = 5.0
    max_radius: float | None = None
    #: Smallest radius of a mark seen only in part (cut by the image edge, partly hidden,
    #: touching another): a smaller arc cannot be told from the rounded end of a bar.
    min_partial_radius: float = 8.0
    #: Whole marks of at least this radius (px) are measured in the search image.
    fine_radius: float = 24.0
    #: Smallest minor/major ratio accepted: a disc seen θ off its face shows cos θ. Courses turn
    #: their marks up to 60° from the course and the robot sees a mark from up to about 12°
    #: beside the course (its start, a bypass's end), so views reach 72°: cos 72° ≈ 0.3. (At
    #: 0.4 — 66° — marks turned toward the edge of that range were passed unseen for a farther
    #: one of their colour; held-out recall 0.953 → 0.966 at 0.3, false marks unchanged.)
    min_axis_ratio: float = 0.3
    #: ``circle`` when minor/major is at least this, else ``ellipse``.
    circle_ratio: float = 0.9
    #: Hue (OpenCV units) a blob's mean hue may lie outside a palette range and still get its name.
    hue_margin: float = 2.0
    #: A blob holding two palette colours whose mean hues differ by at least this (OpenCV hue
    #: units), each over at least half a ``min_partial_radius`` disc, is also read per colour:
    #: touching marks. Closer hues are one mark's shading.
    split_hue_gap: float = 8.0
    #: A blob that gives no mark, even per hue, is split once by saturation (Otsu's threshold
    #: inside it) when the two parts' mean saturations differ by at least this much: a mark
    #: standing on a floor or in front of a board of its own hue but a paler saturation.
    #: 0: never.
    split_saturation_gap: float = 60.0
    #: Blobs whose area exceeds this share of their minimum bounding rectangle are rectangles.
    max_extent: float = 0.9
    #: Blobs smaller than 20 px (equivalent radius) filling less than this share of their
    #: minimum bounding rectangle are triangles or splinters.
    min_small_extent: float = 0.62
    #: Blob area / convex hull area at or above which a blob counts as convex (fast path).
    min_solidity: float = 0.93
    #: Largest mismatch between a whole mark's pixels and its fitted ellipse, in pixels per pixel
    #: of outline (0.25-0.55 for clean discs of any size; a square gives ≈ 0.05 × its side, a
    #: disc with a fifth of its outline hidden ≈ 0.02 × its radius). Larger: the arc path.
    max_outline_error: float = 0.65
    #: The same for whole marks measured in the search image (``fine_radius`` and more), in its
    #: pixels: a strong shading gradient moves a large mark's α = 0.5 rim there by up to one of
    #: them (0.70 on a dark red mark beside a near-colour board); clutter this large that fails
    #: the limit lies above 0.85 on the project's corpus.
    max_search_outline_error: float = 0.75
    #: Share of the visible outline (inside the image) that must be seen as the mark's edge
    #: (0.1 more for marks smaller than 2.5 × ``min_partial_radius``).
    min_support: float = 0.4
    #: Share of the whole outline that must be seen (a sliver at the image edge is not a mark).
    min_arc: float = 0.3
    #: Share of a partial mark's visible area that must have its colour.
    min_fill: float = 0.7
    #: Largest share of the visible outline across which the mark's colour goes on: more is the
    #: end of a stripe or a corner of a larger shape, not a mark.
    max_continued: float = 0.15
    #: Marks scoring lower than this are dropped.
    min_score: float = 0.05
    #: Drop glows: round blobs whose core is much brighter than their body (galaxies, lamps;
    #: :mod:`.glow`). A painted mark is flat.
    reject_glows: bool = True
    #: Drop faint blobs: marks whose colour (white-balanced, grey removed) differs from a ring
    #: just outside them by less than this many BGR units (:mod:`.faint`; scaled down in scenes
    #: darker than ``val_ref_grey``). Out-of-focus clutter of a palette hue is round but faint;
    #: a painted mark is not. 0: off.
    min_chroma_contrast: float = 44.0
    #: The most blob readings one frame gets (each blob, or part or joined shape of blobs,
    #: looked at as a mark: ``Detector.last_skipped`` counts the ones left unread). The
    #: project's frames need at most 258 (a composited photo); a mosaic of 8-px coloured
    #: squares needed 5,096 and 1.2–1.9 s at 640 px. The frame's largest blobs are read first.
    max_readings: int = 400

    @classmethod
    def for_camera(cls, *, focal_px: float, mark_radius_mm: float, max_range_mm: float,
                   floor_px: float = MIN_RADIUS_FLOOR_PX, **kwargs: Any) -> DetectorConfig:
        """A config whose minimum radius is that of a mark at ``max_range_mm`` (pinhole model,
        r = f·R/d, less 10 % for blur and yaw), not below ``floor_px`` (the smallest disc the
        pipeline measures: 2.5 px). Partial marks need 1.6× that. Pixels are the camera's own
        (``reference_width`` None)."""
        if not (focal_px > 0 and mark_radius_mm > 0 and max_range_mm > 0):
            raise ValueError("focal_px, mark_radius_mm and max_range_mm must be positive")
        r_min = max(floor_px, 0.9 * focal_px * mark_radius_mm / max_range_mm)
        kwargs.setdefault("min_radius", r_min)
        kwargs.setdefault("min_partial_radius", max(kwargs["min_radius"], 1.6 * r_min))
        kwargs.setdefault("reference_width", None)
        return cls(**kwargs)

    def for_width(self, width: int) -> DetectorConfig:
        """This config for frames ``width`` px wide (see ``reference_width``)."""
        ref = self.reference_width
        if ref is None or width <= ref:
            return self
        k = width / ref
        return replace(self, min_radius=self.min_radius * k,
                       min_partial_radius=self.min_partial_radius * k, reference_width=None)

    def __post_init__(self) -> None:
        if self.open_size < 1 or self.open_size % 2 == 0:
            raise ValueError(f"open_size must be odd and >= 1, got {self.open_size}")
        if self.downscale not in (1, 2):
            raise ValueError(f"downscale must be 1 or 2, got {self.downscale}")
        if self.min_radius <= 0:
            raise ValueError(f"min_radius must be > 0, got {self.min_radius}")
        if self.max_radius is not None and self.max_radius < self.min_radius:
            raise ValueError("max_radius must be >= min_radius")
        if self.min_partial_radius < self.min_radius:
            raise ValueError("min_partial_radius must be >= min_radius")
        if self.max_readings < 1:
            raise ValueError(f"max_readings must be >= 1, got {self.max_readings}")
        lo, hi = self.gain_limits
        if not 0 < lo <= 1 <= hi:
            raise ValueError(f"gain_limits must satisfy 0 < low <= 1 <= high, got {lo, hi}")
        if not self.min_chroma_contrast >= 0.0:
            raise ValueError(f"min_chroma_contrast must be >= 0, got {self.min_chroma_contrast}")
        if self.tint_limit is not None and not 0.0 <= self.tint_limit <= 1.0:
            raise ValueError(f"tint_limit must be in [0, 1] or None, got {self.tint_limit}")
        for name in ("min_axis_ratio", "circle_ratio", "min_support", "max_continued",
                     "min_arc", "min_fill", "val_rel_min", "min_score", "max_extent",
                     "min_small_extent", "min_solidity"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {value}")
