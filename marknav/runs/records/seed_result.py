"""One run of an evaluation as a record: what the tree said of each waypoint beside the ground
truth's verdict, and the command that replays it."""

from __future__ import annotations

import shlex
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from marknav.runs.records.report import (
    PASSED_OUTCOMES,
    SUCCESS,
    UNSURE_OUTCOMES,
    RunReport,
    reached,
)

__all__ = ["ERROR", "RANDOM", "SeedResult", "WaypointTruth", "random_replay_command",
           "replay_command"]


#: Outcome of a run that raised instead of finishing (a bug, counted as a failure).
ERROR = "error"
#: The mission spec of an evaluation over generated missions (one drawn per seed).
RANDOM = "random"


@dataclass(frozen=True)
class WaypointTruth:
    """A waypoint of one run: what the tree said and what the ground truth shows.

    ``truth`` is the verdict of :mod:`marknav.runs.metrics.truth` from the true path alone
    ("passed", "wrong_side", "skipped", "out_of_order", "off_course"); ``None`` when unknown (no
    truth was recorded), which never counts as passed.
    """

    colour: str
    side: str
    outcome: str  # "passed" | "doubtful" | "unverified" | "failed" | "pending"
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
        """The tree declared it passed (sure or doubtful) but the ground truth does not confirm
        it."""
        return self.outcome in PASSED_OUTCOMES and not self.confirmed

    @property
    def silent_failure(self) -> bool:
        """The robot reported it passed, without doubt, and the ground truth says otherwise."""
        return self.outcome == "passed" and self.truth is not None and not self.confirmed

    @property
    def doubtful(self) -> bool:
        """The robot reported the pass doubtful or unverified (not sure of it)."""
        return self.outcome in UNSURE_OUTCOMES

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
    outcome: str  # "success" | "unverified" | "failed" | "aborted" | "error"
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

    @property
    def silent_failures(self) -> int:
        """Waypoints reported passed, without doubt, that the ground truth denies."""
        return sum(1 for w in self.waypoints if w.silent_failure)

    @property
    def doubtful(self) -> int:
        return sum(1 for w in self.waypoints if w.doubtful)

    @property
    def doubts_borne_out(self) -> int:
        """Doubtful passes the ground truth denies too (the doubt was right)."""
        return sum(1 for w in self.waypoints if w.doubtful and w.truth is not None
                   and not w.confirmed)

    def clearances(self) -> list[float]:
        """Ground-truth clearance of every waypoint the tree passed."""
        return [w.min_clearance_mm for w in self.waypoints
                if w.outcome in PASSED_OUTCOMES and w.min_clearance_mm is not None]

    def to_dict(self) -> dict[str, Any]:
        clear = self.clearances()
        return {
            "seed": self.seed, "outcome": self.outcome, "reason": self.reason,
            "sim_time_s": round(self.sim_time_s, 3), "wall_time_s": round(self.wall_time_s, 3),
            "mission": self.mission,
            "collisions": self.collisions, "wrong_side": self.wrong_side,
            "skipped": self.skipped, "out_of_order": self.out_of_order,
            "off_course": self.off_course,
            "silent_failures": self.silent_failures, "doubtful": self.doubtful,
            "doubts_borne_out": self.doubts_borne_out,
            "waypoints_passed": sum(1 for w in self.waypoints if w.outcome in PASSED_OUTCOMES),
            "min_clearance_mm": round(min(clear), 1) if clear else None,
            "waypoints": [{"colour": w.colour, "side": w.side, "outcome": w.outcome,
                           "passed_on": w.passed_on, "min_clearance_mm": w.min_clearance_mm,
                           "truth": w.truth, "mark": w.mark_index}
                          for w in self.waypoints],
        }


def replay_command(mission_path: str, seed: int, max_time_s: float | None = None,
                   overrides: Sequence[str] = (), engine: str | None = None) -> str:
    """The ``marknav run`` command that replays evaluation run ``seed`` exactly."""
    flag = f" --engine {engine}" if engine is not None else ""
    if mission_path == RANDOM:
        return random_replay_command(seed, max_time_s, engine)
    cmd = f"marknav run {shlex.quote(mission_path)} --world random --seed {seed}{flag}"
    cmd += "".join(f" --set {shlex.quote(o)}" for o in overrides)
    if max_time_s is not None:
        cmd += f" --max-time {max_time_s:g}"
    return cmd


def random_replay_command(seed: int, max_time_s: float | None = None,
                          engine: str | None = None) -> str:
    """The commands that rebuild random mission ``seed`` (for ``engine``: MuJoCo's missions
    have their own rooms) and run it exactly as the evaluation did."""
    out = f"runs/random-{seed}"
    flag = f" --engine {engine}" if engine is not None else ""
    cmd = f"marknav random-mission --seed {seed}{flag} --out {out} && marknav run " \
          f"{out}/mission.yaml --seed {seed}{flag}"
    if max_time_s is not None:
        cmd += f" --max-time {max_time_s:g}"
    return cmd
