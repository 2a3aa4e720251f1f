"""Session 4 notes: the bare detector's real-corpus figures with DetectorConfig overrides.

Usage (from the project root)::

    python docs/notes/2026-12-02/detector-figures.py '{"tint_limit": 0.05}'

The library calls of ``marknav bench vision`` (composited frames, labelled recall, false marks
per natural photograph at 640 px), one OpenCV thread, with every DetectorConfig built taking the
given fields as defaults.
"""

from __future__ import annotations

import json
import sys
from typing import Any

import cv2

from marknav.vision import bench_real
from marknav.vision.detect import model


def main() -> None:
    overrides: dict[str, Any] = json.loads(sys.argv[1])
    plain_init = model.DetectorConfig.__init__

    def init(self: model.DetectorConfig, *args: Any, **kwargs: Any) -> None:
        for key, value in overrides.items():
            kwargs.setdefault(key, value)
        plain_init(self, *args, **kwargs)

    model.DetectorConfig.__init__ = init  # type: ignore[method-assign]
    cv2.setNumThreads(1)
    photos = bench_real.load_photos("tests/data/real")
    composites, _ = bench_real.composite_figures(photos, per_condition=8)
    print(overrides, "composites", json.dumps(composites))
    labelled, palette, negative = bench_real.load_corpus("tests/data")
    print("recall", json.dumps(bench_real.real_recall(labelled, palette)))
    false = bench_real.real_false_marks(labelled, negative, 640)
    print("false 640", json.dumps({k: v for k, v in false.items() if not isinstance(v, list)}))


if __name__ == "__main__":
    main()
