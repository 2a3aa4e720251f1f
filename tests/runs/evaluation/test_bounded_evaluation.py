"""An evaluation's cost is bounded (issue 41, R8/R9): ``--runs``, ``--jobs`` and ``--seed`` are
refused out of range with exit 2; the local pool queues a few jobs per worker, not the whole
evaluation; a worker's memory stays flat from run to run."""

from __future__ import annotations

import os
import subprocess
import sys
from concurrent.futures import Future
from pathlib import Path
from typing import Any

import pytest

from marknav.cli.main import main
from marknav.runs.evaluation import backends
from marknav.runs.evaluation.evaluate import MAX_JOBS, MAX_RUNS, _Jobs

ROOT = Path(__file__).resolve().parents[3]
SLALOM = ROOT / "missions" / "slalom.yaml"


@pytest.mark.parametrize(("argv", "field"), [
    (["--runs", str(10**20)], "--runs: must be at most 100,000"),
    (["--runs", str(10**9)], "--runs: must be at most 100,000"),
    (["--runs", str(MAX_RUNS + 1)], "--runs: must be at most 100,000"),
    (["--runs", "2", "--jobs", str(MAX_JOBS + 1)], f"--jobs: must be at most {MAX_JOBS}"),
    (["--runs", "2", "--seed", str(2**64)], "--seed: must be at most"),
])
def test_out_of_range_numbers_are_exit_2(argv: list[str], field: str,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["evaluate", str(SLALOM), *argv]) == 2
    err = capsys.readouterr().err
    assert field in err and "Traceback" not in err


def test_the_jobs_are_made_as_they_are_asked_for() -> None:
    jobs = _Jobs("m.yaml", 5, 10**7, ("a=1",), None)
    assert len(jobs) == 10**7
    assert jobs[0] == ("m.yaml", 5, ("a=1",)) and jobs[-1] == ("m.yaml", 5 + 10**7 - 1, ("a=1",))
    assert jobs[1:3] == [("m.yaml", 6, ("a=1",)), ("m.yaml", 7, ("a=1",))]
    assert list(_Jobs("m.yaml", 0, 2, (), "mujoco")) == [("m.yaml", 0, (), "mujoco"),
                                                        ("m.yaml", 1, (), "mujoco")]


class _InlinePool:
    """A process pool that runs each job as it is submitted and counts what is queued."""

    queued = 0
    most_queued = 0
    submitted = 0

    def __init__(self, **kwargs: Any) -> None:
        pass

    def submit(self, fn: Any, task: Any, job: Any, max_time_s: Any) -> Future[Any]:
        cls = type(self)
        cls.submitted += 1
        if cls.submitted > 1000:
            raise AssertionError("the whole evaluation was queued up front")
        cls.queued += 1
        cls.most_queued = max(cls.most_queued, cls.queued)
        fut: Future[Any] = Future()
        fut.set_result(job[1])
        return fut

    def shutdown(self, **kwargs: Any) -> None:
        pass


def test_the_pool_queues_a_few_jobs_per_worker(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(backends, "ProcessPoolExecutor", _InlinePool)
    seen: list[int] = []

    def on_result(seed: int) -> None:
        _InlinePool.queued -= 1
        seen.append(seed)
        if len(seen) == 50:
            raise KeyboardInterrupt  # a Ctrl-C after 50 of 10^7 runs

    with pytest.raises(KeyboardInterrupt):
        backends._run_pool(lambda *a: None, _Jobs("m.yaml", 0, 10**7, (), None), None,
                           on_result, workers=2)
    assert len(set(seen)) == 50  # completion order
    assert _InlinePool.most_queued <= backends.QUEUED_PER_WORKER * 2
    assert _InlinePool.submitted <= 50 + backends.QUEUED_PER_WORKER * 2


#: 20 runs in one worker process, as ``_pool_task`` runs them; its resident memory after each.
_WORKER = """
import os, sys
from marknav.runs.evaluation.backends import _run
from marknav.runs.evaluation.job import run_seed
page = os.sysconf("SC_PAGE_SIZE")
for seed in range(int(sys.argv[2])):
    _run(run_seed, (sys.argv[1], seed, ()), 2.0)
    with open("/proc/self/statm") as fh:
        print(int(fh.read().split()[1]) * page, flush=True)
"""
RUNS_IN_ONE_WORKER = 20
#: Growth allowed over the 5th run's memory in any later one of the 20 (bytes): ≈ 10 MB seen;
#: with no collection after each run it was ≈ 75 MB, with the collection but the freed heap
#: kept by the C library ≈ 50 MB, and both kept growing over more runs.
GROWTH_ALLOWED_B = 24 * 2**20
#: Runs before the worker's memory is measured from (imports, first-use caches, numba).
WARM_UP_RUNS = 4


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/statm").exists(), reason="reads /proc/self/statm")
def test_a_workers_memory_stays_flat_over_twenty_runs(tmp_path: Path) -> None:
    out = subprocess.run([sys.executable, "-c", _WORKER, str(SLALOM), str(RUNS_IN_ONE_WORKER)],
                         cwd=tmp_path, capture_output=True, text=True, timeout=600,
                         env={**os.environ, "PY_TREES_DISABLE_COLORS": "1"})
    assert out.returncode == 0, out.stderr
    rss = [int(line) for line in out.stdout.split()]
    assert len(rss) == RUNS_IN_ONE_WORKER
    growth = max(rss[WARM_UP_RUNS:]) - rss[WARM_UP_RUNS]
    assert growth < GROWTH_ALLOWED_B, [r // 2**20 for r in rss]
