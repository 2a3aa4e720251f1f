"""The Dask backend submits the evaluation lazily, as the local pool does: a few jobs per
worker are on the cluster and unfinished at any time, the next submitted as each result
arrives; a Ctrl-C stops it having pulled no more than that window past the results."""

from __future__ import annotations

import time
from collections.abc import Iterator, Sequence
from typing import Any, overload

import pytest

from marknav.runs.evaluation import backends

distributed = pytest.importorskip("distributed")

WORKERS = 2
#: What the backend may have submitted and not yet delivered.
WINDOW = backends.QUEUED_PER_WORKER * WORKERS


def seed_of(mission: str, seed: int, max_time_s: float | None, *rest: Any) -> int:
    """A job that returns at once: only the backend's bookkeeping is measured."""
    return seed


class CountedJobs(Sequence[tuple[str, int, tuple[str, ...]]]):
    """``n`` jobs made as they are asked for, counting how many were pulled."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.pulled = 0

    def __len__(self) -> int:
        return self.n

    @overload
    def __getitem__(self, i: int) -> tuple[str, int, tuple[str, ...]]: ...
    @overload
    def __getitem__(self, i: slice) -> list[tuple[str, int, tuple[str, ...]]]: ...
    def __getitem__(self, i: int | slice) -> Any:
        raise AssertionError("the backend takes the jobs in order, through iter()")

    def __iter__(self) -> Iterator[tuple[str, int, tuple[str, ...]]]:
        for seed in range(self.n):
            self.pulled += 1
            yield ("m.yaml", seed, ())


@pytest.fixture(scope="module")
def cluster() -> Iterator[Any]:
    """A real scheduler with two single-threaded workers in this process, on loopback TCP."""
    with distributed.LocalCluster(n_workers=WORKERS, threads_per_worker=1, processes=False,
                                  host="127.0.0.1", protocol="tcp",
                                  dashboard_address=":0") as c:
        yield c


def test_dask_keeps_a_window_of_jobs_on_the_cluster_and_delivers_every_result(
        cluster: Any) -> None:
    jobs = CountedJobs(40)
    seen: list[int] = []
    ahead: list[int] = []

    def on_result(seed: int) -> None:
        ahead.append(jobs.pulled - len(seen))  # submitted and not yet delivered, this one too
        seen.append(seed)

    used = backends._run_dask(seed_of, jobs, None, on_result, cluster.scheduler_address)
    assert sorted(seen) == list(range(40)) and used == WORKERS
    assert max(ahead) == WINDOW  # never more, and the workers were kept fed


def test_an_interrupt_cancels_the_window_and_pulls_no_more(cluster: Any) -> None:
    jobs = CountedJobs(10_000)
    seen: list[int] = []

    def on_result(seed: int) -> None:
        seen.append(seed)
        if len(seen) == 5:
            raise KeyboardInterrupt  # a Ctrl-C after 5 of 10,000 runs

    with pytest.raises(KeyboardInterrupt):
        backends._run_dask(seed_of, jobs, None, on_result, cluster.scheduler_address)
    assert jobs.pulled <= 5 + WINDOW

    def ours(dask_scheduler: Any) -> list[str]:
        return [str(k) for k in dask_scheduler.tasks if str(k).startswith("marknav-")]

    with distributed.Client(cluster.scheduler_address, set_as_default=False) as client:
        deadline = time.monotonic() + 10
        while client.run_on_scheduler(ours) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert client.run_on_scheduler(ours) == []
