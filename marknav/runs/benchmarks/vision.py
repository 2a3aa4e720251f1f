"""The vision benchmark: the detector against plain ``HoughCircles`` and the HSV floor.

:func:`run_vision_bench` times, in one run and on one core (``cv2.setNumThreads(1)``), our
detector, plain full-frame ``cv2.HoughCircles`` (``HOUGH_GRADIENT`` on the grey image: the paper's
§3.3 baseline) and the BGR→HSV conversion alone (the floor), on the fixed 640×480 frames of
:func:`marknav.sim.synthetic.scene.bench_frames`.
"""

from __future__ import annotations

import os
import platform
import time
from collections.abc import Sequence

import cv2
import numpy as np

from marknav.runs.metrics.matching import match_marks
from marknav.sim.synthetic.scene import BENCH_SPEC, Image, bench_frames
from marknav.vision.detect import Detector
from marknav.vision.palette import DEFAULT_PALETTE

__all__ = ["plain_hough", "run_vision_bench", "to_hsv"]


def plain_hough(img: Image) -> object:
    """The baseline the detector is compared with: plain ``HoughCircles`` on the grey frame."""
    grey = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    return cv2.HoughCircles(grey, cv2.HOUGH_GRADIENT, dp=1, minDist=20, param1=100,
                            param2=30, minRadius=10, maxRadius=80)


def to_hsv(img: Image) -> object:
    """The cost unit the detector is measured in: one BGR→HSV conversion of the frame."""
    return cv2.cvtColor(img, cv2.COLOR_BGR2HSV)


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _time_ms(fn: object, frames: Sequence[Image], repeats: int) -> list[float]:
    assert callable(fn)
    times: list[float] = []
    for _ in range(repeats):
        for img in frames:
            t0 = time.perf_counter()
            fn(img)
            times.append((time.perf_counter() - t0) * 1000.0)
    return times


def run_vision_bench(*, frames: int = 60, repeats: int = 5, seed: int = 2024) -> dict[str, object]:
    """Time the detector against plain Hough and the HSV floor on the same frames, one core.

    Returns ``detector_ms_p50``, ``detector_ms_p99``, ``hough_ms_p50``, ``hough_ms_p99``,
    ``hsv_ms_p50``, ``frames``, ``recall``, ``false_positives`` and ``machine``.
    """
    previous_threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        scenes = bench_frames(frames, seed)
        images = [s.image for s in scenes]
        detector = Detector(DEFAULT_PALETTE)
        found_total = 0
        truth_total = 0
        false_total = 0
        for scene in scenes:
            pairs, _, false = match_marks(detector.detect(scene.image), scene.marks)
            found_total += len(pairs)
            truth_total += len(scene.marks)
            false_total += len(false)

        hough, hsv = plain_hough, to_hsv

        # Interleave the three so that machine load hits them alike.
        det_t: list[float] = []
        hough_t: list[float] = []
        hsv_t: list[float] = []
        for _ in range(repeats):
            det_t += _time_ms(detector.detect, images, 1)
            hough_t += _time_ms(hough, images, 1)
            hsv_t += _time_ms(hsv, images, 1)
        threads = cv2.getNumThreads()
    finally:
        cv2.setNumThreads(previous_threads)

    def pct(values: list[float], q: float) -> float:
        return round(float(np.percentile(values, q)), 3)

    return {
        "frames": len(images),
        "repeats": repeats,
        "width": BENCH_SPEC.width,
        "height": BENCH_SPEC.height,
        "detector_ms_p50": pct(det_t, 50),
        "detector_ms_p99": pct(det_t, 99),
        "hough_ms_p50": pct(hough_t, 50),
        "hough_ms_p99": pct(hough_t, 99),
        "hsv_ms_p50": pct(hsv_t, 50),
        "recall": round(found_total / truth_total, 4) if truth_total else 1.0,
        "false_positives": false_total,
        "machine": {
            "cpu": _cpu_model(),
            "cores": os.cpu_count(),
            "opencv_threads": threads,
            "python": platform.python_version(),
            "opencv": cv2.__version__,
            "numpy": np.__version__,
        },
    }
