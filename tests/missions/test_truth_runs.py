"""The verdict is the truth (issue 11): the zigzag run passes every course mark in order on its
side by the ground truth; a world whose fourth mark the robot never goes near is reported as
skipped and is not a success, whatever the tree declared; an unknown truth is never a pass."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from marknav.cli.main import main
from marknav.missions.schema import load_mission
from marknav.runs.evaluation.evaluate import SeedResult, WaypointTruth, summarise
from marknav.runs.metrics.truth import course_truth
from marknav.runs.records.report import RunReport, WaypointResult
from marknav.sim.world import load_world

ROOT = Path(__file__).resolve().parents[2]
ZIGZAG = ROOT / "missions" / "zigzag.yaml"
SKIP_WORLD = ROOT / "tests" / "data" / "worlds" / "zigzag-skip-world.yaml"


def run(tmp_path: Path, *extra: str) -> tuple[int, dict]:  # type: ignore[type-arg]
    report_path = tmp_path / "report.json"
    code = main(["run", str(ZIGZAG), "--report", str(report_path), *extra])
    return code, json.loads(report_path.read_text())


def recheck(report: dict, world_path: Path) -> list[str]:  # type: ignore[type-arg]
    """The verdicts again, from the report's truth_path alone."""
    mission = load_mission(ZIGZAG)
    path = np.asarray(report["truth_path"], dtype=float)
    return [m.truth for m in course_truth(path[:, 0], path[:, 1:], load_world(world_path),
                                          mission.route, [mission.side_of(c) for c in
                                                          mission.route])]


@pytest.mark.slow
def test_zigzag_passes_every_course_mark_in_order_on_its_side(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, report = run(tmp_path)
    out = capsys.readouterr().out
    assert code == 0, out[-3000:]
    assert report["outcome"] == "success"
    wps = report["waypoints"]
    assert [w["mark"]["index"] for w in wps] == [0, 1, 2, 3, 4]
    assert [(w["mark"]["x_mm"], w["mark"]["y_mm"]) for w in wps] == [
        (-250, 1500), (250, 3000), (-250, 4500), (250, 6000), (-250, 7500)]
    assert [w["truth"] for w in wps] == ["passed"] * 5
    assert [w["passed_on"] for w in wps] == [w["side"] for w in wps]
    assert all(w["min_clearance_mm"] >= 250 for w in wps)
    t = np.asarray([row[0] for row in report["truth_path"]])
    assert np.max(np.diff(t)) <= 0.2 + 1e-6 and t[-1] == pytest.approx(report["sim_time_s"],
                                                                        abs=0.05)
    assert recheck(report, ROOT / "missions" / "worlds" / "zigzag-world.yaml") == ["passed"] * 5


@pytest.mark.slow
def test_a_really_skipped_mark_is_reported_skipped(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, report = run(tmp_path, "--world", str(SKIP_WORLD))
    capsys.readouterr()
    assert code == 1
    assert report["outcome"] == "failed"
    wps = report["waypoints"]
    assert wps[3]["truth"] == "skipped" and wps[3]["mark"] == {
        "index": 3, "x_mm": 6000, "y_mm": -6000}
    assert [w["truth"] for w in wps[:3]] == ["passed"] * 3
    assert recheck(report, SKIP_WORLD)[3] == "skipped"
    rr = RunReport(mission="zigzag", outcome=report["outcome"], reason=report["reason"],
                   waypoints=[WaypointResult(**w) for w in wps])
    result = SeedResult.from_report(0, rr)
    assert not result.success and result.skipped == 1


def test_marks_after_the_run_ended_are_not_reached_rather_than_skipped(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A run cut short by its time limit after the first mark: the later course marks were never
    driven past, so the summary says "not reached", as evaluate counts them, not SKIPPED."""
    code, report = run(tmp_path, "--max-time", "12")
    lines = [ln for ln in capsys.readouterr().out.splitlines() if "ground truth (mark" in ln]
    assert report["outcome"] != "success" and code == 1
    assert [w["truth"] for w in report["waypoints"]] == ["passed"] + ["skipped"] * 4
    assert len(lines) == 5 and "(ok)" in lines[0]
    assert all("(not reached)" in ln and "SKIPPED" not in ln for ln in lines[1:]), lines


def wp(outcome: str, truth: str | None, passed_on: str | None = "left") -> WaypointTruth:
    return WaypointTruth("red", "left", outcome, passed_on, 300.0, truth, 0)


def seed(*wps: WaypointTruth, outcome: str = "success") -> SeedResult:
    return SeedResult(seed=1, outcome=outcome, reason="every waypoint passed", sim_time_s=10.0,
                      wall_time_s=1.0, collisions=0, waypoints=wps)


def test_success_needs_every_waypoint_confirmed_by_the_truth() -> None:
    assert seed(wp("passed", "passed"), wp("passed", "passed")).success
    # The tree says success, the side even looks right — but the truth is unknown or denies.
    for bad in (None, "skipped", "out_of_order", "off_course", "wrong_side"):
        s = seed(wp("passed", "passed"), wp("passed", bad))
        assert not s.success, bad
        assert s.unverified == 1, bad
        assert "the ground truth says: waypoint 2" in s.failure_reason
    assert not seed().success  # no waypoints: nothing confirmed
    assert not seed(wp("passed", "passed"), outcome="failed").success


def test_summary_counts_skipped_beside_collisions_and_wrong_side() -> None:
    results = [
        seed(wp("passed", "passed"), wp("passed", "skipped", None), wp("passed", "passed")),
        # A run that failed at its second waypoint: the marks after it were never reached, not
        # skipped.
        SeedResult(seed=2, outcome="failed", reason="Search: not found", sim_time_s=5.0,
                   wall_time_s=1.0, collisions=1,
                   waypoints=(wp("passed", "passed"), wp("failed", "skipped", None),
                              wp("pending", "skipped", None))),
        SeedResult(seed=3, outcome="success", reason="ok", sim_time_s=5.0, wall_time_s=1.0,
                   collisions=0, waypoints=(wp("passed", "wrong_side", "right"),)),
    ]
    ev = summarise(results, mission="m", mission_path="m.yaml", clearance_mm=300.0)
    d = ev.to_dict()
    assert (d["collisions"], d["wrong_side"], d["skipped"]) == (1, 1, 1)
    assert ev.successes == 0
