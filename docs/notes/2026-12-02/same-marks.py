"""Session 6 notes: do two commits' detectors find the same marks?

Usage (from the project root, with the project's venv active)::

    python docs/notes/2026-12-02/same-marks.py febdb21 HEAD

Each commit's ``marknav`` and ``missions`` are exported (``git archive``) and run in a fresh
interpreter with that folder first on ``sys.path`` (as ``loop-by-commit.py`` does). Every
``Detector.detect`` call's marks are recorded over: the closed loop of ``marknav bench loop``
(816 frames, the robot's detector), the 60 synthetic frames of ``marknav bench vision``, the
composited frames, the labelled photographs and the natural photographs at 640 and 1280 px (the
corpus from this checkout's ``tests/data``). Prints, per call, whether the commits agree: the
same number of marks with the same colours and shapes, and the largest difference of any
coordinate, radius, axis, angle or score.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

RUN = """
import json, sys
sys.path.insert(0, sys.argv[1])
import cv2
import marknav
assert marknav.__file__.startswith(sys.argv[1]), marknav.__file__
from marknav.vision.detect.detector import Detector
from marknav.vision import bench_real
from marknav.vision.bench import bench_frames
from marknav.vision.palette import DEFAULT_PALETTE
from marknav.runs.bench import bench_loop

cv2.setNumThreads(1)
calls = []
plain = Detector.detect


def recorded(self, image):
    marks = plain(self, image)
    calls.append([[m.colour, m.shape, m.x, m.y, m.radius, *m.axes, m.angle_deg, m.score]
                  for m in marks])
    return marks


Detector.detect = recorded
bench_loop()
detector = Detector(DEFAULT_PALETTE)
for scene in bench_frames(60, 2024):
    detector.detect(scene.image)
data = sys.argv[2]
bench_real.composite_figures(bench_real.load_photos(data + "/real"), per_condition=8)
labelled, palette, negative = bench_real.load_corpus(data)
bench_real.real_recall(labelled, palette)
for side in (640, 1280):
    bench_real.real_false_marks(labelled, negative, side)
print(json.dumps(calls))
"""


def _calls(commit: str, tmp: Path, data: Path) -> list[list[list[object]]]:
    root = tmp / commit
    root.mkdir()
    archive = subprocess.run(["git", "archive", commit, "marknav", "missions"], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(root)], input=archive, check=True)
    out = subprocess.run([sys.executable, "-c", RUN, str(root), str(data)], check=True,
                         capture_output=True, text=True, cwd=tmp).stdout
    calls: list[list[list[object]]] = json.loads(out.strip().splitlines()[-1])
    return calls


def main() -> None:
    first, second = sys.argv[1], sys.argv[2]
    data = Path("tests/data").resolve()
    with tempfile.TemporaryDirectory() as tmp:
        a = _calls(first, Path(tmp), data)
        b = _calls(second, Path(tmp), data)
    if len(a) != len(b):
        print(f"the commits made {len(a)} and {len(b)} detector calls: compared up to the first "
              f"{min(len(a), len(b))}")
    differing = 0
    largest = 0.0
    for left, right in zip(a, b, strict=False):
        if len(left) != len(right) or any(x[:2] != y[:2] for x, y in zip(left, right,
                                                                          strict=True)):
            differing += 1
            continue
        for x, y in zip(left, right, strict=True):
            largest = max([largest] + [abs(float(p) - float(q))  # type: ignore[arg-type]
                                       for p, q in zip(x[2:], y[2:], strict=True)])
    print(f"{first}: {len(a)} calls, {sum(map(len, a))} marks; {second}: {len(b)} calls, "
          f"{sum(map(len, b))} marks")
    print(f"calls whose marks differ (number, colour or shape): {differing}; largest numeric "
          f"difference elsewhere: {largest:.3g}")


if __name__ == "__main__":
    main()
