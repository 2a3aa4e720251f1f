"""A worker process of the local pool that dies (a native library aborting it) no longer ends
the evaluation: the runs in flight are run again one at a time in fresh workers, and a run
whose worker dies again becomes a lost run naming how it ended."""

from __future__ import annotations

import multiprocessing
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Any

import pytest

from marknav.runs.evaluation import backends
from marknav.runs.evaluation.job import lost_run
from marknav.runs.records.seed_result import ERROR
from tests.runs.evaluation import dying_task


def test_a_dead_worker_costs_only_its_own_run(tmp_path: Path) -> None:
    jobs = [(str(tmp_path), s) for s in range(8)]
    lost: list[tuple[Any, str]] = []

    def on_lost(job: Any, how: str) -> tuple[str, int, str]:
        lost.append((job, how))
        return ("lost", job[1], how)

    results, workers = backends.run_jobs(dying_task.task, jobs, workers=2, on_lost=on_lost)
    assert workers == 2
    by_seed = {r[1] if r[0] == "lost" else r[0]: r for r in results}
    assert sorted(by_seed) == list(range(8)) and len(results) == 8  # each run once
    assert by_seed[5] == ("lost", 5, "SIGABRT")  # died alone too
    assert lost == [((str(tmp_path), 5), "SIGABRT")]
    assert by_seed[3][0] == 3  # died once, then ran
    assert not multiprocessing.active_children()


def test_without_a_lost_run_the_broken_pool_is_raised(tmp_path: Path) -> None:
    with pytest.raises(BrokenProcessPool):
        backends.run_jobs(dying_task.task, [(str(tmp_path), s) for s in range(6)], workers=2)
    assert not multiprocessing.active_children()


def test_a_lost_run_is_an_error_outcome_naming_how_its_process_ended() -> None:
    result = lost_run(("missions/slalom.yaml", 12), "SIGABRT")
    assert result.seed == 12 and result.outcome == ERROR and not result.success
    assert result.reason == "crashed: its worker process died (SIGABRT), twice"
