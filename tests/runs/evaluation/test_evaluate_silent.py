"""Silent failures: the robot said a waypoint was passed and the ground truth says otherwise."""

from __future__ import annotations

import json

from marknav.runs.evaluation.evaluate import SeedResult, format_evaluation, summarise
from marknav.runs.records.report import RunReport, WaypointResult


def run(outcomes: tuple[str, str], truths: tuple[str, str], *, outcome: str = "failed",
        doubt: str | None = None) -> RunReport:
    wps = [WaypointResult(colour=c, side=s, outcome=o, passed_on=None, min_clearance_mm=300.0,
                          truth=t, mark={"index": i, "x_mm": 0.0, "y_mm": 1500.0 * (i + 1)},
                          doubt=doubt if o == "doubtful" else None)
           for i, (c, s, o, t) in enumerate(zip(("red", "green"), ("left", "right"), outcomes,
                                                truths, strict=True))]
    return RunReport(mission="m", outcome=outcome, reason="r", sim_time_s=30.0,
                     wall_time_s=5.0, waypoints=wps)


def evaluation():
    reports = {
        0: run(("passed", "passed"), ("passed", "passed"), outcome="success"),
        # the robot was sure of waypoint 2; the truth: wrong side -> one silent failure
        1: run(("passed", "passed"), ("passed", "wrong_side")),
        # it doubted waypoint 2, and rightly: not silent
        2: run(("passed", "doubtful"), ("passed", "wrong_side"), doubt="a sighting ..."),
        # it doubted waypoint 1, wrongly (the truth confirms the pass): not a failure at all
        3: run(("doubtful", "passed"), ("passed", "passed"), outcome="success", doubt="x"),
        # sure of a mark it went by without passing (skipped): silent too
        4: run(("passed", "failed"), ("skipped", "skipped")),
    }
    results = [SeedResult.from_report(s, r) for s, r in reports.items()]
    return summarise(results, mission="m", mission_path="m.yaml", clearance_mm=300.0)


def test_silent_failures_are_sure_passes_the_truth_denies() -> None:
    ev = evaluation()
    assert ev.silent_failures == 2 and ev.runs_with_silent_failures == 2
    assert ev.doubtful == 2 and ev.doubts_borne_out == 1
    assert [r.silent_failures for r in ev.results] == [0, 1, 0, 0, 1]
    # the doubtful pass that truth confirms is a success
    assert [r.success for r in ev.results] == [True, False, False, True, False]


def test_silent_failures_in_the_table_and_the_json() -> None:
    ev = evaluation()
    text = format_evaluation(ev)
    assert ("silent       2 silent failures (reported passed, the truth denies; in 2 runs); "
            "2 passes reported doubtful, 1 of them denied by the truth") in text
    d = json.loads(json.dumps(ev.to_dict()))
    assert (d["silent_failures"], d["runs_with_silent_failures"], d["doubtful"],
            d["doubts_borne_out"]) == (2, 2, 2, 1)
    assert [r["silent_failures"] for r in d["results"]] == [0, 1, 0, 0, 1]
    incidents = {s.seed: p for s, p in ev.incidents}
    assert incidents[1] == ["waypoint 2 (green, mark 1) wrong side (reported passed: a silent "
                            "failure)"]
    assert incidents[2] == ["waypoint 2 (green, mark 1) wrong side (reported doubtful)"]
    assert incidents[3] == ["waypoint 1 (red) reported doubtful, passed in truth"]
