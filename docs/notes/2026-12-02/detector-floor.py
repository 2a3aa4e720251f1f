"""Issue 10, session 9: the speed targets against the least a detector must do.

The targets are CPU time per frame over the same frame's BGR→HSV conversion (one core, same
run): simulator frames p50 ≤ 1.5×, real 640×480 photographs p95 ≤ 5×. This script times, on
the frame sets of ``issue-10-16-detector-speed.py frames`` (``sets.pkl``), beside this
checkout's detector (bare defaults, and the robot's camera detector) the **least detectors**:
OpenCV pipelines that only find saturated blobs and fit an ellipse to each, with none of
marknav's work (no white balance, no colour labels, no validation, no partial marks, no
measurement, no suppression):

- ``least_half``: box-reduce to half size (``INTER_AREA``), BGR→HSV, one ``inRange`` on the
  palette's saturation and value floors, 3×3 opening, external contours, ``fitEllipse`` of each
  blob of the detector's minimum area — what marknav's search does before any per-blob reading;
- ``least_half_bare``: the same without the opening and the fits;
- ``least_full``: the same as ``least_half`` at full resolution (no reduction);
- ``least_quarter``: at quarter size (marks under ~8 px radius are lost there).

Ad-hoc measurement behind the closing note (not part of the package or CI). From the repository
root, after ``python docs/notes/2026-12-01/issue-10-16-detector-speed.py frames /tmp/speed``::

    python docs/notes/2026-12-02/detector-floor.py /tmp/speed [N]

Timing as in ``issue-10-16-detector-speed.py``: per frame the least of N repetitions (default 7)
of each function, the order rotated every repetition, ``time.process_time``, one OpenCV thread.
"""

from __future__ import annotations

import json
import math
import pickle
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2
import numpy as np

SETS = ("sim_default", "sim_randomised", "loop", "real640", "composite")


def least(divisor: int, opening: bool, fit: bool, sat_min: int, val_min: int,
          min_radius: float = 5.0) -> Callable[[np.ndarray], int]:
    kernel = np.ones((3, 3), np.uint8)
    min_area = 0.4 * math.pi * (min_radius / divisor) ** 2

    def run(image: np.ndarray) -> int:
        h, w = image.shape[:2]
        small = image if divisor == 1 else cv2.resize(
            image, (w // divisor, h // divisor), interpolation=cv2.INTER_AREA)
        hsv = cv2.cvtColor(small, cv2.COLOR_BGR2HSV)
        mask = cv2.inRange(hsv, (0, sat_min, val_min), (255, 255, 255))
        if opening:
            mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, kernel)
        contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
        found = 0
        if fit:
            for c in contours:
                if len(c) >= 6 and cv2.contourArea(c) >= min_area:
                    cv2.fitEllipse(c)
                    found += 1
        return found

    return run


def main(folder: Path, repeats: int) -> dict[str, Any]:
    cv2.setNumThreads(1)
    from marknav.vision import detector_setup
    from marknav.vision.detect import Detector

    with open(folder / "sets.pkl", "rb") as f:
        data = pickle.load(f)
    out: dict[str, Any] = {}
    for name in SETS:
        frames, palette, _ = data["sets"][name]
        sat = min(c.sat_min for c in palette)
        val = min(c.val_min for c in palette)
        h, w = frames[0].shape[:2]
        fns: dict[str, Callable[[np.ndarray], object]] = {
            "hsv": lambda im: cv2.cvtColor(im, cv2.COLOR_BGR2HSV),
            "detector": Detector(palette).detect,
            "robot": detector_setup.CameraDetector(
                palette, width=w, height=h, focal_px=590.0 * w / 640, mark_radius_mm=100.0,
                max_range_mm=6000.0, horizon_tolerance_deg=3.0).detect,
            "least_full": least(1, True, True, sat, val),
            "least_half": least(2, True, True, sat, val),
            "least_half_bare": least(2, False, False, sat, val),
            "least_quarter": least(4, True, True, sat, val),
        }
        keys = list(fns)
        best: dict[str, list[float]] = {k: [] for k in keys}
        for image in frames:
            for fn in fns.values():
                fn(image)  # warm: tables, compiled loops
            low = dict.fromkeys(keys, float("inf"))
            for r in range(repeats):
                k = r % len(keys)
                for key in keys[k:] + keys[:k]:
                    t0 = time.process_time()
                    fns[key](image)
                    low[key] = min(low[key], time.process_time() - t0)
            for key in keys:
                best[key].append(low[key])
        hsv = np.array(best["hsv"])
        row: dict[str, Any] = {"frames": len(frames), "size": f"{w}x{h}",
                               "hsv_ms_p50": round(float(np.median(hsv)) * 1e3, 3)}
        for key in keys[1:]:
            ratio = np.array(best[key]) / hsv
            row[key] = {"p50": round(float(np.median(ratio)), 2),
                        "p95": round(float(np.percentile(ratio, 95)), 2),
                        "ms_p50": round(float(np.median(best[key])) * 1e3, 3),
                        "ms_p95": round(float(np.percentile(best[key], 95)) * 1e3, 3)}
        out[name] = row
        print(name, json.dumps(row), flush=True)
    return out


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(Path(sys.argv[1]), int(sys.argv[2]) if len(sys.argv) > 2 else 7)
