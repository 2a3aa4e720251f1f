"""Today's verdict of one evaluation run (``SeedResult.success``): the tree's SUCCESS counts only
if the ground truth agrees — every waypoint really passed, each on its colour's side.

Engineer i11 is rewriting the verdict (a ``skipped`` count, the true path's crossings); the new
verdict's tests are theirs. This file pins the current rule only.
"""

from __future__ import annotations

from marknav.missions.evaluate import SeedResult, WaypointTruth


def run(*waypoints: WaypointTruth, outcome: str = "success") -> SeedResult:
    return SeedResult(seed=4, outcome=outcome, reason="every waypoint passed", sim_time_s=20.0,
                      wall_time_s=1.0, collisions=0, waypoints=waypoints)


RED_OK = WaypointTruth("red", "left", "passed", "left", 310.0)


def test_a_pass_the_ground_truth_confirms_is_a_success() -> None:
    result = run(RED_OK, WaypointTruth("green", "right", "passed", "right", 290.0))
    assert result.success
    assert (result.wrong_side, result.unverified) == (0, 0)


def test_a_declared_pass_the_ground_truth_never_saw_is_not_a_success() -> None:
    result = run(RED_OK, WaypointTruth("green", "right", "passed", None, 900.0))
    assert not result.success
    assert (result.wrong_side, result.unverified) == (0, 1)
    assert result.failure_reason == ("the tree completed the route, but the ground truth says: "
                                     "waypoint 2 (green) declared passed but never passed")


def test_a_pass_on_the_wrong_side_is_not_a_success() -> None:
    result = run(WaypointTruth("red", "left", "passed", "right", 280.0), RED_OK)
    assert not result.success
    assert (result.wrong_side, result.unverified) == (1, 0)
    assert result.failure_reason.endswith("waypoint 1 (red) passed on its right, not its left")


def test_a_failed_tree_is_not_a_success_whatever_the_truth() -> None:
    result = run(RED_OK, outcome="failed")
    assert not result.success and result.failure_reason == "every waypoint passed"


def test_one_run_from_its_report_and_as_json() -> None:
    from marknav.missions.report import RunReport, WaypointResult

    report = RunReport(mission="tiny", outcome="success", reason="every waypoint passed",
                       sim_time_s=21.23456, wall_time_s=1.98765, ticks=425, collisions=1,
                       overruns=2, waypoints=[
                           WaypointResult("red", "left", "passed", "left", 312.34),
                           WaypointResult("green", "right", "passed", "left", 287.66),
                           WaypointResult("blue", "left", "pending")])
    result = SeedResult.from_report(7, report)
    assert (result.seed, result.outcome, result.reason) == (7, "success",
                                                           "every waypoint passed")
    assert (result.ticks, result.overruns, result.collisions) == (425, 2, 1)
    assert result.waypoints[1] == WaypointTruth("green", "right", "passed", "left", 287.66)
    assert result.clearances() == [312.34, 287.66]  # the pending one has none
    assert result.to_dict() == {
        "seed": 7, "outcome": "success", "reason": "every waypoint passed",
        "sim_time_s": 21.235, "wall_time_s": 1.988, "collisions": 1, "wrong_side": 1,
        "waypoints_passed": 2, "min_clearance_mm": 287.7,
        "waypoints": [
            {"colour": "red", "side": "left", "outcome": "passed", "passed_on": "left",
             "min_clearance_mm": 312.34},
            {"colour": "green", "side": "right", "outcome": "passed", "passed_on": "left",
             "min_clearance_mm": 287.66},
            {"colour": "blue", "side": "left", "outcome": "pending", "passed_on": None,
             "min_clearance_mm": None}]}
    assert run().to_dict()["min_clearance_mm"] is None  # no waypoint passed


def test_summary_counts_at_the_clearance_target_and_unverified_passes() -> None:
    from marknav.missions.evaluate import CLEARANCE_TOLERANCE_MM, summarise

    target = 300.0 - CLEARANCE_TOLERANCE_MM
    at_target = run(WaypointTruth("red", "left", "passed", "left", target))
    below = replace_seed(run(WaypointTruth("red", "left", "passed", "left", target - 0.1)), 5)
    ghost = replace_seed(run(WaypointTruth("red", "left", "passed", None, None)), 6)
    ev = summarise([ghost, below, at_target], mission="tiny", mission_path="tiny.yaml",
                   clearance_mm=300.0)
    assert [s.seed for s in ev.results] == [4, 5, 6]
    assert (ev.runs, ev.successes, ev.unverified_passes) == (3, 2, 1)
    assert ev.success_rate == 2 / 3
    assert (ev.min_success, ev.jobs, ev.wall_total_s) == (0.95, 1, 0.0)  # the defaults
    assert ev.clearance_below_target == 1  # at the target is not below it
    assert ev.incidents == [
        (below, [f"waypoint 1 (red) clearance {target - 0.1:.0f} mm < {target:.0f} mm"]),
        (ghost, ["waypoint 1 (red) declared passed but never passed"])]
    ev = summarise([at_target], mission="tiny", mission_path="tiny.yaml", clearance_mm=300.0,
                   jobs=2, wall_total_s=3.5)
    assert (ev.mission, ev.mission_path, ev.jobs, ev.wall_total_s) == ("tiny", "tiny.yaml", 2,
                                                                       3.5)
    empty = summarise([], mission="tiny", mission_path="tiny.yaml", clearance_mm=300.0)
    assert (empty.runs, empty.success_rate, empty.success_ci95) == (0, 0.0, (0.0, 1.0))


def replace_seed(result: SeedResult, seed: int) -> SeedResult:
    from dataclasses import replace

    return replace(result, seed=seed)


def test_percentile_and_wilson_bounds() -> None:
    import pytest

    from marknav.missions.evaluate import percentile, wilson_interval

    assert percentile([3, 1, 2], 0.0) == 1.0 and percentile([3, 1, 2], 100.0) == 3.0
    assert percentile([], 50.0) is None
    for q in (-0.5, 100.5):
        with pytest.raises(ValueError, match=rf"^q must be in 0\.\.100, got {q}$"):
            percentile([1.0], q)
    lo, hi = wilson_interval(0, 10)
    assert lo == 0.0 and 0.25 < hi < 0.35
    lo, hi = wilson_interval(10, 10)
    assert 0.65 < lo < 0.75 and hi == 1.0
    lo, hi = wilson_interval(1, 1)
    assert hi == 1.0 and 0.2 < lo < 0.25
    # where floating point lands beside the exact end (5.6e-17 above 0 at 0 of 3): exactly 0
    assert wilson_interval(0, 3)[0] == 0.0
    for successes, n in ((1, 0), (-1, 5), (6, 5), (0, -1)):
        with pytest.raises(ValueError,
                           match=rf"^need 0 ≤ successes ≤ n, got {successes} of {n}$"):
            wilson_interval(successes, n)
