"""Evaluation statistics and aggregation, on synthetic run reports (no simulation)."""

from __future__ import annotations

import json
import math
import re
from collections.abc import Sequence
from pathlib import Path

import pytest
import yaml

from marknav.cli.main import main
from marknav.runs.evaluation import evaluate as ev_mod
from marknav.runs.evaluation.evaluate import (
    SeedResult,
    format_evaluation,
    percentile,
    replay_command,
    summarise,
    wilson_interval,
)
from marknav.runs.records.report import RunReport, WaypointResult
from marknav.testing import BASE_MISSION

Z2 = 1.959963984540054**2


# ------------------------------------------------------------------------------- statistics


def test_wilson_interval_at_the_ends_has_a_closed_form() -> None:
    # k = 0: [0, z²/(n+z²)]; k = n: [n/(n+z²), 1].
    assert wilson_interval(0, 10) == (0.0, pytest.approx(Z2 / (10 + Z2), abs=1e-12))
    lo, hi = wilson_interval(10, 10)
    assert lo == pytest.approx(10 / (10 + Z2), abs=1e-12) and hi == 1.0
    assert wilson_interval(0, 10)[1] == pytest.approx(0.27753, abs=1e-5)


def test_wilson_interval_against_published_values() -> None:
    # Newcombe (1998), Stat. Med. 17:857, table I, method 3: 81/263 -> 0.2553 to 0.3662;
    # 15/148 -> 0.0624 to 0.1605; 0/20 -> 0 to 0.1611; 1/29 -> 0.0061 to 0.1718.
    for (k, n), (lo, hi) in {(81, 263): (0.2553, 0.3662), (15, 148): (0.0624, 0.1605),
                             (0, 20): (0.0, 0.1611), (1, 29): (0.0061, 0.1718)}.items():
        got = wilson_interval(k, n)
        assert got[0] == pytest.approx(lo, abs=6e-5), (k, n)
        assert got[1] == pytest.approx(hi, abs=6e-5), (k, n)


def test_wilson_interval_is_symmetric_and_contains_the_estimate() -> None:
    lo, hi = wilson_interval(5, 10)
    assert lo == pytest.approx(1 - hi) and lo == pytest.approx(0.2366, abs=1e-4)
    for k in range(0, 41):
        lo, hi = wilson_interval(k, 40)
        assert 0.0 <= lo <= k / 40 <= hi <= 1.0


def test_wilson_interval_bad_counts() -> None:
    assert wilson_interval(0, 0) == (0.0, 1.0)
    with pytest.raises(ValueError):
        wilson_interval(3, 2)
    with pytest.raises(ValueError):
        wilson_interval(-1, 2)


def test_percentile_interpolates_linearly() -> None:
    assert percentile([float(v) for v in range(1, 22)], 5) == pytest.approx(2.0)
    assert percentile([0.0, 100.0], 5) == pytest.approx(5.0)
    assert percentile([300.0, 250.0, 320.0, 310.0, 305.0], 5) == pytest.approx(260.0)
    assert percentile([272.5], 5) == 272.5
    assert percentile([], 5) is None
    with pytest.raises(ValueError):
        percentile([1.0], 101)


# ------------------------------------------------------------------------------- aggregation


def report(outcome: str = "success", reason: str = "every waypoint passed", *,
           passed_on: tuple[str | None, ...] = ("left", "right"),
           clearance: tuple[float | None, ...] = (300.0, 310.0), collisions: int = 0,
           sim: float = 40.0, wall: float = 8.0) -> RunReport:
    sides = ("left", "right")
    wps = []
    for i, (p, c) in enumerate(zip(passed_on, clearance, strict=True)):
        truth = "skipped" if p is None else ("passed" if p == sides[i] else "wrong_side")
        wps.append(WaypointResult(colour=("red", "green")[i], side=sides[i],
                                  outcome="passed" if p is not None else "failed",
                                  passed_on=p, min_clearance_mm=c, truth=truth,
                                  mark={"index": i, "x_mm": 0.0, "y_mm": 1500.0 * (i + 1)},
                                  truth_detail=f"passed on its {p} at {c:.0f} mm"
                                  if truth == "wrong_side" else ""))
    return RunReport(mission="m", outcome=outcome, reason=reason, sim_time_s=sim,
                     wall_time_s=wall, waypoints=wps, collisions=collisions)


def synthetic() -> list[SeedResult]:
    reports = {
        10: report(sim=40.0),
        11: report(passed_on=("right", "right"), clearance=(305.0, 290.0), sim=42.0),
        12: report("aborted", "BackOff: bumped 3 times", passed_on=("left", None),
                   clearance=(240.0, 120.0), collisions=3, sim=12.5),
        13: report(clearance=(298.0, 301.0), collisions=1, sim=44.0),
        14: report("failed", "time limit: 140 s", passed_on=(None, None),
                   clearance=(900.0, 2000.0), sim=140.0),
    }
    # Out of order on purpose: summarise sorts by seed.
    return [SeedResult.from_report(s, reports[s]) for s in (13, 10, 14, 12, 11)]


def test_summarise_counts_what_went_wrong() -> None:
    ev = summarise(synthetic(), mission="m", mission_path="missions/m.yaml", clearance_mm=300.0,
                   min_success=0.95)
    assert [s.seed for s in ev.results] == [10, 11, 12, 13, 14]
    # seed 11: the tree completed, but the ground truth has red passed on the wrong side
    assert ev.runs == 5 and ev.successes == 2 and ev.success_rate == pytest.approx(0.4)
    assert ev.success_ci95 == pytest.approx(wilson_interval(2, 5))
    assert ev.collisions == 4 and ev.runs_with_collisions == 2
    assert ev.wrong_side == 1  # seed 11, waypoint 1: red passed on its right
    # Passed waypoints only: 10: 300, 310; 11: 305, 290; 12: 240 (waypoint 2 failed); 13: 298,
    # 301. Seed 14 passed nothing.
    assert ev.min_clearance_mm == 240.0
    assert ev.clearance_p05_mm == pytest.approx(percentile(
        [300.0, 310.0, 305.0, 290.0, 240.0, 298.0, 301.0], 5))
    assert ev.clearance_target_mm == 250.0 and ev.clearance_below_target == 1
    assert ev.sim_time_median_s == 42.0 and ev.sim_time_max_s == 140.0
    assert ev.wall_time_mean_s == pytest.approx(8.0)
    assert [(f.seed, f.outcome, f.failure_reason) for f in ev.failures] == [
        (11, "success", "the tree completed the route, but the ground truth says: waypoint 1 "
                        "(red, mark 0) wrong side: passed on its right at 305 mm"),
        (12, "aborted", "BackOff: bumped 3 times"), (14, "failed", "time limit: 140 s")]
    assert not ev.passed
    incidents = {s.seed: problems for s, problems in ev.incidents}
    assert incidents == {
        11: ["waypoint 1 (red, mark 0) wrong side: passed on its right at 305 mm "
             "(reported passed: a silent failure)"],
        12: ["3 collisions", "waypoint 1 (red) clearance 240 mm < 250 mm"],
        13: ["1 collision"],
    }


def test_json_has_the_documented_keys_and_replay_commands() -> None:
    ev = summarise(synthetic(), mission="m", mission_path="missions/my m.yaml",
                   clearance_mm=300.0, max_time_s=90.0)
    d = json.loads(json.dumps(ev.to_dict()))
    for key in ("runs", "success_rate", "success_ci95", "collisions", "wrong_side",
                "min_clearance_mm", "clearance_p05_mm", "failures", "sim_time_s", "wall_time_s"):
        assert key in d, key
    assert d["runs"] == 5 and d["success_rate"] == 0.4
    assert d["success_ci95"] == [round(v, 4) for v in wilson_interval(2, 5)]
    assert d["sim_time_s"] == {"median": 42.0, "max": 140.0}
    assert d["failures"][1] == {
        "seed": 12, "outcome": "aborted", "reason": "BackOff: bumped 3 times",
        "replay": "marknav run 'missions/my m.yaml' --world random --seed 12 --max-time 90"}
    assert [r["seed"] for r in d["results"]] == [10, 11, 12, 13, 14]
    assert d["results"][2]["min_clearance_mm"] == 240.0


def test_replay_command() -> None:
    assert replay_command("missions/slalom.yaml", 7) == (
        "marknav run missions/slalom.yaml --world random --seed 7")


def test_text_summary_lists_failures_and_incidents() -> None:
    ev = summarise(synthetic(), mission="m", mission_path="m.yaml", clearance_mm=300.0)
    text = format_evaluation(ev)
    assert "success      2/5 = 40.0%" in text
    assert "collisions   4 (in 2 runs)" in text
    assert "wrong side   1 mark passed on the wrong side" in text
    assert "clearance    min 240 mm, 5th percentile" in text
    assert "  seed 14: failed — time limit: 140 s\n    replay: marknav run m.yaml --world random " \
           "--seed 14" in text
    assert "  seed 11: the tree completed the route, but the ground truth says: " \
           "waypoint 1 (red, mark 0) wrong side: passed on its right at 305 mm" in text


def test_no_passed_waypoint_has_no_clearance() -> None:
    only = [SeedResult.from_report(0, report("failed", "x", passed_on=(None, None)))]
    ev = summarise(only, mission="m", mission_path="m.yaml", clearance_mm=300.0)
    assert ev.min_clearance_mm is None and ev.clearance_p05_mm is None
    assert ev.to_dict()["min_clearance_mm"] is None
    assert "no waypoint passed" in format_evaluation(ev)
    assert ev.success_ci95 == pytest.approx((0.0, Z2 / (1 + Z2)))
    assert not math.isnan(ev.sim_time_median_s)


# ------------------------------------------------------------------------- the command's exit


@pytest.fixture
def mission_file(tmp_path: Path) -> Path:
    path = tmp_path / "m.yaml"
    path.write_text(yaml.safe_dump({**BASE_MISSION, "route": ["red", "green"]}),
                    encoding="utf-8")
    return path


@pytest.fixture
def scripted_runs(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """run_seed replaced: seeds divisible by 10 fail, the rest succeed."""
    calls: list[int] = []

    def fake(path: str, seed: int, max_time_s: float | None = None,
             overrides: Sequence[str] = ()) -> SeedResult:
        calls.append(seed)
        if seed % 10 == 0:
            return SeedResult.from_report(seed, report("aborted", "Search: timeout",
                                                       passed_on=("left", None)))
        return SeedResult.from_report(seed, report())

    monkeypatch.setattr(ev_mod, "run_seed", fake)
    return calls


def test_exit_1_under_min_success(mission_file: Path, scripted_runs: list[int],
                                  capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["evaluate", str(mission_file), "--runs", "20", "--seed", "5"])
    out, err = capsys.readouterr()
    assert scripted_runs == list(range(5, 25))
    assert code == 1
    assert "success      18/20 = 90.0%" in out
    assert f"replay: marknav run {mission_file} --world random --seed 10" in out
    # (a busy machine may take over a second to load the compiled loops: a status line)
    lines = [line for line in err.strip().splitlines()
             if not line.startswith("preparing the simulator")]
    # piped: progress lines (at the start, every 10 s, at the end), then the verdict
    assert lines[0].startswith(f"evaluate {mission_file.stem}: 0/20 runs done, ")
    assert lines[-2].startswith(f"evaluate {mission_file.stem}: 20/20 runs done, 18 successes")
    assert lines[-1] == ("marknav evaluate: success rate 90.0% (18/20) is under --min-success "
                         "95.0%")


def test_exit_0_at_or_over_min_success(mission_file: Path, scripted_runs: list[int],
                                       capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["evaluate", str(mission_file), "--runs", "20", "--seed", "5", "--json",
                 "--min-success", "0.9"]) == 0
    out, err = capsys.readouterr()
    d = json.loads(out)
    assert d["success_rate"] == 0.9 and [f["seed"] for f in d["failures"]] == [10, 20]
    # stdout is the JSON alone; stderr has the piped progress lines only
    assert all(line.startswith(("evaluate ", "preparing the simulator"))
               for line in err.splitlines())
    assert main(["evaluate", str(mission_file), "--runs", "9", "--seed", "1"]) == 0


@pytest.mark.parametrize(("argv", "message"), [
    (["--runs", "0"], "--runs: must be at least 1, got 0"),
    (["--runs", "2", "--jobs", "0"], "--jobs: must be at least 1, got 0"),
    (["--runs", "2", "--seed", "-1"], "--seed: must be ≥ 0, got -1"),
    (["--runs", "2", "--max-time", "0"], "--max-time: must be positive, got 0.0"),
    (["--runs", "2", "--min-success", "1.5"], "--min-success: must be between 0 and 1, got 1.5"),
    ([], "--runs: give the number of runs: --runs N"),
    (["--runs", "2", "--plot", "x.png"], "--plot: only applies with --accuracy"),
])
def test_bad_input_exits_2(argv: list[str], message: str, mission_file: Path,
                           scripted_runs: list[int], capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["evaluate", str(mission_file), *argv]) == 2
    assert capsys.readouterr().err == f"marknav evaluate: error: {message}\n"
    assert scripted_runs == []


def test_missing_or_invalid_mission_exits_2(tmp_path: Path, scripted_runs: list[int],
                                            capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["evaluate", str(tmp_path / "nope.yaml"), "--runs", "2"]) == 2
    assert "nope.yaml" in capsys.readouterr().err
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: b\nroute: [red]\nmarks: {colours: {}}\n", encoding="utf-8")
    assert main(["evaluate", str(bad), "--runs", "2"]) == 2
    assert f"{bad}:" in capsys.readouterr().err
    assert main(["evaluate", "--runs", "2"]) == 2
    assert "give a MISSION" in capsys.readouterr().err
    assert scripted_runs == []


def test_progress_bar_on_a_terminal(mission_file: Path, scripted_runs: list[int],
                                    monkeypatch: pytest.MonkeyPatch,
                                    capsys: pytest.CaptureFixture[str]) -> None:
    import sys

    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert main(["evaluate", str(mission_file), "--runs", "2", "--seed", "9",
                 "--min-success", "0"]) == 0
    err = capsys.readouterr().err
    # a rich bar redrawn in place (cursor movements), not a line per update; its last state
    # stays on screen
    assert "\x1b[" in err
    last = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", err).rstrip().rsplit("\n", 1)[-1]
    assert f"evaluate {mission_file.stem}" in last and "2/2" in last and "1 success" in last
    assert "ETA" in last


def test_a_crashing_run_is_an_error_not_the_end(mission_file: Path,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    import marknav.runs.loop.run as run_mod

    def boom(req: object) -> object:
        raise ZeroDivisionError("division by zero")

    monkeypatch.setattr(run_mod, "execute", boom)
    result = ev_mod.run_seed(str(mission_file), 4)
    assert (result.seed, result.outcome, result.reason) == (
        4, "error", "crashed: ZeroDivisionError: division by zero")
    assert not result.success and result.waypoints == ()
