"""Evaluation: many simulated runs of one mission on generated, randomised worlds, and statistics.

Issue 7 (``marknav evaluate``). Run ``k`` uses seed ``S + k``: the world is generated from the
mission's route with that seed and randomised conditions (lighting, colour cast, noise, blur,
wheel mismatch and slip, mark yaw, camera latency — :func:`marknav.sim.world.random_conditions`),
exactly what ``marknav run MISSION --world random --seed S+k`` replays. Runs are independent and
deterministic for their seed, so they can run in parallel processes without changing any result.

The per-run job is :mod:`marknav.runs.evaluation.job`, the statistics and their summary
:mod:`marknav.runs.metrics.statistics`, where the runs execute
:mod:`marknav.runs.evaluation.backends`,
and the position accuracy experiment (``marknav evaluate --accuracy``)
:mod:`marknav.runs.evaluation.accuracy`; this module runs an evaluation and is where the rest of
marknav imports all of them from.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import overload

from marknav.core.errors import InputError
from marknav.runs.evaluation.accuracy import (
    ACCURACY_GRIDS,
    AccuracyResult,
    format_accuracy,
    plot_accuracy,
    position_accuracy,
)
from marknav.runs.evaluation.backends import Job, run_jobs
from marknav.runs.evaluation.job import lost_run, run_seed
from marknav.runs.metrics.statistics import (
    CLEARANCE_TOLERANCE_MM,
    Evaluation,
    format_evaluation,
    percentile,
    summarise,
    wilson_interval,
)
from marknav.runs.records.seed_result import RANDOM, SeedResult, WaypointTruth, replay_command

__all__ = [
    "ACCURACY_GRIDS",
    "CLEARANCE_TOLERANCE_MM",
    "AccuracyResult",
    "Evaluation",
    "SeedResult",
    "WaypointTruth",
    "evaluate",
    "format_accuracy",
    "format_evaluation",
    "percentile",
    "plot_accuracy",
    "position_accuracy",
    "record_failures",
    "replay_command",
    "run_seed",
    "summarise",
    "wilson_interval",
]


Progress = Callable[[int, int, int], None]

#: Most runs one evaluation takes: each keeps its result for the summary (a few kB: 10^5 runs are
#: a few hundred MB) and takes a second or more of a core (10^5 runs: over a day on one core).
MAX_RUNS = 100_000
#: Most worker processes (each holds one whole run, ≈ 250 MB: 64 of them fill 16 GB).
MAX_JOBS = 64
#: Seeds are 64-bit: the world generator's random source takes them whole.
MAX_SEED = 2**63 - 1


class _Jobs(Sequence[Job]):
    """The jobs of seeds ``first`` … ``first + n − 1``, made as they are asked for (an
    evaluation's backends queue them lazily; a list of 10^7 jobs was gigabytes)."""

    def __init__(self, spec: str, first: int, n: int, overrides: tuple[str, ...],
                 engine: str | None) -> None:
        self._spec, self._first, self._n = spec, first, n
        self._overrides, self._engine = overrides, engine

    def __len__(self) -> int:
        return self._n

    def _job(self, k: int) -> Job:
        # (mission, seed, overrides[, engine]): the engine only when --engine was given
        seed = self._first + k
        if self._engine is not None:
            return (self._spec, seed, self._overrides, self._engine)
        return (self._spec, seed, self._overrides)

    @overload
    def __getitem__(self, index: int) -> Job: ...

    @overload
    def __getitem__(self, index: slice) -> list[Job]: ...

    def __getitem__(self, index: int | slice) -> Job | list[Job]:
        picked = range(self._n)[index]
        if isinstance(picked, range):
            return [self._job(k) for k in picked]
        return self._job(picked)

    def __iter__(self) -> Iterator[Job]:
        return (self._job(k) for k in range(self._n))


class EvaluationStopped(KeyboardInterrupt):
    """The evaluation was interrupted; ``evaluation`` summarises the runs that had finished
    (``interrupted`` set). A ``KeyboardInterrupt``: a caller that does not look for it sees
    the interruption as before."""

    def __init__(self, evaluation: Evaluation, signame: str = "SIGINT") -> None:
        super().__init__(signame)
        self.evaluation = evaluation


def _check_numbers(runs: int, jobs: int, seed: int, max_time_s: float | None,
                   min_success: float) -> None:
    """:class:`InputError` naming the option of the first number out of its range."""
    if runs < 1:
        raise InputError(f"must be at least 1, got {runs}", field="--runs")
    if runs > MAX_RUNS:
        raise InputError(f"must be at most {MAX_RUNS:,} (each run keeps its result for the "
                         f"summary), got {runs:,}", field="--runs")
    if jobs < 1:
        raise InputError(f"must be at least 1, got {jobs}", field="--jobs")
    if jobs > MAX_JOBS:
        raise InputError(f"must be at most {MAX_JOBS} worker processes, got {jobs:,}",
                         field="--jobs")
    if seed < 0:
        raise InputError(f"must be ≥ 0, got {seed}", field="--seed")
    if seed > MAX_SEED - runs:
        raise InputError(f"must be at most {MAX_SEED - runs:,} (seeds are 64-bit), got "
                         f"{seed:,}", field="--seed")
    if max_time_s is not None and not max_time_s > 0:
        raise InputError(f"must be positive, got {max_time_s}", field="--max-time")
    if not 0.0 <= min_success <= 1.0:
        raise InputError(f"must be between 0 and 1, got {min_success}", field="--min-success")


def evaluate(
    mission_path: str | Path,
    *,
    runs: int,
    seed: int = 0,
    jobs: int = 1,
    max_time_s: float | None = None,
    min_success: float = 0.95,
    progress: Progress | None = None,
    overrides: Sequence[str] = (),
    dask: str | None = None,
    engine: str | None = None,
) -> Evaluation:
    """Run ``runs`` simulated missions (seeds ``seed`` … ``seed + runs − 1``) and summarise them.

    ``jobs`` > 1 runs them in that many worker processes (each loads the mission from its path);
    the results do not depend on it; ``engine`` overrides the mission's simulator engine;
    ``dask`` (``tcp://HOST:PORT``) runs them on that Dask
    cluster instead (:mod:`marknav.runs.evaluation.backends`). ``progress(done, total,
    successes)`` is called with ``done = 0`` when the runs start, then after each run. Bad
    input raises :class:`InputError` before anything runs.
    """
    from marknav.missions.schema import load_mission

    _check_numbers(runs, jobs, seed, max_time_s, min_success)
    path = str(mission_path)
    from marknav.missions.overrides import parse_overrides

    if path == RANDOM:
        if overrides:
            raise InputError("changes a mission file; random missions are drawn whole from "
                             "their seed", field="--set")
        name, clearance = "random missions", 0.0
        engine_used = engine or "builtin"
    else:
        # bad input (and a bad --set) fails here, before any worker starts
        mission = load_mission(path, overrides=parse_overrides(overrides))
        name, clearance = mission.name, mission.navigation.clearance_mm
        engine_used = engine or (mission.sim.engine if mission.sim is not None else "builtin")
    if engine_used == "mujoco":
        # no MuJoCo or no headless OpenGL: exit 2 here, not a crash in every worker
        from marknav.sim.mujoco.gl import import_mujoco

        import_mujoco()
    results: list[SeedResult] = []
    wall0 = time.perf_counter()

    def done(result: SeedResult) -> None:
        results.append(result)
        if progress is not None:
            progress(len(results), runs, sum(1 for s in results if s.success))

    # Where the runs execute (this process, a local pool, a Dask cluster): evaluate_backends.
    if progress is not None:
        progress(0, runs, 0)
    resolve = dask is not None and path != RANDOM  # a cluster's cwd differs
    spec = str(Path(path).resolve()) if resolve else path  # a cluster's cwd differs

    def summary(workers: int) -> Evaluation:
        ev = summarise(list(results), mission=name, mission_path=path,
                       clearance_mm=clearance, min_success=min_success,
                       max_time_s=max_time_s, jobs=workers,
                       wall_total_s=time.perf_counter() - wall0)
        ev.overrides = tuple(overrides)
        ev.planned_runs = runs
        ev.engine, ev.engine_given = engine_used, engine is not None
        return ev

    jobs_list = _Jobs(spec, seed, runs, tuple(overrides), engine)
    try:
        _, workers = run_jobs(run_seed, jobs_list,
                              max_time_s=max_time_s,
                              workers=jobs, dask=dask, on_result=done, on_lost=lost_run)
    except KeyboardInterrupt as exc:  # what finished is kept (the runs cut short are not)
        ev = summary(jobs)
        ev.interrupted = True
        raise EvaluationStopped(ev, str(exc) or "SIGINT") from exc
    return summary(workers)


def record_failures(ev: Evaluation, folder: Path,
                    on_recorded: Callable[[SeedResult, Path, SeedResult], None] | None = None
                    ) -> list[Path]:
    """Run each failing seed of ``ev`` again (a run depends on its seed alone) with its MCAP
    recording in ``folder/seed-N/run.mcap`` (a folder each: a rosbag2 folder holds one bag).
    ``on_recorded(failure, path, again)`` after each; returns the recordings written."""
    written = []
    for failure in ev.failures:
        path = folder / f"seed-{failure.seed}" / "run.mcap"
        path.parent.mkdir(parents=True, exist_ok=True)
        again = run_seed(ev.mission_path, failure.seed, ev.max_time_s, ev.overrides,
                         ev.engine if ev.engine_given else None, record_path=path)
        if path.exists():
            written.append(path)
        if on_recorded is not None:
            on_recorded(failure, path, again)
    return written
