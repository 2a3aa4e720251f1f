"""The vision benchmark on real photographs and on marks composited into them.

The corpus is a folder holding ``labels.json`` and the photographs it names (the project's
``tests/data``; see its README for sources and licences). :func:`run_real_bench` reports, in one
run on one core, for the labelled photographs and the composited frames
(:mod:`marknav.sim.synthetic.composite`):

- **recall**: labelled marks found with the right colour, centre within 0.2 r and radius within
  15 %; on composited frames also the range error (pinhole range from the found radius);
- **false marks per natural photograph** with a red/green/blue palette at 640 and 1280 px (the
  long side), with and without the horizon prior;
- **timings** of the detector, plain ``HoughCircles`` and BGR→HSV on the same frames (p50, p95)
  and the detector's ratio to BGR→HSV frame by frame.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from marknav.missions.mission_detector import (
    ROBOT_TINT_LIMIT,
    CameraDetector,
    camera_detector_config,
)
from marknav.runs.benchmarks.vision import plain_hough, to_hsv
from marknav.runs.metrics.matching import match_marks
from marknav.runs.metrics.photo_corpus import (
    Label,
    LabelledPhoto,
    default_corpus,
    hit,
    load_corpus,
    real_recall,
)
from marknav.sim.synthetic.composite import COMPOSITE_PALETTE, composite_frames, load_photos
from marknav.sim.synthetic.scene import Image
from marknav.vision.detect import Detector, DetectorConfig
from marknav.vision.palette import Palette

__all__ = [
    "CAMERA",
    "Label",
    "LabelledPhoto",
    "camera_config",
    "default_corpus",
    "load_corpus",
    "real_false_marks",
    "real_recall",
    "run_real_bench",
]


def _resized(image: Image, long_side: int) -> tuple[Image, float]:
    h, w = image.shape[:2]
    s = long_side / max(h, w)
    interp = cv2.INTER_AREA if s < 1 else cv2.INTER_CUBIC
    return np.asarray(cv2.resize(image, (round(w * s), round(h * s)), interpolation=interp),
                      np.uint8), s


#: marknav's default camera and marks (missions/slalom.yaml: 640 px wide, f = 590 px, marks of
#: 100 mm) with `camera.detect.max_range_mm: 6000` (marks smaller than 8.9 px are not searched for).
CAMERA = {"focal_px": 590.0, "mark_radius_mm": 100.0, "max_range_mm": 6000.0}
CAMERA_WIDTH, CAMERA_HEIGHT = 640, 480


def camera_config(width: int, horizon_row: float | None = None,
                  horizon_tolerance_px: float = 24.0) -> DetectorConfig:
    """The config perception builds for :data:`CAMERA` scaled to ``width`` px."""
    cfg = camera_detector_config(
        width=width, height=round(width * CAMERA_HEIGHT / CAMERA_WIDTH),
        focal_px=CAMERA["focal_px"] * width / CAMERA_WIDTH,
        mark_radius_mm=CAMERA["mark_radius_mm"], max_range_mm=CAMERA["max_range_mm"],
        horizon_tolerance_deg=None, tint_limit=ROBOT_TINT_LIMIT)
    return cfg.with_(suppress={"horizon_row": horizon_row,
                               "horizon_tolerance_px": horizon_tolerance_px})


def real_false_marks(photos: Sequence[LabelledPhoto], palette: Palette, long_side: int, *,
                     horizon: bool = False, camera: bool = False) -> dict[str, Any]:
    """Marks found in the natural photographs (resized to ``long_side``) that are neither a
    labelled mark nor an ignored object, per photograph. ``horizon``: with the horizon prior
    at the image's middle row (the photographs were not taken at mark height: this is the
    figure for a detector configured for marknav's level camera). ``camera``: the minimum
    radius of :data:`CAMERA` (:func:`camera_config`) instead of the fixed pixel default."""
    false = 0
    where: dict[str, int] = {}
    natural = [p for p in photos if p.natural]
    detectors: dict[tuple[int, int], Detector] = {}
    for photo in natural:
        image, s = _resized(photo.image, long_side)
        h, w = image.shape[:2]
        if (h, w) not in detectors:
            row, tol = ((h - 1) / 2.0, 0.05 * h) if horizon else (None, 24.0)
            config = camera_config(w, row, tol) if camera else DetectorConfig().with_(
                suppress={"horizon_row": row, "horizon_tolerance_px": tol})
            detectors[(h, w)] = Detector(palette, config)
        known = [Label(lab.colour, lab.x * s, lab.y * s, lab.radius * s)
                 for lab in photo.marks + photo.ignore]
        n = sum(1 for m in detectors[(h, w)].detect(image)
                if not any(hit(lab, m, colour=False) or
                           math.hypot(m.x - lab.x, m.y - lab.y) < lab.radius for lab in known))
        false += n
        if n:
            where[photo.name] = n
    return {"photos": len(natural), "false_marks": false,
            "per_photo": round(false / max(len(natural), 1), 3), "where": where}


def _timings(frames: Sequence[Image], detect: Callable[[Image], object],
             repeats: int, hough_frames: int | None = None) -> dict[str, float | None]:
    """Per-frame timings (ms) interleaved; plain Hough on the first ``hough_frames`` frames
    only (None: all), once: on textured photographs it takes seconds a frame."""
    hough, hsv = plain_hough, to_hsv
    det_t: list[float] = []
    hough_t: list[float] = []
    hsv_t: list[float] = []
    ratio: list[float] = []
    if not frames:
        return {}
    for _ in range(repeats):
        for img in frames:  # interleaved so that machine load hits all three alike
            t0 = time.perf_counter()
            detect(img)
            t1 = time.perf_counter()
            if (hough_frames is None or len(hough_t) < hough_frames) and \
                    len(hough_t) < len(frames):
                hough(img)
                hough_t.append((time.perf_counter() - t1) * 1e3)
            t2 = time.perf_counter()
            hsv(img)
            t3 = time.perf_counter()
            det_t.append((t1 - t0) * 1e3)
            hsv_t.append((t3 - t2) * 1e3)
            ratio.append((t1 - t0) / max(t3 - t2, 1e-9))

    def pct(values: list[float], q: float) -> float | None:
        return round(float(np.percentile(values, q)), 3) if values else None

    return {"hough_frames": len(hough_t),
            "detector_ms_p50": pct(det_t, 50), "detector_ms_p95": pct(det_t, 95),
            "hough_ms_p50": pct(hough_t, 50), "hough_ms_p95": pct(hough_t, 95),
            "hsv_ms_p50": pct(hsv_t, 50), "hsv_ms_p95": pct(hsv_t, 95),
            "detector_over_hsv_p50": pct(ratio, 50), "detector_over_hsv_p95": pct(ratio, 95)}


def composite_figures(photos: Sequence[tuple[str, Image]], *, per_condition: int,
                      seed: int = 10) -> tuple[dict[str, Any], list[Image]]:
    """Recall, false marks and range error on composited frames, per condition and overall."""
    frames = composite_frames(photos, per_condition=per_condition, seed=seed)
    detector = Detector(COMPOSITE_PALETTE)
    by: dict[str, list[int]] = {}
    range_err: list[float] = []
    for frame in frames:
        pairs, _, false = match_marks(detector.detect(frame.image), frame.marks)
        key = "+".join(frame.conditions)
        row = by.setdefault(key, [0, 0, 0])
        row[0] += len(pairs)
        row[1] += len(frame.marks)
        row[2] += len(false)
        range_err += [abs(t.a / m.radius - 1.0) for t, m in pairs]
    found = sum(r[0] for r in by.values())
    total = sum(r[1] for r in by.values())
    out: dict[str, Any] = {
        "frames": len(frames), "marks": total,
        "recall": round(found / total, 4) if total else 1.0,
        "false_marks": sum(r[2] for r in by.values()),
        "range_err_p95": round(float(np.percentile(range_err, 95)), 4) if range_err else None,
        "recall_by_condition": {k: round(r[0] / r[1], 3) if r[1] else 1.0
                                for k, r in by.items()},
    }
    return out, [f.image for f in frames]


def run_real_bench(corpus: str | Path, *, per_condition: int = 8, repeats: int = 3,
                   hough: bool = True, sizes: Sequence[int] = (640, 1280)) -> dict[str, Any]:
    """All figures above, one core (``cv2.setNumThreads(1)``), in one run; false marks at the
    long sides ``sizes``."""
    previous = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        photos, palette, negative = load_corpus(corpus)
        real: dict[str, Any] = {"recall": real_recall(photos, palette)}
        for side in sizes:
            real[f"false_{side}"] = real_false_marks(photos, negative, side)
            real[f"false_{side}_horizon"] = real_false_marks(photos, negative, side,
                                                              horizon=True)
            real[f"false_{side}_camera"] = real_false_marks(photos, negative, side,
                                                             camera=True)
        detector = Detector(negative)
        at_640 = [_resized(p.image, 640)[0] for p in photos if p.natural]
        real["timing_640"] = _timings(at_640, detector.detect, repeats,
                                      None if hough else 0)
        # What perception runs: the camera's minimum radius and the horizon prior (3°).
        robot = CameraDetector(negative, width=CAMERA_WIDTH, height=CAMERA_HEIGHT,
                               focal_px=CAMERA["focal_px"],
                               mark_radius_mm=CAMERA["mark_radius_mm"],
                               max_range_mm=CAMERA["max_range_mm"], horizon_tolerance_deg=3.0,
                               tint_limit=ROBOT_TINT_LIMIT)
        real["timing_640_camera_horizon"] = _timings(at_640, robot.detect, repeats, 0)
        backgrounds = load_photos(Path(corpus) / "real")
        composite, images = composite_figures(backgrounds, per_condition=per_condition)
        composite["timing"] = _timings(images, Detector(COMPOSITE_PALETTE).detect, 1,
                                       None if hough else 0)
    finally:
        cv2.setNumThreads(previous)
    return {"real": real, "composite": composite}
