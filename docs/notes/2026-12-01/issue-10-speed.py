"""Issue 10, session 2: the detector's CPU time per frame against the same frame's BGR→HSV.

Ad-hoc measurement behind the closing note's speed figures (not part of the package or CI):
frames of four kinds, each timed with ``time.process_time`` the minimum of REPEATS interleaved
repetitions (the detector, the detector perception builds — camera minimum radius and 3° horizon
prior —, and ``cv2.cvtColor(BGR2HSV)``), one OpenCV thread. Run from the repository root:

    python docs/notes/2026-12-01/issue-10-speed.py [REPEATS]
"""

from __future__ import annotations

import json
import sys
import time
from collections.abc import Callable
from typing import Any

import cv2
import numpy as np
from marknav.vision.bench_real import _resized, default_corpus, load_corpus
from marknav.vision.composite import COMPOSITE_PALETTE, composite_frames, load_photos
from marknav.vision.detector_setup import CameraDetector

from marknav.planning.kinematics import Pose
from marknav.sim.camera import CameraConfig, Renderer
from marknav.sim.world import generate_world
from marknav.vision.detect import Detector
from marknav.vision.palette import DEFAULT_PALETTE, Palette


def sim_frames(conditions: str) -> list[Any]:
    frames = []
    for seed in range(12):
        world = generate_world(["red", "green", "blue", "red"], seed=seed, clearance_mm=400,
                               conditions=conditions)  # type: ignore[arg-type]
        renderer = Renderer(world, DEFAULT_PALETTE, CameraConfig())
        rng = np.random.default_rng(seed)
        for k in range(5):
            pose = Pose(float(rng.uniform(-200, 200)), float(k * 500),
                        float(np.pi / 2 + rng.uniform(-0.3, 0.3)))
            frames.append(renderer.render(pose, rng))
    return frames


def main(repeats: int) -> dict[str, Any]:
    cv2.setNumThreads(1)
    corpus = default_corpus()
    assert corpus is not None, "run from a source checkout"
    photos, _, negative = load_corpus(corpus)
    sets: dict[str, tuple[list[Any], Palette]] = {
        "sim_default": (sim_frames("default"), DEFAULT_PALETTE),
        "sim_randomised": (sim_frames("randomised"), DEFAULT_PALETTE),
        "real640": ([_resized(p.image, 640)[0] for p in photos if p.natural], negative),
        "composite": ([f.image for f in composite_frames(load_photos(corpus / "real"),
                                                          per_condition=8, seed=10)],
                      COMPOSITE_PALETTE),
    }
    out: dict[str, Any] = {}
    for name, (frames, palette) in sets.items():
        camera = CameraDetector(palette, width=640, height=480, focal_px=590.0,
                                mark_radius_mm=100.0, max_range_mm=6000.0,
                                horizon_tolerance_deg=3.0)
        fns: dict[str, Callable[[Any], object]] = {
            "detector": Detector(palette).detect, "perception": camera.detect,
            "hsv": lambda im: cv2.cvtColor(im, cv2.COLOR_BGR2HSV)}
        best: dict[str, list[float]] = {k: [] for k in fns}
        for image in frames:
            low = dict.fromkeys(fns, float("inf"))
            for _ in range(repeats):
                for key, fn in fns.items():
                    t0 = time.process_time()
                    fn(image)
                    low[key] = min(low[key], time.process_time() - t0)
            for key in fns:
                best[key].append(low[key])
        hsv = np.array(best["hsv"])
        row: dict[str, Any] = {"frames": len(frames),
                               "hsv_ms_p50": round(float(np.median(hsv)) * 1e3, 3)}
        for key in ("detector", "perception"):
            ratio = np.array(best[key]) / hsv
            row[key] = {"ms_p50": round(float(np.median(best[key])) * 1e3, 3),
                        "x_hsv_p50": round(float(np.median(ratio)), 2),
                        "x_hsv_p95": round(float(np.percentile(ratio, 95)), 2)}
        out[name] = row
    return out


if __name__ == "__main__":
    print(json.dumps(main(int(sys.argv[1]) if len(sys.argv) > 1 else 5), indent=1))
