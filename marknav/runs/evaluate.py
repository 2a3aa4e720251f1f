"""Evaluation: many simulated runs of one mission on generated, randomised worlds, and statistics.

Issue 7 (``marknav evaluate``). Run ``k`` uses seed ``S + k``: the world is generated from the
mission's route with that seed and randomised conditions (lighting, colour cast, noise, blur,
wheel mismatch and slip, mark yaw, camera latency — :func:`marknav.sim.world.random_conditions`),
exactly what ``marknav run MISSION --world random --seed S+k`` replays. Runs are independent and
deterministic for their seed, so they can run in parallel processes without changing any result.

Statistics:

- success: the tree completed the route *and* the simulator's ground truth confirms every mark
  was passed on its colour's side (a run the tree believes complete but the truth denies is a
  failure, with the truth's reason);
- success rate with the Wilson score interval (Wilson 1927; Newcombe 1998, method 3):
  for k successes in n runs, p̂ = k/n and z the normal quantile,
  centre = (p̂ + z²/2n) / (1 + z²/n), half-width = z·√(p̂(1−p̂)/n + z²/4n²) / (1 + z²/n);
- collisions (bumper contacts, from the simulator's ground truth), marks passed on the wrong side
  (a waypoint whose ground-truth ``passed_on`` differs from its colour's side), marks the tree
  declared passed that the ground truth shows were never passed;
- clearance: the minimum and the 5th percentile (linear interpolation between order statistics,
  numpy's default) of every passed waypoint's ground-truth ``min_clearance_mm``;
- time per run: median and maximum simulated seconds, mean wall seconds.
"""

from __future__ import annotations

import logging
import math
import shlex
import time
import traceback
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from marknav.core.errors import InputError
from marknav.core.figures import save_figure
from marknav.runs.evaluate_backends import run_jobs
from marknav.runs.report import SUCCESS, RunReport, reached
from marknav.sim.accuracy import DEFAULT_XS_MM, DEFAULT_YS_MM

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
    "replay_command",
    "run_seed",
    "summarise",
    "wilson_interval",
]

log = logging.getLogger(__name__)

#: The normal quantile of a two-sided 95 % interval.
Z95 = 1.959963984540054
#: The clearance target: a pass may come this much closer than ``navigation.clearance_mm``.
CLEARANCE_TOLERANCE_MM = 50.0
#: Outcome of a run that raised instead of finishing (a bug, counted as a failure).
ERROR = "error"
#: The mission spec of an evaluation over generated missions (one drawn per seed).
RANDOM = "random"


# --------------------------------------------------------------------------------- statistics


def wilson_interval(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval for a binomial proportion (95 % by default); (0, 1) when n = 0."""
    if n < 0 or not 0 <= successes <= max(n, 0):
        raise ValueError(f"need 0 ≤ successes ≤ n, got {successes} of {n}")
    if n == 0:
        return 0.0, 1.0
    p = successes / n
    z2 = z * z
    denom = 1.0 + z2 / n
    centre = (p + z2 / (2.0 * n)) / denom
    half = z * math.sqrt(p * (1.0 - p) / n + z2 / (4.0 * n * n)) / denom
    # At the ends the bound is exactly 0 (k = 0) or 1 (k = n); floating point misses by 1e-16.
    lo = 0.0 if successes == 0 else max(0.0, centre - half)
    hi = 1.0 if successes == n else min(1.0, centre + half)
    return lo, hi


def percentile(values: Sequence[float], q: float) -> float | None:
    """The ``q``-th percentile (0..100, linear interpolation); None for no values."""
    if not 0.0 <= q <= 100.0:
        raise ValueError(f"q must be in 0..100, got {q}")
    if len(values) == 0:
        return None
    return float(np.percentile(np.asarray(values, dtype=float), q))


# ------------------------------------------------------------------------------- one run


@dataclass(frozen=True)
class WaypointTruth:
    """A waypoint of one run: what the tree said and what the ground truth shows.

    ``truth`` is the verdict of :mod:`marknav.sim.truth` from the true path alone ("passed",
    "wrong_side", "skipped", "out_of_order", "off_course"); ``None`` when unknown (no truth was
    recorded), which never counts as passed.
    """

    colour: str
    side: str
    outcome: str  # "passed" | "failed" | "pending"
    passed_on: str | None
    min_clearance_mm: float | None
    truth: str | None = None
    mark_index: int | None = None
    detail: str = ""

    @property
    def confirmed(self) -> bool:
        """The ground truth confirms the mark was passed, in order, on its side."""
        return self.truth == "passed"

    @property
    def wrong_side(self) -> bool:
        return self.truth == "wrong_side"

    @property
    def unverified(self) -> bool:
        """The tree declared it passed but the ground truth does not confirm it."""
        return self.outcome == "passed" and not self.confirmed

    def describe(self) -> str:
        """What the truth says of a waypoint it does not confirm."""
        what = "no ground truth" if self.truth is None else self.truth.replace("_", " ")
        mark = f", mark {self.mark_index}" if self.mark_index is not None else ""
        return f"({self.colour}{mark}) {what}" + (f": {self.detail}" if self.detail else "")


@dataclass(frozen=True)
class SeedResult:
    """One evaluation run, reduced to what the statistics need (small enough to pickle).

    ``mission`` is the job's mission spec (a path, or "random" for a generated mission), so a
    failure's replay command reproduces it.
    """

    seed: int
    outcome: str  # "success" | "failed" | "aborted" | "error"
    reason: str
    sim_time_s: float
    wall_time_s: float
    collisions: int
    waypoints: tuple[WaypointTruth, ...]
    ticks: int = 0
    overruns: int = 0
    mission: str = ""
    clearance_mm: float | None = None  # the mission's navigation.clearance_mm

    @classmethod
    def from_report(cls, seed: int, report: RunReport, mission: str = "",
                    clearance_mm: float | None = None) -> SeedResult:
        return cls(
            seed=seed, outcome=report.outcome, reason=report.reason,
            sim_time_s=report.sim_time_s, wall_time_s=report.wall_time_s,
            collisions=report.collisions,
            waypoints=tuple(WaypointTruth(
                w.colour, w.side, w.outcome, w.passed_on, w.min_clearance_mm, w.truth,
                w.mark["index"] if w.mark else None, w.truth_detail) for w in report.waypoints),
            ticks=report.ticks, overruns=report.overruns, mission=mission,
            clearance_mm=clearance_mm,
        )

    @property
    def success(self) -> bool:
        """The tree completed the route and the ground truth agrees: every course mark passed,
        in order, on its side (an unknown truth is not a pass). Collisions and thin clearances
        are counted apart."""
        return (self.outcome == SUCCESS and len(self.waypoints) > 0
                and all(w.confirmed for w in self.waypoints))

    @property
    def failure_reason(self) -> str:
        """Why the run is not a success: the tree's reason, or what the ground truth denies."""
        if self.outcome != SUCCESS:
            return self.reason
        denied = [f"waypoint {i} {w.describe()}"
                  for i, w in enumerate(self.waypoints, start=1) if not w.confirmed]
        return ("the tree completed the route, but the ground truth says: "
                + ("; ".join(denied) or "no waypoints"))

    def _count(self, verdict: str) -> int:
        return sum(1 for w in self.waypoints[:reached(self.waypoints)] if w.truth == verdict)

    @property
    def wrong_side(self) -> int:
        return self._count("wrong_side")

    @property
    def skipped(self) -> int:
        """Course marks the robot went beyond without passing them."""
        return self._count("skipped")

    @property
    def out_of_order(self) -> int:
        return self._count("out_of_order")

    @property
    def off_course(self) -> int:
        return self._count("off_course")

    @property
    def unverified(self) -> int:
        return sum(1 for w in self.waypoints if w.unverified)

    def clearances(self) -> list[float]:
        """Ground-truth clearance of every waypoint the tree passed."""
        return [w.min_clearance_mm for w in self.waypoints
                if w.outcome == "passed" and w.min_clearance_mm is not None]

    def to_dict(self) -> dict[str, Any]:
        clear = self.clearances()
        return {
            "seed": self.seed, "outcome": self.outcome, "reason": self.reason,
            "sim_time_s": round(self.sim_time_s, 3), "wall_time_s": round(self.wall_time_s, 3),
            "mission": self.mission,
            "collisions": self.collisions, "wrong_side": self.wrong_side,
            "skipped": self.skipped, "out_of_order": self.out_of_order,
            "off_course": self.off_course,
            "waypoints_passed": sum(1 for w in self.waypoints if w.outcome == "passed"),
            "min_clearance_mm": round(min(clear), 1) if clear else None,
            "waypoints": [{"colour": w.colour, "side": w.side, "outcome": w.outcome,
                           "passed_on": w.passed_on, "min_clearance_mm": w.min_clearance_mm,
                           "truth": w.truth, "mark": w.mark_index}
                          for w in self.waypoints],
        }


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
             overrides: Sequence[str] = ()) -> SeedResult:
    """One evaluation run — the job (mission spec, seed[, --set overrides]): load the mission
    and run it on the generated randomised world of ``seed``; or, for the spec ``"random"``,
    draw the mission and its world from ``seed``
    (:func:`marknav.runs.random_mission.random_mission`, here in the worker, so the job
    stays small).

    A run that raises (a bug, not a mission failure) becomes outcome ``"error"`` with the
    exception as its reason; bad input (:class:`InputError`) and Ctrl-C propagate.
    """
    from marknav.missions.overrides import parse_overrides
    from marknav.missions.schema import load_mission
    from marknav.runs.run import RunRequest, execute

    wall0 = time.perf_counter()
    try:
        if mission_path == RANDOM:
            from marknav.runs.random_mission import random_mission

            drawn = random_mission(seed)
            mission = drawn.mission
            req = RunRequest(mission=mission, seed=seed, world_model=drawn.world,
                             max_time_s=max_time_s)
        else:
            mission = load_mission(mission_path, overrides=parse_overrides(overrides))  # --set
            req = RunRequest(mission=mission, seed=seed, generate_world=True, randomise=True,
                             max_time_s=max_time_s)
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


# ------------------------------------------------------------------------------ many runs


def replay_command(mission_path: str, seed: int, max_time_s: float | None = None,
                   overrides: Sequence[str] = ()) -> str:
    """The ``marknav run`` command that replays evaluation run ``seed`` exactly."""
    if mission_path == RANDOM:
        from marknav.runs.random_mission import replay_command as random_replay

        return random_replay(seed, max_time_s)
    cmd = f"marknav run {shlex.quote(mission_path)} --world random --seed {seed}"
    cmd += "".join(f" --set {shlex.quote(o)}" for o in overrides)
    if max_time_s is not None:
        cmd += f" --max-time {max_time_s:g}"
    return cmd


@dataclass
class Evaluation:
    """The statistics of an evaluation (:func:`summarise`)."""

    mission: str
    mission_path: str
    results: list[SeedResult]
    clearance_mm: float
    min_success: float = 0.95
    max_time_s: float | None = None
    jobs: int = 1
    wall_total_s: float = 0.0
    seeds: tuple[int, int] = (0, 0)

    runs: int = 0
    successes: int = 0
    success_rate: float = 0.0
    success_ci95: tuple[float, float] = (0.0, 1.0)
    collisions: int = 0
    runs_with_collisions: int = 0
    wrong_side: int = 0
    skipped: int = 0
    out_of_order: int = 0
    off_course: int = 0
    unverified_passes: int = 0
    min_clearance_mm: float | None = None
    clearance_p05_mm: float | None = None
    clearance_below_target: int = 0
    sim_time_median_s: float = 0.0
    sim_time_max_s: float = 0.0
    wall_time_mean_s: float = 0.0
    failures: list[SeedResult] = field(default_factory=list)
    incidents: list[tuple[SeedResult, list[str]]] = field(default_factory=list)
    overrides: tuple[str, ...] = ()  # the --set KEY=VALUE settings every run used

    @property
    def clearance_target_mm(self) -> float:
        return self.clearance_mm - CLEARANCE_TOLERANCE_MM

    @property
    def passed(self) -> bool:
        """Whether the success rate reaches ``min_success``."""
        return self.success_rate >= self.min_success

    def replay(self, seed: int) -> str:
        return replay_command(self.mission_path, seed, self.max_time_s, self.overrides)

    def to_dict(self) -> dict[str, Any]:
        def r(v: float | None, nd: int = 1) -> float | None:
            return None if v is None else round(v, nd)

        return {
            "mission": self.mission,
            "runs": self.runs,
            "seeds": list(self.seeds),
            "overrides": list(self.overrides),
            "jobs": self.jobs,
            "successes": self.successes,
            "success_rate": round(self.success_rate, 4),
            "success_ci95": [round(self.success_ci95[0], 4), round(self.success_ci95[1], 4)],
            "min_success": self.min_success,
            "passed": self.passed,
            "collisions": self.collisions,
            "runs_with_collisions": self.runs_with_collisions,
            "wrong_side": self.wrong_side,
            "skipped": self.skipped,
            "out_of_order": self.out_of_order,
            "off_course": self.off_course,
            "unverified_passes": self.unverified_passes,
            "min_clearance_mm": r(self.min_clearance_mm),
            "clearance_p05_mm": r(self.clearance_p05_mm),
            "clearance_target_mm": self.clearance_target_mm,
            "clearance_below_target": self.clearance_below_target,
            "sim_time_s": {"median": round(self.sim_time_median_s, 2),
                           "max": round(self.sim_time_max_s, 2)},
            "wall_time_s": round(self.wall_time_mean_s, 3),
            "evaluation_wall_s": round(self.wall_total_s, 2),
            "failures": [{"seed": f.seed, "outcome": f.outcome, "reason": f.failure_reason,
                          "replay": self.replay(f.seed)} for f in self.failures],
            "incidents": [{"seed": s.seed, "problems": problems, "replay": self.replay(s.seed)}
                          for s, problems in self.incidents],
            "results": [s.to_dict() for s in self.results],
        }


def _target_of(result: SeedResult, clearance_mm: float) -> float:
    own = result.clearance_mm if result.clearance_mm is not None else clearance_mm
    return own - CLEARANCE_TOLERANCE_MM


def _incident(result: SeedResult, target_mm: float) -> list[str]:
    """What went wrong in a run besides (or despite) its outcome."""
    problems = []
    if result.collisions:
        problems.append(f"{result.collisions} collision{'s' if result.collisions != 1 else ''}")
    got_to = reached(result.waypoints)
    for i, w in enumerate(result.waypoints, start=1):
        if (i <= got_to and w.truth is not None and not w.confirmed) or w.unverified:
            problems.append(f"waypoint {i} {w.describe()}")
        if (w.outcome == "passed" and w.min_clearance_mm is not None
                and w.min_clearance_mm < target_mm):
            problems.append(f"waypoint {i} ({w.colour}) clearance {w.min_clearance_mm:.0f} mm "
                            f"< {target_mm:.0f} mm")
    return problems


def summarise(
    results: Sequence[SeedResult],
    *,
    mission: str,
    mission_path: str,
    clearance_mm: float,
    min_success: float = 0.95,
    max_time_s: float | None = None,
    jobs: int = 1,
    wall_total_s: float = 0.0,
) -> Evaluation:
    """Aggregate per-seed results (any order; sorted by seed) into an :class:`Evaluation`."""
    ordered = sorted(results, key=lambda s: s.seed)
    ev = Evaluation(mission=mission, mission_path=mission_path, results=ordered,
                    clearance_mm=clearance_mm, min_success=min_success, max_time_s=max_time_s,
                    jobs=jobs, wall_total_s=wall_total_s)
    n = len(ordered)
    ev.runs = n
    if n:
        ev.seeds = (ordered[0].seed, ordered[-1].seed)
    ev.successes = sum(1 for s in ordered if s.success)
    ev.success_rate = ev.successes / n if n else 0.0
    ev.success_ci95 = wilson_interval(ev.successes, n)
    ev.collisions = sum(s.collisions for s in ordered)
    ev.runs_with_collisions = sum(1 for s in ordered if s.collisions)
    ev.wrong_side = sum(s.wrong_side for s in ordered)
    ev.skipped = sum(s.skipped for s in ordered)
    ev.out_of_order = sum(s.out_of_order for s in ordered)
    ev.off_course = sum(s.off_course for s in ordered)
    ev.unverified_passes = sum(s.unverified for s in ordered)
    clearances = [c for s in ordered for c in s.clearances()]
    ev.min_clearance_mm = min(clearances) if clearances else None
    ev.clearance_p05_mm = percentile(clearances, 5.0)
    # Each run against its own mission's clearance (random missions draw one per run).
    ev.clearance_below_target = sum(
        1 for s in ordered for c in s.clearances() if c < _target_of(s, clearance_mm))
    sim_times = [s.sim_time_s for s in ordered]
    if sim_times:
        ev.sim_time_median_s = float(np.median(sim_times))
        ev.sim_time_max_s = max(sim_times)
        ev.wall_time_mean_s = float(np.mean([s.wall_time_s for s in ordered]))
    ev.failures = [s for s in ordered if not s.success]
    for s in ordered:
        problems = _incident(s, _target_of(s, clearance_mm))
        if problems:
            ev.incidents.append((s, problems))
    return ev


Progress = Callable[[int, int, int], None]


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
) -> Evaluation:
    """Run ``runs`` simulated missions (seeds ``seed`` … ``seed + runs − 1``) and summarise them.

    ``jobs`` > 1 runs them in that many worker processes (each loads the mission from its path);
    the results do not depend on it; ``dask`` (``tcp://HOST:PORT``) runs them on that Dask
    cluster instead (:mod:`marknav.runs.evaluate_backends`). ``progress(done, total,
    successes)`` is called with ``done = 0`` when the runs start, then after each run. Bad
    input raises :class:`InputError` before anything runs.
    """
    from marknav.missions.schema import load_mission

    if runs < 1:
        raise InputError(f"must be at least 1, got {runs}", field="--runs")
    if jobs < 1:
        raise InputError(f"must be at least 1, got {jobs}", field="--jobs")
    if seed < 0:
        raise InputError(f"must be ≥ 0, got {seed}", field="--seed")
    if max_time_s is not None and not max_time_s > 0:
        raise InputError(f"must be positive, got {max_time_s}", field="--max-time")
    if not 0.0 <= min_success <= 1.0:
        raise InputError(f"must be between 0 and 1, got {min_success}", field="--min-success")
    path = str(mission_path)
    from marknav.missions.overrides import parse_overrides

    if path == RANDOM:
        if overrides:
            raise InputError("changes a mission file; random missions are drawn whole from "
                             "their seed", field="--set")
        name, clearance = "random missions", 0.0
    else:
        # bad input (and a bad --set) fails here, before any worker starts
        mission = load_mission(path, overrides=parse_overrides(overrides))
        name, clearance = mission.name, mission.navigation.clearance_mm
    seeds = list(range(seed, seed + runs))
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
    _, workers = run_jobs(run_seed, [(spec, s, tuple(overrides)) for s in seeds],
                          max_time_s=max_time_s,
                          workers=jobs, dask=dask, on_result=done)
    ev = summarise(results, mission=name, mission_path=path,
                   clearance_mm=clearance, min_success=min_success,
                   max_time_s=max_time_s, jobs=workers,
                   wall_total_s=time.perf_counter() - wall0)
    ev.overrides = tuple(overrides)
    return ev


def format_evaluation(ev: Evaluation) -> str:
    """The evaluation's summary as text (what ``marknav evaluate`` prints)."""
    lo, hi = ev.success_ci95
    first, last = ev.seeds
    lines = [
        f"{ev.mission}: {ev.runs} simulated run{'s' if ev.runs != 1 else ''} on "
        + ("generated missions and " if ev.mission_path == RANDOM else "")
        + f"randomised worlds (seeds {first}–{last}, {ev.jobs} job{'s' if ev.jobs != 1 else ''})",
        f"  success      {ev.successes}/{ev.runs} = {ev.success_rate:.1%}  "
        f"(95 % CI {lo:.1%}–{hi:.1%}, Wilson)",
        f"  collisions   {ev.collisions} (in {ev.runs_with_collisions} run"
        f"{'s' if ev.runs_with_collisions != 1 else ''})",
        f"  wrong side   {ev.wrong_side} mark{'s' if ev.wrong_side != 1 else ''} passed on the "
        f"wrong side" + (f"; {ev.unverified_passes} declared passed but not confirmed"
                         if ev.unverified_passes else ""),
        f"  skipped      {ev.skipped} course mark{'s' if ev.skipped != 1 else ''} never passed; "
        f"{ev.out_of_order} out of order; {ev.off_course} off-course mark"
        f"{'s' if ev.off_course != 1 else ''} passed instead",
    ]
    if ev.min_clearance_mm is None:
        lines.append("  clearance    no waypoint passed")
    else:
        assert ev.clearance_p05_mm is not None
        lines.append(
            f"  clearance    min {ev.min_clearance_mm:.0f} mm, 5th percentile "
            f"{ev.clearance_p05_mm:.0f} mm (target ≥ "
            + ("each mission's " if ev.mission_path == RANDOM
               else f"{ev.clearance_target_mm:.0f} mm = ")
            + f"clearance_mm − {CLEARANCE_TOLERANCE_MM:.0f}; {ev.clearance_below_target} below)")
    speed = ""
    if ev.wall_time_mean_s > 0:
        mean_sim = float(np.mean([s.sim_time_s for s in ev.results]))
        speed = f", {mean_sim / ev.wall_time_mean_s:.1f}× real time"
    lines.append(
        f"  time/run     median {ev.sim_time_median_s:.1f} s, max {ev.sim_time_max_s:.1f} s "
        f"simulated; mean {ev.wall_time_mean_s:.1f} s wall{speed} "
        f"(evaluation {ev.wall_total_s:.0f} s)")
    if ev.failures:
        lines.append(f"failures ({len(ev.failures)}):")
        for f in ev.failures:
            what = f.failure_reason if f.outcome == SUCCESS else f"{f.outcome} — {f.reason}"
            lines.append(f"  seed {f.seed}: {what}")
            lines.append(f"    replay: {ev.replay(f.seed)}")
    incidents = [(s, p) for s, p in ev.incidents if s.success]
    if incidents:
        lines.append(f"successful runs with incidents ({len(incidents)}):")
        for s, problems in incidents:
            lines.append(f"  seed {s.seed}: {'; '.join(problems)}")
            lines.append(f"    replay: {ev.replay(s.seed)}")
    return "\n".join(lines)


# -------------------------------------------------------------------- position accuracy

#: Grids of the accuracy experiment (x across, y ahead; mm). "paper" is Fig. 13's span.
ACCURACY_GRIDS: dict[str, tuple[tuple[float, ...], tuple[float, ...]]] = {
    "paper": (DEFAULT_XS_MM, DEFAULT_YS_MM),
    "coarse": ((-300.0, 0.0, 300.0), (500.0, 1000.0, 2000.0, 3000.0)),
}


@dataclass(frozen=True)
class AccuracyResult:
    """The Fig. 13 table and what it was measured with."""

    table: Any  # marknav.sim.accuracy.AccuracyTable
    source: str  # the mission path, or "default camera"
    grid: str
    focal_px: float
    mark_radius_mm: float

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"source": self.source, "grid": self.grid,
                             "focal_px": self.focal_px, "mark_radius_mm": self.mark_radius_mm}
        d.update(self.table.to_dict())
        return d


def position_accuracy(mission_path: str | None = None, *, frames: int = 100,
                      grid: str = "paper", seed: int = 0) -> AccuracyResult:
    """The paper's Fig. 13 experiment in the simulator (:func:`marknav.sim.accuracy.
    accuracy_table`): with a mission, its camera, range model, mark radius, palette and first
    route colour; without, a pinhole camera f = 590 px and a 100 mm red mark."""
    from marknav.sim.accuracy import accuracy_table
    from marknav.sim.camera import CameraConfig

    if frames < 1:
        raise InputError(f"must be at least 1, got {frames}", field="--frames")
    if grid not in ACCURACY_GRIDS:
        raise InputError(f"unknown grid {grid!r} ({', '.join(ACCURACY_GRIDS)})", field="--grid")
    xs, ys = ACCURACY_GRIDS[grid]
    if mission_path is None:
        table = accuracy_table(xs_mm=xs, ys_mm=ys, frames=frames, seed=seed)
        return AccuracyResult(table, "default camera", grid, CameraConfig().focal_px, 100.0)

    from marknav.missions.camera import range_model_of
    from marknav.missions.schema import load_mission

    mission = load_mission(mission_path)
    cam = mission.camera
    table = accuracy_table(
        xs_mm=xs, ys_mm=ys, frames=frames, model=range_model_of(mission),
        camera=CameraConfig(width=cam.width, height=cam.height, focal_px=cam.focal_px),
        mark_radius_mm=mission.marks.radius_mm, colour=mission.route[0],
        palette=mission.palette(), seed=seed)
    return AccuracyResult(table, mission_path, grid, cam.focal_px, mission.marks.radius_mm)


def format_accuracy(result: AccuracyResult) -> str:
    """The accuracy table as text, one row per distance."""
    t = result.table
    lines = [
        f"Position error (paper eq. 40) against ground truth, {result.source}: {t.model}, "
        f"{t.frames_per_point} frames per point, grid {result.grid}",
        f"{'y mm':>6} {'points':>6} {'median mm':>10} {'p95 mm':>8} {'max mm':>8} "
        f"{'median %':>9} {'missed':>7}",
    ]
    for row in t.rows:
        if row.points == 0:
            lines.append(f"{row.y_mm:6.0f} {0:6d} {'—':>10} {'—':>8} {'—':>8} {'—':>9} "
                         f"{row.missed:7d}")
            continue
        lines.append(f"{row.y_mm:6.0f} {row.points:6d} {row.median_mm:10.1f} {row.p95_mm:8.1f} "
                     f"{row.max_mm:8.1f} {100.0 * row.median_rel:9.2f} {row.missed:7d}")
    lines.append(f"grid points not wholly in view (skipped): {t.skipped}; frames in which the "
                 f"detector missed the mark: {t.missed}")
    return "\n".join(lines)


def plot_accuracy(result: AccuracyResult, out: str | Path) -> None:
    """Error against distance: median, 95th percentile and maximum of eq. 40's error per
    distance (mm, left) and the median as a share of the distance (right), with the range error
    that half a pixel of radius error causes (δd ≈ d²·δr / (f·R)) for scale."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise InputError("--plot needs matplotlib: pip install 'marknav[plot]'",
                         field="--plot") from None
    rows = [r for r in result.table.rows if r.points > 0]
    if not rows:
        raise InputError("no grid point had the mark in view: nothing to plot", field="--plot")
    y = np.array([r.y_mm for r in rows])
    med = np.array([r.median_mm for r in rows])
    p95 = np.array([r.p95_mm for r in rows])
    mx = np.array([r.max_mm for r in rows])
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(11.0, 4.4), dpi=100)
    ax.fill_between(y, med, p95, alpha=0.25, label="median … 95th percentile")
    ax.plot(y, med, "o-", label="median")
    ax.plot(y, p95, "s--", label="95th percentile")
    ax.plot(y, mx, "^:", label="maximum")
    dense = np.linspace(float(y.min()), float(y.max()), 200)
    ax.plot(dense, dense**2 * 0.5 / (result.focal_px * result.mark_radius_mm), "-",
            color="grey", lw=1, label="δd for δr = 0.5 px")
    ax.set_xlabel("distance ahead y [mm]")
    ax.set_ylabel("position error e (eq. 40) [mm]")
    ax.grid(True, alpha=0.3)
    # below the axes: the curves rise to the upper right corner, where 'best' would put it
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=3,
              frameon=False)
    ax2.plot(y, 100.0 * med / y, "o-")
    ax2.set_xlabel("distance ahead y [mm]")
    ax2.set_ylabel("median error [% of distance]")
    ax2.set_ylim(bottom=0)
    ax2.grid(True, alpha=0.3)
    t = result.table
    fig.suptitle(f"Position accuracy ({result.source}; {t.model}; {t.frames_per_point} frames "
                 "per point)", fontsize=10)
    save_figure(fig, out)
