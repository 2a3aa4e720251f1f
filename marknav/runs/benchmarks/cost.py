"""What a frame costs: the detector beside three baselines, in one run, on the same frames.

:func:`run_cost_bench` times, frame by frame and on one OpenCV thread,

- ``detector``: marknav's detector (:class:`marknav.vision.detect.Detector`, the palette's
  colours);
- ``least``: the least OpenCV detector of the same palette (:func:`least_opencv_detector`):
  box-reduce to half size, BGR→HSV, one ``inRange`` per colour (two for a colour whose hue range
  wraps), a 3×3 opening, external contours, ``fitEllipse`` of each blob as large as the
  smallest mark — what any colour-blob detector must do, with no validation, no partial marks,
  no measurement and no white balance;
- ``hough``: plain ``HoughCircles`` on the grey frame (the paper's §3.3 baseline);
- ``hsv``: one BGR→HSV conversion of the full frame (a unit of cost);

on three frame sets: the synthetic frames of :func:`marknav.sim.synthetic.scene.bench_frames`,
the real photographs of the source tree's ``tests/data/real`` with their long side at 640 px,
and frames of the simulator's randomised worlds. Per frame each function's time is the least of
``repeats`` runs (the order rotated every run, so load falls on all alike); reported are p50
and p95 over the frames in ms, and the frame-by-frame ratios of the detector to each baseline.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from marknav.runs.benchmarks.vision import plain_hough, to_hsv
from marknav.sim.synthetic.scene import Image, bench_frames
from marknav.vision.detect import Detector
from marknav.vision.detect.least import least_opencv_detector
from marknav.vision.palette import DEFAULT_PALETTE, Palette

__all__ = ["least_opencv_detector", "photo_frames", "run_cost_bench", "sim_frames",
           "time_functions"]


def photo_frames(folder: str | Path, long_side: int = 640) -> list[Image]:
    """The photographs of ``folder`` (``*.jpg``/``*.png``, by name) with their long side at
    ``long_side`` px."""
    from marknav.sim.synthetic.composite import load_photos

    out = []
    for _name, image in load_photos(folder):
        h, w = image.shape[:2]
        s = long_side / max(h, w)
        interp = cv2.INTER_AREA if s < 1 else cv2.INTER_CUBIC
        out.append(np.asarray(cv2.resize(image, (round(w * s), round(h * s)),
                                         interpolation=interp), np.uint8))
    return out


def sim_frames(n: int = 24, *, seed: int = 0) -> list[Image]:
    """``n`` simulator frames (640×480): four views along the course of each of ``n / 4``
    randomised slalom worlds (conditions, yaws, clutter), from the start pose forward."""
    from marknav.planning.kinematics import Pose
    from marknav.sim.builtin_camera import CameraConfig, render
    from marknav.sim.world.generate import generate_world

    rng = np.random.default_rng([seed, 0xF4A3E])
    frames: list[Image] = []
    world_seed = seed
    while len(frames) < n:
        world = generate_world(["red", "green", "blue", "red"], seed=world_seed,
                               clearance_mm=300.0, conditions="randomised")
        world_seed += 1
        for k in range(min(4, n - len(frames))):
            pose = Pose(float(rng.uniform(-150, 150)), 600.0 * k,
                        math.pi / 2 + float(rng.uniform(-0.3, 0.3)))
            frames.append(np.asarray(render(world, pose, CameraConfig(), DEFAULT_PALETTE,
                                            rng), np.uint8))
    return frames


def time_functions(functions: dict[str, Callable[[Image], object]], frames: Sequence[Image],
                   repeats: int) -> dict[str, list[float]]:
    """Per frame, the least of ``repeats`` timed runs (ms) of each function, the order of the
    functions rotated every run; each function is run once on the frame before (tables,
    caches)."""
    names = list(functions)
    out: dict[str, list[float]] = {k: [] for k in names}
    for image in frames:
        for fn in functions.values():
            fn(image)
        best = dict.fromkeys(names, math.inf)
        for r in range(repeats):
            k = r % len(names)
            for name in names[k:] + names[:k]:
                t0 = time.perf_counter()
                functions[name](image)
                best[name] = min(best[name], (time.perf_counter() - t0) * 1e3)
        for name in names:
            out[name].append(best[name])
    return out


def _summary(times: dict[str, list[float]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for name, values in times.items():
        out[f"{name}_ms"] = {"p50": round(float(np.percentile(values, 50)), 3),
                             "p95": round(float(np.percentile(values, 95)), 3)}
    det = np.asarray(times["detector"])
    for base in ("least", "hough", "hsv"):
        ratio = det / np.maximum(np.asarray(times[base]), 1e-6)
        out[f"detector_over_{base}"] = {"p50": round(float(np.percentile(ratio, 50)), 2),
                                        "p95": round(float(np.percentile(ratio, 95)), 2)}
    return out


def run_cost_bench(*, synthetic: int = 40, sim: int = 24, photos: str | Path | None = None,
                   repeats: int = 5, palette: Palette = DEFAULT_PALETTE) -> dict[str, Any]:
    """The cost table (see the module docstring): ``{set: {frames, size, detector_ms: {p50,
    p95}, least_ms, hough_ms, hsv_ms, detector_over_least: {p50, p95}, ...}}``. ``photos``: the
    folder of real photographs (default: the source tree's ``tests/data/real`` when present)."""
    if photos is None:
        here = Path(__file__).resolve().parents[3] / "tests" / "data" / "real"
        photos = here if here.is_dir() else None
    sets: dict[str, list[Image]] = {"synthetic": [s.image for s in bench_frames(synthetic)]}
    if photos is not None:
        sets["real_640"] = photo_frames(photos)
    if sim > 0:
        sets["simulator"] = sim_frames(sim)
    previous = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        functions: dict[str, Callable[[Image], object]] = {
            "detector": Detector(palette).detect,
            "least": least_opencv_detector(palette),
            "hough": plain_hough,
            "hsv": to_hsv,
        }
        out: dict[str, Any] = {"repeats": repeats, "opencv_threads": 1}
        for name, frames in sets.items():
            sizes = sorted({f"{f.shape[1]}x{f.shape[0]}" for f in frames})
            row: dict[str, Any] = {"frames": len(frames), "sizes": sizes}
            row.update(_summary(time_functions(functions, frames, repeats)))
            out[name] = row
    finally:
        cv2.setNumThreads(previous)
    return out
