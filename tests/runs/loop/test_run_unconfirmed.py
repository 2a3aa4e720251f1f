"""A run whose passes the robot could not confirm ends "unverified", never "success"; each
waypoint's verdict follows what looking back decided."""

from __future__ import annotations

import py_trees

from marknav.behaviours import keys
from marknav.runs.loop.run import mark_unconfirmed, waypoint_outcomes
from marknav.runs.records.report import RunReport, WaypointResult
from marknav.runs.records.seed_result import SeedResult


def report_for(mission, outcome="success"):
    return RunReport(mission=mission.name, outcome=outcome, reason="every waypoint passed",
                     waypoints=[WaypointResult(colour=c, side=mission.side_of(c))
                                for c in mission.route])


def passes(*checks):
    """One red/green/red pass per entry: (doubt, check)."""
    records = tuple(keys.PassedWaypoint(i, f"w{i}", "red", "left", float(i), 0.0, 0.0,
                                        doubt=doubt, check=check)
                    for i, (doubt, check) in enumerate(checks))
    py_trees.blackboard.Blackboard.set(keys.PASSED, records)


def test_each_verdict_follows_the_look_back(blackboard, mission_factory):
    mission = mission_factory(route=["red", "green", "red", "green"])
    report = report_for(mission)
    passes((None, None), ("not seen", "confirmed"), ("not seen", "unverified"),
           ("not seen", None))
    assert waypoint_outcomes(mission, report) == ["passed", "passed", "unverified", "doubtful"]
    assert [w.check for w in report.waypoints] == [None, "confirmed", "unverified", None]


def test_a_refuted_pass_is_the_failed_waypoint(blackboard, mission_factory):
    mission = mission_factory(route=["red", "green", "red"])
    report = report_for(mission, outcome="failed")
    passes((None, None), ("a sighting across the path", "refuted"))
    assert waypoint_outcomes(mission, report) == ["passed", "failed", "pending"]


def test_an_unverified_pass_makes_the_run_unverified_and_never_a_success(blackboard,
                                                                         mission_factory):
    mission = mission_factory(route=["red", "green"])
    report = report_for(mission)
    passes((None, None), ("not seen since the bypass began", "unverified"))
    for w, o in zip(report.waypoints, waypoint_outcomes(mission, report), strict=True):
        w.outcome = o
        w.truth = "passed"
    mark_unconfirmed(report)
    assert report.outcome == "unverified"
    assert report.reason == ("every waypoint passed, but 1 of them not confirmed by the "
                             "robot's own evidence: waypoint 2 (green) unverified: not seen "
                             "since the bypass began")
    result = SeedResult.from_report(0, report)
    assert not result.success and result.silent_failures == 0 and result.doubtful == 1


def test_a_run_of_sure_passes_stays_a_success(blackboard, mission_factory):
    mission = mission_factory(route=["red"])
    report = report_for(mission)
    passes(("not seen", "confirmed"))
    report.waypoints[0].outcome = waypoint_outcomes(mission, report)[0]
    mark_unconfirmed(report)
    assert (report.outcome, report.reason) == ("success", "every waypoint passed")
