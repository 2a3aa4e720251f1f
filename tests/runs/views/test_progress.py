"""Progress of long commands: a line every ~10 s when piped, a status only for a slow start,
and an interrupted evaluation that keeps (and prints) the runs that finished."""

from __future__ import annotations

import io
import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, ClassVar

import pytest

from marknav.cli.main import main
from marknav.runs.evaluation import evaluate as evaluate_module
from marknav.runs.evaluation.evaluate import EvaluationStopped, SeedResult, evaluate
from marknav.runs.views.progress import Progress, slow_status

SLALOM = Path(__file__).resolve().parents[3] / "missions" / "slalom.yaml"


class Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def test_piped_progress_writes_a_line_at_start_every_period_and_at_the_end() -> None:
    out, clock = io.StringIO(), Clock()
    progress = Progress("evaluate slalom", out, unit="runs done", every_s=10.0,
                        terminal=False, clock=clock)
    progress.start(4)
    clock.t += 5.0
    progress.update(1, note="1 success")  # 5 s after the last line: not yet
    clock.t += 7.0
    progress.update(2, note="2 successes")  # 12 s: a line, with the pace so far
    clock.t += 3.0
    assert progress.eta_s() == pytest.approx(9.0)  # counts down while a run goes on
    progress.update(3, note="2 successes")
    progress.finish()  # the last state, whatever the period
    assert out.getvalue().splitlines() == [
        "evaluate slalom: 0/4 runs done, 0:00 elapsed, ETA —",
        "evaluate slalom: 2/4 runs done, 2 successes, 0:12 elapsed, ETA 0:12",
        "evaluate slalom: 3/4 runs done, 2 successes, 0:15 elapsed, ETA 0:05",
    ]


def _lines_within(out: io.StringIO, n: int, timeout_s: float = 10.0) -> list[str]:
    """``out``'s lines once there are ``n`` (the ticker thread writes them; the timeout is a
    bound on a stuck thread, not a measurement)."""
    deadline = time.monotonic() + timeout_s
    while len(out.getvalue().splitlines()) < n and time.monotonic() < deadline:
        time.sleep(0.005)
    return out.getvalue().splitlines()


def test_piped_progress_goes_on_when_no_step_finishes() -> None:
    out, clock = io.StringIO(), Clock()
    with Progress("tune slalom", out, total=3, every_s=0.5, terminal=False, clock=clock):
        assert _lines_within(out, 1) == ["tune slalom: 0/3 done, 0:00 elapsed, ETA —"]
        for _ in range(3):  # no step finishes: a silent pipe looks hung, so the ticker writes
            clock.t += 30.0
            _lines_within(out, len(out.getvalue().splitlines()) + 1)
    assert out.getvalue().splitlines() == [
        f"tune slalom: 0/3 done, {elapsed} elapsed, ETA —"
        for elapsed in ("0:00", "0:30", "1:00", "1:30", "1:30")  # the last one: finish()
    ]


def test_a_resumed_count_is_not_in_the_pace() -> None:
    out, clock = io.StringIO(), Clock()
    progress = Progress("tune", out, unit="trials complete", terminal=False, clock=clock)
    progress.start(10, done=6)  # 6 trials from an earlier session
    clock.t += 60.0
    progress.update(7)
    assert progress.eta_s() == pytest.approx(180.0)  # 3 left at 60 s each, not 3 × 60/7
    progress.finish()


class ManualTimer:
    """:class:`threading.Timer` as ``slow_status`` uses it, fired by the test: "``after_s``
    has passed" happens when the test says so."""

    made: ClassVar[list[ManualTimer]] = []

    def __init__(self, delay_s: float, function: Callable[[], None]) -> None:
        self.delay_s, self.function = delay_s, function
        self.daemon = False
        self.started = self.cancelled = False
        ManualTimer.made.append(self)

    def start(self) -> None:
        self.started = True

    def cancel(self) -> None:
        self.cancelled = True

    def fire(self) -> None:  # even once cancelled: a real timer can be firing as it is
        self.function()


def test_slow_status_shows_only_for_a_slow_block() -> None:
    out = io.StringIO()
    ManualTimer.made.clear()
    with slow_status("preparing the detector…", out, after_s=0.5, terminal=False,
                     make_timer=ManualTimer):
        pass  # a fast block: over before its timer fires
    (fast,) = ManualTimer.made
    assert (fast.delay_s, fast.started, fast.daemon, fast.cancelled) == (0.5, True, True, True)
    fast.fire()  # firing late (as the block ended) shows nothing
    assert out.getvalue() == ""
    with slow_status("preparing the detector…", out, after_s=0.02, terminal=False,
                     make_timer=ManualTimer):
        ManualTimer.made[-1].fire()  # a slow block: still running when its timer fires
        assert out.getvalue() == "preparing the detector…\n"
    assert out.getvalue() == "preparing the detector…\n"


def _seed_result(seed: int) -> SeedResult:
    return SeedResult(seed=seed, outcome="success", reason="every waypoint passed",
                      sim_time_s=30.0, wall_time_s=3.0, collisions=0, waypoints=(),
                      mission=str(SLALOM))


def _interrupted_after(finished: int) -> Any:
    def run_jobs(task: Any, jobs: list[Any], *, on_result: Any, **_kw: Any) -> Any:
        for job in jobs[:finished]:
            on_result(_seed_result(job[1]))
        raise KeyboardInterrupt("SIGINT")
    return run_jobs


def test_an_interrupted_evaluation_keeps_the_finished_runs(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(evaluate_module, "run_jobs", _interrupted_after(2))
    with pytest.raises(EvaluationStopped) as stop:
        evaluate(SLALOM, runs=5, seed=10)
    ev = stop.value.evaluation
    assert isinstance(stop.value, KeyboardInterrupt)
    assert (ev.interrupted, ev.runs, ev.planned_runs) == (True, 2, 5)
    assert [r.seed for r in ev.results] == [10, 11]
    assert evaluate_module.format_evaluation(ev).startswith(
        "INTERRUPTED: the 2 runs that finished of the 5 planned\n")


def test_evaluate_json_after_ctrl_c_prints_the_finished_runs_and_exits_130(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(evaluate_module, "run_jobs", _interrupted_after(3))
    monkeypatch.setattr("marknav.runs.loop.run.prepare", lambda simulator: None)
    assert main(["evaluate", str(SLALOM), "--runs", "8", "--json"]) == 130
    captured = capsys.readouterr()
    data = json.loads(captured.out)
    assert (data["interrupted"], data["runs"], data["planned_runs"]) == (True, 3, 8)
    assert [r["seed"] for r in data["results"]] == [0, 1, 2]
    said = [line for line in captured.err.splitlines() if "interrupted" in line]
    assert said == ["marknav evaluate: interrupted; 3 of 8 runs had finished: their figures "
                    "are printed, marked interrupted"]
