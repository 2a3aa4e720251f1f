"""The statistics of an evaluation: per-run results (:class:`~marknav.runs.evaluation.job.
SeedResult`, in any order) aggregated into one :class:`Evaluation` — success rate with its
confidence interval, collisions, verdicts the ground truth denies, clearances, times, and each
run's incidents — and that summary as the text ``marknav evaluate`` prints.

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
- **silent failures**: waypoints the robot reported ``passed`` — sure of it — that the ground
  truth denies (wrong side, skipped, another mark, out of order). A pass the robot reported
  ``doubtful`` (:func:`marknav.behaviours.bypass.verify_pass`) is not silent: it is counted
  apart, with how many of the doubts the truth bears out;
- clearance: the minimum and the 5th percentile (linear interpolation between order statistics,
  numpy's default) of every passed waypoint's ground-truth ``min_clearance_mm``;
- time per run: median and maximum simulated seconds, mean wall seconds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from marknav.runs.records.report import PASSED_OUTCOMES, SUCCESS, reached
from marknav.runs.records.seed_result import RANDOM, SeedResult, replay_command

__all__ = [
    "CLEARANCE_TOLERANCE_MM",
    "Evaluation",
    "format_evaluation",
    "percentile",
    "summarise",
    "wilson_interval",
]

#: The normal quantile of a two-sided 95 % interval.
Z95 = 1.959963984540054
#: The clearance target: a pass may come this much closer than ``navigation.clearance_mm``.
CLEARANCE_TOLERANCE_MM = 50.0


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
    silent_failures: int = 0
    runs_with_silent_failures: int = 0
    doubtful: int = 0
    doubts_borne_out: int = 0
    min_clearance_mm: float | None = None
    clearance_p05_mm: float | None = None
    clearance_below_target: int = 0
    sim_time_median_s: float = 0.0
    sim_time_max_s: float = 0.0
    wall_time_mean_s: float = 0.0
    failures: list[SeedResult] = field(default_factory=list)
    incidents: list[tuple[SeedResult, list[str]]] = field(default_factory=list)
    overrides: tuple[str, ...] = ()  # the --set KEY=VALUE settings every run used
    #: Ctrl-C (or SIGTERM) stopped the evaluation: the figures are those of the runs that
    #: finished, out of ``planned_runs``.
    interrupted: bool = False
    planned_runs: int = 0
    engine: str = "builtin"  # the simulator engine every run used
    engine_given: bool = False  # --engine was given (the replay commands repeat it)

    @property
    def clearance_target_mm(self) -> float:
        return self.clearance_mm - CLEARANCE_TOLERANCE_MM

    @property
    def passed(self) -> bool:
        """Whether the success rate reaches ``min_success``."""
        return self.success_rate >= self.min_success

    def replay(self, seed: int) -> str:
        return replay_command(self.mission_path, seed, self.max_time_s, self.overrides,
                              self.engine if self.engine_given else None)

    def to_dict(self) -> dict[str, Any]:
        def r(v: float | None, nd: int = 1) -> float | None:
            return None if v is None else round(v, nd)

        return {
            "mission": self.mission,
            "engine": self.engine,
            "runs": self.runs,
            "interrupted": self.interrupted,
            "planned_runs": self.planned_runs or self.runs,
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
            "silent_failures": self.silent_failures,
            "runs_with_silent_failures": self.runs_with_silent_failures,
            "doubtful": self.doubtful,
            "doubts_borne_out": self.doubts_borne_out,
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
        said = (" (reported passed: a silent failure)" if w.silent_failure
                else " (reported doubtful)" if w.doubtful else "")
        if (i <= got_to and w.truth is not None and not w.confirmed) or w.unverified:
            problems.append(f"waypoint {i} {w.describe()}{said}")
        elif w.doubtful:
            problems.append(f"waypoint {i} ({w.colour}) reported doubtful, passed in truth")
        if (w.outcome in PASSED_OUTCOMES and w.min_clearance_mm is not None
                and w.min_clearance_mm < target_mm):
            problems.append(f"waypoint {i} ({w.colour}) clearance {w.min_clearance_mm:.0f} mm "
                            f"< {target_mm:.0f} mm")
    return problems


def _count_outcomes(ev: Evaluation, ordered: Sequence[SeedResult]) -> None:
    """Runs, successes with their interval, and the totals of every kind of incident."""
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
    ev.silent_failures = sum(s.silent_failures for s in ordered)
    ev.runs_with_silent_failures = sum(1 for s in ordered if s.silent_failures)
    ev.doubtful = sum(s.doubtful for s in ordered)
    ev.doubts_borne_out = sum(s.doubts_borne_out for s in ordered)


def _measure_clearances(ev: Evaluation, ordered: Sequence[SeedResult],
                        clearance_mm: float) -> None:
    """The smallest and 5th-percentile clearance of passed marks, and how many fell below
    each run's own target (random missions draw one clearance per run)."""
    clearances = [c for s in ordered for c in s.clearances()]
    ev.min_clearance_mm = min(clearances) if clearances else None
    ev.clearance_p05_mm = percentile(clearances, 5.0)
    ev.clearance_below_target = sum(
        1 for s in ordered for c in s.clearances() if c < _target_of(s, clearance_mm))


def _measure_times(ev: Evaluation, ordered: Sequence[SeedResult]) -> None:
    """Median and longest simulated time, mean wall time per run."""
    sim_times = [s.sim_time_s for s in ordered]
    if sim_times:
        ev.sim_time_median_s = float(np.median(sim_times))
        ev.sim_time_max_s = max(sim_times)
        ev.wall_time_mean_s = float(np.mean([s.wall_time_s for s in ordered]))


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
    _count_outcomes(ev, ordered)
    _measure_clearances(ev, ordered, clearance_mm)
    _measure_times(ev, ordered)
    ev.failures = [s for s in ordered if not s.success]
    for s in ordered:
        problems = _incident(s, _target_of(s, clearance_mm))
        if problems:
            ev.incidents.append((s, problems))
    return ev


def format_evaluation(ev: Evaluation) -> str:
    """The evaluation's summary as text (what ``marknav evaluate`` prints)."""
    lo, hi = ev.success_ci95
    first, last = ev.seeds
    lines = [
        *([f"INTERRUPTED: the {ev.runs} run{'s' if ev.runs != 1 else ''} that finished of the "
           f"{ev.planned_runs} planned"] if ev.interrupted else []),
        f"{ev.mission}: {ev.runs} simulated run{'s' if ev.runs != 1 else ''} "
        + (f"(engine {ev.engine}) " if ev.engine != "builtin" else "") + "on "
        + ("generated missions and " if ev.mission_path == RANDOM else "")
        + f"randomised worlds (seeds {first}–{last}, {ev.jobs} job{'s' if ev.jobs != 1 else ''})",
        f"  success      {ev.successes}/{ev.runs} = {ev.success_rate:.1%}  "
        f"(95 % CI {lo:.1%}–{hi:.1%}, Wilson)",
        f"  collisions   {ev.collisions} (in {ev.runs_with_collisions} run"
        f"{'s' if ev.runs_with_collisions != 1 else ''})",
        f"  wrong side   {ev.wrong_side} mark{'s' if ev.wrong_side != 1 else ''} passed on the "
        f"wrong side" + (f"; {ev.unverified_passes} declared passed but not confirmed"
                         if ev.unverified_passes else ""),
        f"  silent       {ev.silent_failures} silent failure"
        f"{'s' if ev.silent_failures != 1 else ''} (reported passed, the truth denies; in "
        f"{ev.runs_with_silent_failures} run{'s' if ev.runs_with_silent_failures != 1 else ''})"
        f"; {ev.doubtful} pass{'es' if ev.doubtful != 1 else ''} reported doubtful, "
        f"{ev.doubts_borne_out} of them denied by the truth",
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
