"""``marknav bench vision``: the figures it reports and their shape (not a timed test: no
assertion here depends on how fast this machine is)."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from marknav.cli.main import main
from marknav.runs.benchmarks.vision import run_vision_bench
from marknav.runs.metrics.matching import match_marks
from marknav.sim.synthetic.scene import BENCH_SPEC, bench_frames
from marknav.vision.detect import Detector, Mark

KEYS = {"frames", "repeats", "width", "height", "detector_ms_p50", "detector_ms_p99",
        "hough_ms_p50", "hough_ms_p99", "hsv_ms_p50", "recall", "false_positives", "machine"}


def test_bench_frames_are_fixed_640x480_scenes_with_three_marks() -> None:
    a, b = bench_frames(3), bench_frames(3)
    assert all(s.image.shape == (480, 640, 3) for s in a)
    assert all(len(s.marks) == BENCH_SPEC.n_marks for s in a)
    assert all(np.array_equal(x.image, y.image) for x, y in zip(a, b, strict=True))


def test_run_vision_bench_reports_timings_recall_and_machine() -> None:
    threads = cv2.getNumThreads()
    result = run_vision_bench(frames=4, repeats=1)
    assert set(result) == KEYS
    assert result["frames"] == 4 and (result["width"], result["height"]) == (640, 480)
    timings = {key: result[key] for key in ("detector_ms_p50", "detector_ms_p99",
                                             "hough_ms_p50", "hsv_ms_p50")}
    assert all(isinstance(v, float) and v > 0 for v in timings.values()), timings
    assert float(str(timings["detector_ms_p50"])) <= float(str(timings["detector_ms_p99"]))
    assert result["recall"] == 1.0 and result["false_positives"] == 0
    machine = result["machine"]
    assert isinstance(machine, dict) and machine["opencv_threads"] == 1
    assert cv2.getNumThreads() == threads  # restored


def test_match_marks_pairs_by_colour_and_distance() -> None:
    scene = bench_frames(1)[0]
    truth = scene.marks[0]
    near = Mark(truth.colour, truth.x + 1.0, truth.y, truth.a, (truth.a, truth.b), 0.0,
                "circle", 1.0)
    wrong = Mark("violet", truth.x, truth.y, truth.a, (truth.a, truth.b), 0.0, "circle", 1.0)
    pairs, missed, false = match_marks([wrong, near], scene.marks)
    assert pairs == [(truth, near)] and false == [wrong] and len(missed) == len(scene.marks) - 1
    found = Detector().detect(scene.image)
    pairs, missed, false = match_marks(found, scene.marks)
    assert len(pairs) == len(scene.marks) and not missed and not false


@pytest.mark.slow
def test_bench_vision_command_prints_one_json_object(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "vision", "--json", "--quick"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out) == {"machine", "vision"}
    assert {"detector_ms_p50", "detector_ms_p99", "hough_ms_p50", "hsv_ms_p50", "frames",
            "recall"} <= set(out["vision"])
    assert out["vision"]["frames"] == 10 and out["vision"]["recall"] == 1.0
    assert {"cpu", "cores", "python", "opencv", "numpy"} <= set(out["machine"])


@pytest.mark.slow
def test_bench_vision_command_prints_a_readable_table(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "vision", "--quick"]) == 0
    text = capsys.readouterr().out
    assert text.splitlines()[0] == "machine:"
    assert "vision:" in text.splitlines()
    assert any(line.strip().startswith("detector_ms_p50: ") for line in text.splitlines())
