"""Issues 10 and 16, session 3: this checkout's detector against a baseline's, on the same frames in
the same run — the same marks (colour, centre and radius within 0.1 px) and CPU time per frame over
the same frame's BGR→HSV conversion.

Ad-hoc measurement behind the closing note (not part of the package or CI). The baseline is another
commit's ``marknav`` package renamed ``marknav_main`` so that both import in one process::

    mkdir -p /tmp/base && git archive cb38fd1 marknav | tar -x -C /tmp/base
    mv /tmp/base/marknav /tmp/base/marknav_main
    grep -rl marknav /tmp/base/marknav_main --include=*.py | xargs sed -i -E \\
        's/\\bmarknav\\./marknav_main./g; s/^(from|import) marknav\\b/\\1 marknav_main/'

Then, from the repository root (``frames`` once; it runs the closed loop to record its frames)::

    python docs/notes/2026-12-01/issue-10-16-detector-speed.py frames /tmp/speed
    python docs/notes/2026-12-01/issue-10-16-detector-speed.py compare /tmp/speed /tmp/base [N]
    python docs/notes/2026-12-01/issue-10-16-detector-speed.py quality

``quality``: this checkout's labelled-photo recall, false marks at 640 px (defaults; camera minimum
radius with the horizon prior) and composited-frame figures (``bench_real``, the bench's sizes).

N: repetitions (default 6). Frame sets:

- ``loop``: every 4th frame the closed loop's detector sees (``bench_loop``: the slalom, with its
  camera's detector, 3° horizon prior);
- ``sim_default``, ``sim_randomised``: 12 worlds × 5 poses, as ``issue-10-speed.py``;
- ``real640``: the natural photographs at 640 px, detector defaults; ``real640_robot``: the same
  with perception's camera detector (``max_range_mm`` 6000, 3° prior);
- ``real_native``: every photograph at its own size; ``composite``: the bench's 48 frames.

Timing: per frame the least of N repetitions of each of (this detector, the baseline's,
BGR→HSV), the order rotated every repetition (the first call on a frame pays for its cache
misses), ``time.process_time``, one OpenCV thread.
"""

from __future__ import annotations

import dataclasses
import importlib
import importlib.util
import json
import pickle
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2
import numpy as np

HERE = Path(__file__).resolve().parent


def record_frames(out: Path) -> None:
    """The closed loop's frames and its detector's config, and the other frame sets."""
    from marknav.vision.bench_real import _resized, default_corpus, load_corpus
    from marknav.vision.composite import COMPOSITE_PALETTE, composite_frames, load_photos

    from marknav.runs.bench import bench_loop
    from marknav.vision import detector_setup
    from marknav.vision.palette import DEFAULT_PALETTE

    loop: list[Any] = []
    config: dict[str, Any] = {}
    original = detector_setup.CameraDetector.detect

    def recording(self: Any, image: Any) -> Any:
        if len(loop) % 4 == 0 or not config:
            h, w = image.shape[:2]
            config["palette"] = self.palette
            config["config"] = self.detector_for(w, h)._base_config
        loop.append(image.copy())
        return original(self, image)

    detector_setup.CameraDetector.detect = recording  # type: ignore[method-assign]
    try:
        bench_loop()
    finally:
        detector_setup.CameraDetector.detect = original  # type: ignore[method-assign]
    spec = importlib.util.spec_from_file_location("speed2", HERE / "issue-10-speed.py")
    assert spec is not None and spec.loader is not None
    speed2 = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(speed2)
    corpus = default_corpus()
    assert corpus is not None, "run from a source checkout"
    photos, _, negative = load_corpus(corpus)
    natural = [_resized(p.image, 640)[0] for p in photos if p.natural]
    sets = {
        "loop": (loop[::4], config["palette"], "loop"),
        "sim_default": (speed2.sim_frames("default"), DEFAULT_PALETTE, "default"),
        "sim_randomised": (speed2.sim_frames("randomised"), DEFAULT_PALETTE, "default"),
        "real640": (natural, negative, "default"),
        "real640_robot": (natural, negative, "robot"),
        "real_native": ([p.image for p in photos], negative, "default"),
        "composite": ([f.image for f in composite_frames(load_photos(corpus / "real"),
                                                         per_condition=8, seed=10)],
                      COMPOSITE_PALETTE, "default"),
    }
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "sets.pkl", "wb") as f:
        pickle.dump({"sets": sets, "loop_cfg": config["config"]}, f)
    print({k: len(v[0]) for k, v in sets.items()})


def compare(folder: Path, baseline: Path, repeats: int) -> dict[str, Any]:
    sys.path.insert(0, str(baseline))
    cv2.setNumThreads(1)
    import marknav.vision.detector_setup as new_setup

    import marknav.vision.detect as new

    # The baseline, imported from the path above.
    old = importlib.import_module("marknav_main.vision.detect")
    old_setup = importlib.import_module("marknav_main.vision.detector_setup")
    OldRange = importlib.import_module("marknav_main.vision.palette").ColourRange

    with open(folder / "sets.pkl", "rb") as f:
        data = pickle.load(f)

    def old_palette(palette: Any) -> tuple[Any, ...]:
        keys = ("name", "hue_lo", "hue_hi", "sat_min", "val_min")
        return tuple(OldRange(**{k: getattr(c, k) for k in keys}) for c in palette)

    def detectors(kind: str, palette: Any) -> tuple[Callable[[Any], Any], Callable[[Any], Any]]:
        if kind == "loop":
            cfg = data["loop_cfg"]
            known = {f.name for f in dataclasses.fields(old.DetectorConfig)}
            fields = {f.name: getattr(cfg, f.name) for f in dataclasses.fields(cfg)
                      if f.name in known}  # (settings added since the baseline: defaults)
            return (new.Detector(palette, cfg).detect,
                    old.Detector(old_palette(palette), old.DetectorConfig(**fields)).detect)
        if kind == "robot":
            kw: dict[str, Any] = dict(width=640, height=480, focal_px=590.0, mark_radius_mm=100.0,
                                      max_range_mm=6000.0, horizon_tolerance_deg=3.0)
            return (new_setup.CameraDetector(palette, **kw).detect,
                    old_setup.CameraDetector(old_palette(palette), **kw).detect)
        return new.Detector(palette).detect, old.Detector(old_palette(palette)).detect

    def match(a: list[Any], b: list[Any]) -> tuple[int, int, int, int]:
        """(same within 0.1 px, moved by more, only in a, only in b): same colour, the nearest
        within 3 px."""
        same = moved = 0
        used: set[int] = set()
        for m in a:
            best: tuple[float, int] | None = None
            for j, o in enumerate(b):
                if j in used or o.colour != m.colour:
                    continue
                d = max(abs(m.x - o.x), abs(m.y - o.y), abs(m.radius - o.radius))
                if best is None or d < best[0]:
                    best = (d, j)
            if best is not None and best[0] <= 3.0:
                used.add(best[1])
                same, moved = (same + 1, moved) if best[0] <= 0.1 else (same, moved + 1)
        return same, moved, len(a) - same - moved, len(b) - len(used)

    out: dict[str, Any] = {}
    for name, (frames, palette, kind) in data["sets"].items():
        fn_new, fn_old = detectors(kind, palette)
        counts = np.zeros(4, int)
        for image in frames:
            counts += match(fn_new(image), fn_old(image))
        fns: dict[str, Callable[[Any], object]] = {
            "new": fn_new, "old": fn_old, "hsv": lambda im: cv2.cvtColor(im, cv2.COLOR_BGR2HSV)}
        keys = list(fns)
        best: dict[str, list[float]] = {k: [] for k in fns}
        for image in frames:
            low = dict.fromkeys(fns, float("inf"))
            for r in range(repeats):
                for key in keys[r % 3:] + keys[:r % 3]:
                    t0 = time.process_time()
                    fns[key](image)
                    low[key] = min(low[key], time.process_time() - t0)
            for key in fns:
                best[key].append(low[key])
        hsv = np.array(best["hsv"])
        row: dict[str, Any] = dict(zip(("same", "moved", "only_new", "only_old"),
                                       counts.tolist(), strict=True))
        row["frames"] = len(frames)
        for key in ("new", "old"):
            ratio = np.array(best[key]) / hsv
            row[key] = {"ms_sum": round(float(np.sum(best[key])) * 1e3, 1),
                        "x_hsv_p50": round(float(np.median(ratio)), 2),
                        "x_hsv_p95": round(float(np.percentile(ratio, 95)), 2)}
        row["cpu_ratio_old_over_new"] = round(float(np.sum(best["old"]) / np.sum(best["new"])), 2)
        out[name] = row
        print(name, json.dumps(row), flush=True)
    return out


def quality() -> dict[str, Any]:
    from marknav.vision.bench_real import (
        composite_figures,
        default_corpus,
        load_corpus,
        real_false_marks,
        real_recall,
    )
    from marknav.vision.composite import load_photos

    cv2.setNumThreads(1)
    corpus = default_corpus()
    assert corpus is not None, "run from a source checkout"
    photos, palette, negative = load_corpus(corpus)
    out: dict[str, Any] = {
        "recall": real_recall(photos, palette),
        "false640": real_false_marks(photos, negative, 640),
        "false640_camera_horizon": real_false_marks(photos, negative, 640, horizon=True,
                                                    camera=True),
        "composite": composite_figures(load_photos(corpus / "real"), per_condition=8)[0],
    }
    print(json.dumps(out, default=str))
    return out


if __name__ == "__main__":
    if len(sys.argv) >= 3 and sys.argv[1] == "frames":
        record_frames(Path(sys.argv[2]))
    elif len(sys.argv) >= 4 and sys.argv[1] == "compare":
        compare(Path(sys.argv[2]), Path(sys.argv[3]), int(sys.argv[4]) if len(sys.argv) > 4 else 6)
    elif len(sys.argv) == 2 and sys.argv[1] == "quality":
        quality()
    else:
        sys.exit(__doc__)
