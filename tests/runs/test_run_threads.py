"""A simulated run keeps OpenCV to one thread and gives the previous setting back (issue 16:
the workers' threads cost CPU and oversubscribe the cores when runs go in parallel)."""

from __future__ import annotations

from typing import Any

import cv2
import pytest

from marknav.runs import run as runmod
from marknav.runs.run import RunRequest, execute, one_opencv_thread
from marknav.testing import make_mission


def test_a_simulated_run_uses_one_opencv_thread_then_restores_it(
        monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[int] = []
    original = runmod.run_tree

    def watching(*args: Any, **kwargs: Any) -> Any:
        seen.append(cv2.getNumThreads())
        return original(*args, **kwargs)

    monkeypatch.setattr(runmod, "run_tree", watching)
    before = cv2.getNumThreads()
    cv2.setNumThreads(3)
    try:
        mission = make_mission(name="tiny", route=["red"],
                               camera={"width": 320, "height": 240, "focal_px": 295,
                                       "range": {"model": "pinhole", "focal_px": 295}})
        report = execute(RunRequest(mission=mission, seed=1, max_time_s=0.2)).report
        assert report.ticks > 0
        assert seen == [1]
        assert cv2.getNumThreads() == 3
    finally:
        cv2.setNumThreads(before)


def test_the_setting_comes_back_after_an_exception_and_inactive_leaves_it() -> None:
    before = cv2.getNumThreads()
    cv2.setNumThreads(2)
    try:
        with pytest.raises(RuntimeError), one_opencv_thread():
            assert cv2.getNumThreads() == 1
            raise RuntimeError("boom")
        assert cv2.getNumThreads() == 2
        with one_opencv_thread(False):
            assert cv2.getNumThreads() == 2
    finally:
        cv2.setNumThreads(before)
