"""Throughput of an evaluation on a Dask cluster, one worker against two (issue 16).

:func:`bench_dask` starts a :class:`distributed.LocalCluster` of N single-threaded worker
processes on loopback (N = 1, then 2, ...), and for each:

1. ``start_s`` — the cluster's start: scheduler and worker processes up;
2. ``warmup_s`` — every worker imports what a run needs (marknav's run loop, the simulator,
   the detector, OpenCV, NumPy): the first run in a fresh worker would otherwise pay it;
3. ``evaluation_s`` — the evaluation itself, exactly what ``marknav evaluate MISSION --runs R
   --seed S --dask tcp://…`` does once the cluster is up (:func:`marknav.runs.evaluation.backends.
   run_jobs`: connect a client, submit the R runs, collect the results as they finish).

Steps 1 and 2 happen once per cluster, however long the evaluation: a user of a long
evaluation on a running cluster sees step 3, so the throughput (runs per minute) and the
speed-up (``speedup_2_vs_1`` = evaluation time with one worker / with two) are step 3's. The
per-seed results (every field but wall time) must be the same for every worker count
(``identical``). The CPU time of each worker process is reported too, and that of this process
(the scheduler runs in it, with the client): on a shared machine they tell contention (runs
slowing each other) and the cluster's own overhead from waiting for a core.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from marknav.core.errors import InputError

__all__ = ["bench_dask", "default_mission_path"]

log = logging.getLogger(__name__)


def default_mission_path() -> Path:
    """The built-in example ``slalom`` (the checkout's ``missions/slalom.yaml``)."""
    from marknav.missions.examples import EXAMPLES_DIR

    return EXAMPLES_DIR / "slalom.yaml"


def _warm_up() -> float:
    """In a worker: import what a run needs; the process's CPU seconds so far."""
    import os

    import cv2  # noqa: F401
    import numpy  # noqa: F401

    import marknav.runs.evaluation.evaluate
    import marknav.runs.loop.run
    import marknav.runs.loop.sim_environment
    import marknav.vision.detect  # noqa: F401

    return sum(os.times()[:2])


def _cpu_s() -> float:
    """In a worker: the process's CPU seconds so far (user + system)."""
    import os

    return sum(os.times()[:2])


def _outcome(result: Any) -> dict[str, Any]:
    d: dict[str, Any] = result.to_dict()
    d.pop("wall_time_s", None)
    return d


def _measure(mission: str, seeds: Sequence[int], max_time_s: float, workers: int
             ) -> tuple[dict[str, Any], dict[int, dict[str, Any]]]:
    from distributed import Client, LocalCluster

    from marknav.runs.evaluation.backends import run_jobs
    from marknav.runs.evaluation.job import run_seed

    t0 = time.perf_counter()
    with (LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                       host="127.0.0.1", dashboard_address=None) as cluster,
          Client(cluster, set_as_default=False) as client):
        client.wait_for_workers(workers)
        start_s = time.perf_counter() - t0
        t1 = time.perf_counter()
        cpu0: dict[str, float] = client.run(_warm_up)
        warmup_s = time.perf_counter() - t1
        t2, here0 = time.perf_counter(), time.process_time()
        results, _ = run_jobs(run_seed, [(mission, s) for s in seeds], max_time_s=max_time_s,
                              dask=cluster.scheduler_address)
        evaluation_s = time.perf_counter() - t2
        here_s = time.process_time() - here0
        cpu1: dict[str, float] = client.run(_cpu_s)
    cpu = sorted(cpu1[w] - cpu0[w] for w in cpu1)
    section = {
        "workers": workers,
        "start_s": round(start_s, 2),
        "warmup_s": round(warmup_s, 2),
        "evaluation_s": round(evaluation_s, 2),
        "runs_per_min": round(60.0 * len(seeds) / evaluation_s, 2),
        "worker_cpu_s": [round(c, 2) for c in cpu],
        "cpu_s_per_run": round(sum(cpu) / len(seeds), 2),
        # this process during the evaluation: the scheduler (in-process here) and the client
        "scheduler_client_cpu_s": round(here_s, 2),
    }
    return section, {r.seed: _outcome(r) for r in results}


def bench_dask(*, mission: str | Path | None = None, runs: int = 8, seed: int = 100,
               max_time_s: float = 90.0, workers: Sequence[int] = (1, 2)) -> dict[str, Any]:
    """Evaluate ``runs`` seeds from ``seed`` of ``mission`` (default the slalom) on local Dask
    clusters of each size in ``workers``; see the module docstring for what is timed."""
    try:
        import distributed  # noqa: F401
    except ImportError:
        raise InputError("needs dask.distributed: pip install 'marknav[cluster]'",
                         field="bench dask") from None
    if runs < 1 or not workers or min(workers) < 1:
        raise ValueError("runs and every worker count must be ≥ 1")
    path = str(Path(mission).resolve()) if mission is not None else str(default_mission_path())
    seeds = list(range(seed, seed + runs))
    sections: list[dict[str, Any]] = []
    outcomes: list[dict[int, dict[str, Any]]] = []
    chatty = logging.getLogger("distributed")  # clusters coming and going: not the news here
    level = chatty.level
    chatty.setLevel(max(level, logging.WARNING))
    try:
        for n in workers:
            section, outcome = _measure(path, seeds, max_time_s, n)
            log.info("%d worker(s): %s", n, section)
            sections.append(section)
            outcomes.append(outcome)
    finally:
        chatty.setLevel(level)
    out: dict[str, Any] = {
        "mission": Path(path).name,
        "runs": runs,
        "seeds": f"{seeds[0]}-{seeds[-1]}",
        "max_time_s": max_time_s,
        "clusters": sections,
        "identical": all(o == outcomes[0] for o in outcomes[1:]),
        "successes": sum(1 for o in outcomes[0].values() if o.get("outcome") == "success"),
    }
    by_n = {s["workers"]: s["evaluation_s"] for s in sections}
    if 1 in by_n and 2 in by_n:
        out["speedup_2_vs_1"] = round(by_n[1] / by_n[2], 2)
    return out
