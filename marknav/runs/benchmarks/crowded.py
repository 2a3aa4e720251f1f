"""Crowded frames: the detector's worst case, for ``marknav bench vision``.

A room can hold a poster of coloured squares, a rug, a shelf of coloured boxes: hundreds of
saturated blobs of palette hues in one frame. Every blob is looked at as a possible mark, so
such a frame costs what no corpus photograph does: every mark-shaped blob is measured, up to
:attr:`~marknav.vision.detect.shape.ShapeConfig.max_blobs` a frame.

:func:`crowded_frames` draws such frames (fixed seeds): mosaics of random colours and
"confetti" (random anti-aliased discs, many of them true marks of palette colours) at 640 and
1280 px. :func:`crowded_figures` times the bare detector and the robot's camera detector on each,
with the blobs each frame had measured and the ones it left unmeasured.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable

import cv2
import numpy as np

from marknav.missions.mission_detector import ROBOT_TINT_LIMIT, CameraDetector
from marknav.runs.benchmarks.photos import CAMERA, CAMERA_HEIGHT, CAMERA_WIDTH
from marknav.runs.benchmarks.vision import to_hsv
from marknav.sim.synthetic.scene import Image
from marknav.vision.detect import Detector
from marknav.vision.detect.pipeline import run_stages
from marknav.vision.palette import DEFAULT_PALETTE

__all__ = ["crowded_figures", "crowded_frames", "run_crowded_bench"]


def _mosaic(width: int, height: int, side: int, seed: int) -> Image:
    rng = np.random.default_rng(seed)
    cells = rng.integers(0, 256, (height // side, width // side, 3), dtype=np.uint8)
    return np.asarray(cv2.resize(cells, (width, height), interpolation=cv2.INTER_NEAREST),
                      np.uint8)


def _confetti(width: int, height: int, n: int, radii: tuple[int, int], seed: int) -> Image:
    rng = np.random.default_rng(seed)
    out: Image = np.full((height, width, 3), 128, np.uint8)
    for _ in range(n):
        colour = tuple(int(v) for v in rng.integers(0, 256, 3))
        centre = (int(rng.integers(0, width)), int(rng.integers(0, height)))
        cv2.circle(out, centre, int(rng.integers(*radii)), colour, -1, cv2.LINE_AA)
    return out


def crowded_frames() -> dict[str, Image]:
    """The crowded frames by name (deterministic)."""
    return {
        "mosaic_8px_640": _mosaic(640, 480, 8, 0),
        "mosaic_16px_640": _mosaic(640, 480, 16, 1),
        "mosaic_12px_1280": _mosaic(1280, 960, 12, 2),
        "confetti_640": _confetti(640, 480, 300, (4, 20), 3),
        "confetti_1280": _confetti(1280, 960, 1200, (8, 40), 4),
    }


def crowded_figures(detectors: dict[str, Callable[[int, int], Detector]],
                    repeats: int = 3) -> dict[str, dict[str, object]]:
    """Per crowded frame and detector (``detectors``: name → the detector for a frame's width
    and height): the least of ``repeats`` times (ms), the BGR→HSV conversion's, the marks
    found, the mark-shaped blobs measured and left unmeasured. Call with one OpenCV thread."""
    out: dict[str, dict[str, object]] = {}
    for name, image in crowded_frames().items():
        h, w = image.shape[:2]
        row: dict[str, object] = {"width": w, "height": h}
        hsv = min(_ms(to_hsv, image) for _ in range(repeats))
        row["hsv_ms"] = round(hsv, 3)
        for label, make in detectors.items():
            detector = make(w, h)
            best = min(_ms(detector.detect, image) for _ in range(repeats))
            screened = sum(1 for b in run_stages(image, detector.palette, detector.config,
                                                 until="segment").blobs
                           if b.ellipse is not None)
            limit = detector.config.shape.max_blobs
            row[label] = {"ms": round(best, 1), "over_hsv": round(best / max(hsv, 1e-6), 1),
                          "marks": len(detector.detect(image)),
                          "measured": min(screened, limit),
                          "unmeasured": max(0, screened - limit)}
        out[name] = row
    return out


def _ms(fn: Callable[[Image], object], image: Image) -> float:
    t0 = time.perf_counter()
    fn(image)
    return (time.perf_counter() - t0) * 1e3


def run_crowded_bench(repeats: int = 3) -> dict[str, dict[str, object]]:
    """:func:`crowded_figures` for the bare detector (``detector``: defaults, the default
    palette) and the robot's (``robot``: perception's camera detector, 3° horizon prior), one
    OpenCV thread."""
    robot = CameraDetector(DEFAULT_PALETTE, width=CAMERA_WIDTH, height=CAMERA_HEIGHT,
                           focal_px=CAMERA["focal_px"], mark_radius_mm=CAMERA["mark_radius_mm"],
                           max_range_mm=CAMERA["max_range_mm"], horizon_tolerance_deg=3.0,
                           tint_limit=ROBOT_TINT_LIMIT)
    previous = cv2.getNumThreads()
    cv2.setNumThreads(1)
    # The frames are crowded on purpose: their unmeasured blobs are figures here, not warnings.
    detect_log = logging.getLogger("marknav.vision.detect")
    level = detect_log.level
    detect_log.setLevel(logging.ERROR)
    try:
        return crowded_figures({"detector": lambda w, h: Detector(DEFAULT_PALETTE),
                                "robot": robot.detector_for}, repeats)
    finally:
        detect_log.setLevel(level)
        cv2.setNumThreads(previous)
