"""The detector as a pipeline of pure stages over one frozen value, :class:`Scene`.

Each stage is a function ``Scene -> Scene`` with its own small frozen config; nothing is kept on
an object between frames. In order:

1. :mod:`.photometry` — the frame at half size, its exposure and light colour taken out;
2. :mod:`.classify` — one mask per palette colour (hue range, exposure-relative floors);
3. :mod:`.segment` — the masks opened and cut along the frame's own edges into blobs;
4. :mod:`.shape` — each blob measured as an ellipse at full resolution, kept if it is one;
5. :mod:`.suppress` — one mark per object, the horizon band, largest (nearest) first.

:class:`Detector` holds only the palette and the configs (both frozen) and runs the stages;
:func:`run_stages` runs any prefix of them, which is how the tests and the docs' pictures see
each stage's output.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import numpy.typing as npt

from marknav.vision.detect.classify import ClassifyConfig, classify
from marknav.vision.detect.model import MIN_RADIUS_FLOOR_PX, Mark
from marknav.vision.detect.photometry import PhotometryConfig, photometry
from marknav.vision.detect.scene import SEARCH_SCALE, Blob, Scene
from marknav.vision.detect.segment import SegmentConfig, segment
from marknav.vision.detect.shape import ShapeConfig, measure, screen
from marknav.vision.detect.suppression import SuppressConfig, suppress
from marknav.vision.palette import DEFAULT_PALETTE, Palette

__all__ = ["STAGES", "Blob", "Detector", "DetectorConfig", "Scene", "Stage", "detect_marks",
           "run_stages"]

U8Array = npt.NDArray[np.uint8]
#: A BGR frame is rows × columns × 3 channels.
_BGR_DIMS = 3


@dataclass(frozen=True)
class DetectorConfig:
    """Every stage's config (see each for its fields, their units and their reasons)."""

    photometry: PhotometryConfig = field(default_factory=PhotometryConfig)
    classify: ClassifyConfig = field(default_factory=ClassifyConfig)
    segment: SegmentConfig = field(default_factory=SegmentConfig)
    shape: ShapeConfig = field(default_factory=ShapeConfig)
    suppress: SuppressConfig = field(default_factory=SuppressConfig)
    #: ``shape.min_radius_px`` holds for frames this wide (px); wider frames scale it up in
    #: proportion (a 1280-px frame of the same scene has marks twice as large, and clutter
    #: twice as many pixels to look round in). ``None``: fixed pixels (a camera's config).
    reference_width: int | None = 640

    @classmethod
    def for_camera(cls, *, focal_px: float, mark_radius_mm: float, max_range_mm: float,
                   floor_px: float = MIN_RADIUS_FLOOR_PX) -> DetectorConfig:
        """The default config with the minimum radius of a mark at ``max_range_mm`` (pinhole
        model, r = f·R/d, less 10 % for blur and yaw), not below ``floor_px``."""
        if not (focal_px > 0 and mark_radius_mm > 0 and max_range_mm > 0):
            raise ValueError("focal_px, mark_radius_mm and max_range_mm must be positive")
        r_min = max(floor_px, 0.9 * focal_px * mark_radius_mm / max_range_mm)
        return replace(cls().with_(shape={"min_radius_px": r_min}), reference_width=None)

    def for_width(self, width: int) -> DetectorConfig:
        """This config for frames ``width`` px wide (see ``reference_width``)."""
        ref = self.reference_width
        if ref is None or width <= ref:
            return self
        scaled = self.with_(shape={"min_radius_px": self.shape.min_radius_px * width / ref})
        return replace(scaled, reference_width=None)

    def with_(self, **changes: dict[str, Any]) -> DetectorConfig:
        """This config with some stages' fields changed: ``with_(shape={"min_fill": 0.7})``."""
        return replace(self, **{k: replace(getattr(self, k), **v) for k, v in changes.items()})


Stage = Callable[[Scene, DetectorConfig], Scene]

#: The stages in order, by name.
STAGES: tuple[tuple[str, Stage], ...] = (
    ("photometry", lambda s, c: photometry(s, c.photometry)),
    ("classify", lambda s, c: classify(s, c.classify)),
    ("segment", lambda s, c: segment(s, c.segment, lambda b: screen(b, c.shape))),
    ("shape", lambda s, c: measure(s, c.shape)),
    ("suppress", lambda s, c: suppress(s, c.suppress)),
)


def run_stages(image: U8Array, palette: Palette, config: DetectorConfig,
               until: str | None = None,
               stages: Sequence[tuple[str, Stage]] = STAGES) -> Scene:
    """The scene after every stage up to ``until`` (inclusive; ``None``: all of them);
    ``stages``: the pipeline (the ablation replaces one)."""
    scene = Scene(image=image, palette=tuple(palette))
    for name, stage in stages:
        scene = stage(scene, config)
        if name == until:
            break
    return scene


class Detector:
    """The marks of ``palette`` in BGR frames: :meth:`detect` runs every stage."""

    def __init__(self, palette: Palette = DEFAULT_PALETTE,
                 config: DetectorConfig | None = None) -> None:
        if not palette:
            raise ValueError("palette is empty")
        self.palette: Palette = tuple(palette)
        self.config = config or DetectorConfig()

    def detect(self, image: U8Array) -> list[Mark]:
        """The marks in one BGR frame, largest (nearest) first."""
        if image.ndim != _BGR_DIMS or image.shape[2] != _BGR_DIMS or image.dtype != np.uint8 or \
                min(image.shape[:2]) < SEARCH_SCALE:
            raise ValueError(f"expected a BGR uint8 image, got shape {image.shape} "
                             f"dtype {image.dtype}")
        config = self.config.for_width(image.shape[1])
        return list(run_stages(image, self.palette, config).marks)


def detect_marks(image: U8Array, palette: Palette = DEFAULT_PALETTE) -> list[Mark]:
    """The marks in one BGR frame with the default config."""
    return Detector(palette).detect(image)


