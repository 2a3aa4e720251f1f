"""An evaluation's runs keep OpenCV to one thread each and give the previous setting back
(issue 16: OpenCV's worker threads cost CPU and oversubscribe the cores when runs go in
parallel)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import py_trees
import pytest
import yaml

from marknav.runs.evaluation.backends import one_opencv_thread, run_jobs
from marknav.runs.evaluation.evaluate import run_seed
from marknav.runs.loop import run as runmod
from tests.tiny_mission import TINY


def test_an_evaluation_job_runs_on_one_opencv_thread_then_restores_it(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    mission = tmp_path / "tiny.yaml"
    mission.write_text(yaml.safe_dump(TINY), encoding="utf-8")
    seen: list[int] = []
    original = runmod.execute

    def watching(*args: Any, **kwargs: Any) -> Any:
        seen.append(cv2.getNumThreads())
        return original(*args, **kwargs)

    monkeypatch.setattr(runmod, "execute", watching)
    before = cv2.getNumThreads()
    cv2.setNumThreads(3)
    try:
        results, workers = run_jobs(run_seed, [(str(mission), 1), (str(mission), 2)],
                                    max_time_s=0.2)
        assert workers == 1 and [r.seed for r in results] == [1, 2]
        assert all(r.outcome == "failed" for r in results)  # the 0.2 s time limit
        assert seen == [1, 1]
        assert cv2.getNumThreads() == 3
    finally:
        cv2.setNumThreads(before)


def test_the_setting_comes_back_after_an_exception() -> None:
    before = cv2.getNumThreads()
    cv2.setNumThreads(2)
    try:
        with pytest.raises(RuntimeError), one_opencv_thread():
            assert cv2.getNumThreads() == 1
            raise RuntimeError("boom")
        assert cv2.getNumThreads() == 2
    finally:
        cv2.setNumThreads(before)


def test_a_simulated_run_ticks_on_one_opencv_thread_then_restores_it(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """``marknav run`` on the simulator (lock-step, small arrays) keeps OpenCV to one thread
    while the tree ticks, and gives the previous setting back when the run ends."""
    from marknav.testing import make_mission

    seen: list[int] = []
    original = py_trees.trees.BehaviourTree.tick

    def watching(self: Any) -> Any:
        seen.append(cv2.getNumThreads())
        return original(self)

    monkeypatch.setattr(py_trees.trees.BehaviourTree, "tick", watching)
    before = cv2.getNumThreads()
    cv2.setNumThreads(3)
    try:
        report = runmod.execute(runmod.RunRequest(mission=make_mission(**TINY), seed=1,
                                                  max_time_s=0.2)).report
        assert report.outcome == "failed" and report.ticks >= 3
        assert seen and set(seen) == {1}
        assert cv2.getNumThreads() == 3
    finally:
        cv2.setNumThreads(before)
