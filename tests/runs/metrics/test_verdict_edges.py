"""The evaluation's verdict and statistics at edges mutation testing found unasserted
(docs/mutation.md, runs/evaluation/evaluate.py): a run's JSON record field by field, which
waypoints a run
reached, incidents at their boundaries, the summary's defaults and totals, the statistics'
argument checks. Synthetic results only (no simulation)."""

from __future__ import annotations

import pytest

from marknav.runs.evaluation.evaluate import (
    CLEARANCE_TOLERANCE_MM,
    SeedResult,
    WaypointTruth,
    percentile,
    summarise,
    wilson_interval,
)
from marknav.runs.records.report import RunReport, WaypointResult


def wp(colour: str, outcome: str, truth: str | None, clearance: float | None = 300.0,
       passed_on: str | None = "left", mark: int | None = 0, detail: str = "") -> WaypointTruth:
    return WaypointTruth(colour, "left", outcome, passed_on, clearance, truth, mark, detail)


def result(*waypoints: WaypointTruth, seed: int = 7, outcome: str = "success",
           collisions: int = 0, clearance_mm: float | None = None) -> SeedResult:
    return SeedResult(seed=seed, outcome=outcome, reason="every waypoint passed",
                      sim_time_s=12.34567, wall_time_s=1.23456, collisions=collisions,
                      waypoints=tuple(waypoints), mission="missions/m.yaml",
                      clearance_mm=clearance_mm)


def test_a_runs_record_field_by_field() -> None:
    r = result(
        wp("red", "passed", "passed", 301.26, mark=0),
        wp("green", "passed", "wrong_side", 287.26, passed_on="right", mark=1,
           detail="passed on its right at 287 mm"),
        wp("blue", "failed", "skipped", 950.0, passed_on=None, mark=2),
        wp("red", "passed", "out_of_order", 410.0, mark=3),
        wp("green", "passed", "off_course", 520.0, mark=4),
        wp("blue", "pending", "skipped", None, passed_on=None, mark=5),  # never reached
        collisions=2)
    assert r.to_dict() == {
        "seed": 7, "outcome": "success", "reason": "every waypoint passed",
        "sim_time_s": 12.346, "wall_time_s": 1.235, "mission": "missions/m.yaml",
        "collisions": 2, "wrong_side": 1, "skipped": 1, "out_of_order": 1, "off_course": 1,
        # sure of 3 passes the truth denies (wrong side, out of order, off course)
        "silent_failures": 3, "doubtful": 0, "doubts_borne_out": 0,
        "waypoints_passed": 4, "min_clearance_mm": 287.3,
        "waypoints": [
            {"colour": "red", "side": "left", "outcome": "passed", "passed_on": "left",
             "min_clearance_mm": 301.26, "truth": "passed", "mark": 0},
            {"colour": "green", "side": "left", "outcome": "passed", "passed_on": "right",
             "min_clearance_mm": 287.26, "truth": "wrong_side", "mark": 1},
            {"colour": "blue", "side": "left", "outcome": "failed", "passed_on": None,
             "min_clearance_mm": 950.0, "truth": "skipped", "mark": 2},
            {"colour": "red", "side": "left", "outcome": "passed", "passed_on": "left",
             "min_clearance_mm": 410.0, "truth": "out_of_order", "mark": 3},
            {"colour": "green", "side": "left", "outcome": "passed", "passed_on": "left",
             "min_clearance_mm": 520.0, "truth": "off_course", "mark": 4},
            {"colour": "blue", "side": "left", "outcome": "pending", "passed_on": None,
             "min_clearance_mm": None, "truth": "skipped", "mark": 5}]}


def test_a_run_reaches_the_last_waypoint_the_tree_or_the_truth_passed() -> None:
    # the tree declared the second passed (no ground truth for it): the first was skipped
    skipped_then_declared = result(wp("red", "failed", "skipped", passed_on=None),
                                   wp("green", "passed", None, passed_on=None))
    assert skipped_then_declared.skipped == 1
    # a waypoint with no ground truth and not declared passed was not reached
    never_reached = result(wp("red", "passed", "passed"),
                           wp("green", "failed", "skipped", passed_on=None),
                           wp("blue", "pending", None, None, passed_on=None))
    assert never_reached.skipped == 0


def test_from_a_report_keeps_every_field() -> None:
    rep = RunReport(mission="m", outcome="success", reason="ok", sim_time_s=3.0,
                    wall_time_s=0.5, collisions=1, ticks=60, overruns=2,
                    waypoints=[WaypointResult("red", "right", "passed", "left", 280.0, None,
                                              "wrong_side", "passed on its left at 280 mm")])
    r = SeedResult.from_report(4, rep, mission="missions/x.yaml", clearance_mm=320.0)
    assert (r.seed, r.ticks, r.overruns, r.mission, r.clearance_mm, r.collisions) == (
        4, 60, 2, "missions/x.yaml", 320.0, 1)
    assert r.waypoints == (WaypointTruth("red", "right", "passed", "left", 280.0, "wrong_side",
                                         None, "passed on its left at 280 mm"),)
    bare = SeedResult.from_report(4, rep)  # no mission spec or clearance given
    assert (bare.mission, bare.clearance_mm) == ("", None)


def incidents(*results: SeedResult, clearance_mm: float = 300.0) -> dict[int, list[str]]:
    ev = summarise(list(results), mission="m", mission_path="m.yaml", clearance_mm=clearance_mm)
    return {s.seed: problems for s, problems in ev.incidents}


def test_incidents_name_unconfirmed_waypoints_up_to_the_last_reached() -> None:
    # declared passed with no ground truth at all
    assert incidents(result(wp("red", "passed", None, mark=None))) == {
        7: ["waypoint 1 (red) no ground truth"]}
    # the last waypoint reached, not declared by the tree, passed on the wrong side per truth
    assert incidents(result(wp("red", "passed", "passed"),
                            wp("green", "failed", "wrong_side", mark=1, detail="at 400 mm"),
                            outcome="failed")) == {
        7: ["waypoint 2 (green, mark 1) wrong side: at 400 mm"]}


def test_a_clearance_exactly_at_the_target_is_no_incident() -> None:
    target = 300.0 - CLEARANCE_TOLERANCE_MM
    at = result(wp("red", "passed", "passed", target))
    below = result(wp("red", "passed", "passed", target - 0.5), seed=8)
    assert incidents(at, below) == {8: [f"waypoint 1 (red) clearance {target - 0.5:.0f} mm "
                                        f"< {target:.0f} mm"]}
    ev = summarise([at, below], mission="m", mission_path="m.yaml", clearance_mm=300.0)
    assert ev.clearance_below_target == 1


def test_summary_defaults_and_totals() -> None:
    rs = [result(wp("red", "passed", "out_of_order"), seed=1),
          result(wp("red", "passed", "off_course"), seed=2),
          result(wp("red", "passed", "passed"), seed=3)]
    ev = summarise(rs, mission="m", mission_path="m.yaml", clearance_mm=300.0)
    d = ev.to_dict()
    assert (d["mission"], d["min_success"], d["jobs"], d["evaluation_wall_s"]) == (
        "m", 0.95, 1, 0.0)
    assert (ev.out_of_order, ev.off_course, ev.unverified_passes) == (1, 1, 2)
    ev = summarise(rs, mission="m", mission_path="m.yaml", clearance_mm=300.0, jobs=3,
                   wall_total_s=12.5)
    assert (ev.jobs, ev.wall_total_s, ev.to_dict()["jobs"]) == (3, 12.5, 3)
    empty = summarise([], mission="m", mission_path="m.yaml", clearance_mm=300.0)
    assert (empty.runs, empty.successes, empty.success_rate) == (0, 0, 0.0)


def test_statistics_refuse_impossible_arguments_by_name() -> None:
    with pytest.raises(ValueError, match=r"^need 0 ≤ successes ≤ n, got 3 of 2$"):
        wilson_interval(3, 2)
    with pytest.raises(ValueError, match=r"^need 0 ≤ successes ≤ n, got 1 of 0$"):
        wilson_interval(1, 0)
    assert percentile([1.0, 2.0], 0.0) == 1.0 and percentile([1.0, 2.0], 100.0) == 2.0
    assert percentile([1.0, 2.0], 0.5) == pytest.approx(1.005)
    for q in (-0.5, 100.5):
        with pytest.raises(ValueError, match=rf"^q must be in 0\.\.100, got {q}$"):
            percentile([1.0], q)


def test_no_successes_give_a_lower_bound_of_exactly_zero() -> None:
    # centre − half is 1e-17 off for n = 3, 6, 7, 12, ...: the bound is set, not computed
    assert [wilson_interval(0, n)[0] for n in (3, 6, 7, 12, 14)] == [0.0] * 5
