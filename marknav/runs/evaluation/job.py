"""One evaluation run — the job a backend executes: a mission spec and a seed in, a small
picklable :class:`SeedResult` out. The run uses the generated randomised world of its seed (or,
for the spec ``"random"``, a mission drawn from the seed too), and :func:`replay_command` is the
``marknav run`` command that repeats it exactly. A :class:`SeedResult` holds what the statistics
need: the tree's outcome and, per waypoint, what the ground truth shows
(:class:`WaypointTruth`), from which it decides whether the run was a success.
"""

from __future__ import annotations

import logging
import time
import traceback
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from marknav.core.errors import InputError
from marknav.runs.records.seed_result import (
    ERROR,
    RANDOM,
    SeedResult,
)

__all__ = ["run_seed"]

log = logging.getLogger(__name__)


@contextmanager
def _quiet_runs() -> Iterator[None]:
    """Per-run warnings (bumps, collisions) are what the evaluation counts: keep them out of the
    terminal unless the user asked for more log output (-v)."""
    package = logging.getLogger("marknav")
    if logging.getLogger().getEffectiveLevel() < logging.WARNING:
        yield
        return
    old = package.level
    package.setLevel(logging.ERROR)
    try:
        yield
    finally:
        package.setLevel(old)


def run_seed(mission_path: str, seed: int, max_time_s: float | None = None,
             overrides: Sequence[str] = (), engine: str | None = None,
             record_path: Path | None = None) -> SeedResult:
    """One evaluation run — the job (mission spec, seed[, --set overrides]): load the mission
    and run it on the generated randomised world of ``seed``; or, for the spec ``"random"``,
    draw the mission and its world from ``seed``
    (:func:`marknav.runs.evaluation.random_mission.random_mission`, here in the worker, so the job
    stays small). ``engine`` overrides the mission's simulator engine; ``record_path`` saves
    the run's MCAP recording there.

    A run that raises (a bug, not a mission failure) becomes outcome ``"error"`` with the
    exception as its reason; bad input (:class:`InputError`) and Ctrl-C propagate.
    """
    from marknav.missions.overrides import parse_overrides
    from marknav.missions.schema import load_mission
    from marknav.runs.loop.run import RunRequest, execute

    wall0 = time.perf_counter()
    try:
        if mission_path == RANDOM:
            from marknav.runs.evaluation.random_mission import random_mission

            drawn = random_mission(seed, "mujoco" if engine == "mujoco" else "builtin")
            mission = drawn.mission
            req = RunRequest(mission=mission, seed=seed, world_model=drawn.world,
                             max_time_s=max_time_s, engine=engine, record_path=record_path)
        else:
            mission = load_mission(mission_path, overrides=parse_overrides(overrides))  # --set
            req = RunRequest(mission=mission, seed=seed, generate_world=True, randomise=True,
                             max_time_s=max_time_s, engine=engine, record_path=record_path)
        with _quiet_runs():
            report = execute(req).report
    except InputError:
        if mission_path != RANDOM:
            raise
        log.error("random mission %d is invalid:\n%s", seed, traceback.format_exc())
        return SeedResult(seed=seed, outcome=ERROR, reason="invalid random mission: "
                          f"{traceback.format_exc(limit=1).strip().splitlines()[-1]}",
                          sim_time_s=0.0, wall_time_s=time.perf_counter() - wall0,
                          collisions=0, waypoints=(), mission=mission_path)
    except Exception as exc:  # one broken run must not end the evaluation
        log.error("seed %d crashed:\n%s", seed, traceback.format_exc())
        return SeedResult(seed=seed, outcome=ERROR, reason=f"crashed: {type(exc).__name__}: "
                          f"{exc}", sim_time_s=0.0, wall_time_s=time.perf_counter() - wall0,
                          collisions=0, waypoints=(), mission=mission_path)
    return SeedResult.from_report(seed, report, mission=mission_path,
                                  clearance_mm=mission.navigation.clearance_mm)


def lost_run(job: tuple[Any, ...], how: str) -> SeedResult:
    """A job whose worker process died, twice (the local pool runs it again alone first): an
    ``"error"`` outcome naming how the process ended."""
    return SeedResult(seed=int(job[1]), outcome=ERROR,
                      reason=f"crashed: its worker process died ({how}), twice",
                      sim_time_s=0.0, wall_time_s=0.0, collisions=0, waypoints=(),
                      mission=str(job[0]))
