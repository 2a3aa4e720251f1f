"""The complete run log and replay, on one real simulated slalom run.

The run's tree statuses are read straight from the py_trees nodes after every tick (not through
the recorder's own capture) and compared with what the log alone rebuilds; the plot is drawn
from the log. (The run's MCAP recording: tests/runs/records/test_mcap_recording.py.)
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from marknav.cli.main import main
from marknav.missions.schema import load_mission
from marknav.runs.loop.run import RunRequest, execute
from marknav.runs.records import runlog
from marknav.runs.records.runlog import Replay, read_log
from marknav.runs.records.tree_state import TreeState, _preorder

ROOT = Path(__file__).resolve().parents[3]
SLALOM = ROOT / "missions" / "slalom.yaml"


@pytest.fixture(scope="module")
def slalom_run(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """One slalom run with a log and saved frames (2 Hz)."""
    folder = tmp_path_factory.mktemp("run")
    live: list[tuple[list[str], list[str], list[bool]]] = []
    original = runlog.Recorder.tick

    def spy(self: runlog.Recorder, now: float, overruns: int) -> None:
        original(self, now, overruns)
        nodes = _preorder(self.root)
        live.append(([n.status.value for n in nodes],
                     [n.feedback_message if n.status.value != "INVALID" else ""
                      for n in nodes],
                     [n.id in self.state.ticked.ids for n in nodes]))

    mp = pytest.MonkeyPatch()
    mp.setattr(runlog.Recorder, "tick", spy)
    try:
        result = execute(RunRequest(
            mission=load_mission(str(SLALOM)), report_path=folder / "report.json",
            events_path=folder / "report.events.jsonl", frames_hz=2.0))
    finally:
        mp.undo()
    return {"folder": folder, "live": live, "result": result,
            "records": read_log(folder / "report.events.jsonl")}


@pytest.mark.slow
def test_statuses_are_rebuilt_tick_by_tick_from_the_log_alone(slalom_run: dict[str, Any]) -> None:
    replay = Replay(slalom_run["records"])
    live = slalom_run["live"]
    report = slalom_run["result"].report
    assert len(replay) == len(live) == report.ticks
    for k, (rec, state) in enumerate(replay.states()):
        assert rec["n"] == k
        assert state.status == live[k][0], f"tick {k}"
        for i, (said, reached) in enumerate(zip(live[k][1], live[k][2], strict=True)):
            # a node this tick did not reach says when its words are from
            assert state.message[i] == said if reached or not said else \
                re.fullmatch(r"at t=\d+\.\d\d s: " + re.escape(said), state.message[i]), \
                (k, state.names[i], state.message[i])
    # times are run-relative and never go backwards, every record has one
    times = [r["t"] for r in slalom_run["records"]]
    assert times[0] == 0.0 and times == sorted(times)
    kinds = Counter(r["kind"] for r in slalom_run["records"])
    assert kinds["tick"] == report.ticks and kinds["frame"] > 0.8 * report.ticks
    assert [r["kind"] for r in slalom_run["records"][-2:]] == ["report", "end"]
    # odometry and true pose every tick; the true path ends where the simulator's did
    last = replay.ticks[-1]
    env = slalom_run["result"].environment
    assert np.hypot(*(np.asarray(last["truth"][:2]) - env.truth.xy[-1])) < 30.0
    # odometry, not the truth (after 7 m it has drifted by a few hundred mm, not metres)
    assert np.hypot(*(np.asarray(last["pose"][:2]) - np.asarray(last["truth"][:2]))) < 500.0


def test_the_log_holds_detections_blackboard_writes_wheels_and_frames(
        slalom_run: dict[str, Any]) -> None:
    records = slalom_run["records"]
    frames = [r for r in records if r["kind"] == "frame"]
    first = frames[0]["marks"][0]
    assert set(first) >= {"colour", "x_px", "y_px", "axes_px", "forward_mm", "left_mm", "world"}
    plans = [p for r in records if r["kind"] == "tick"
             for p in r.get("bb", {}).get("/marknav/plans", [])]
    assert len(plans) == len(slalom_run["result"].plans) > 0
    passed = [p for r in records if r["kind"] == "tick"
              for p in r.get("bb", {}).get("/marknav/passed", [])]
    assert [p["colour"] for p in passed] == ["red", "green", "red", "blue"]
    wheels = [r["panel"]["wheels_mm_s"] for r in records if r["kind"] == "tick"]
    assert max(max(w) for w in wheels) > 100
    saved = [f for f in frames if "image" in f]
    # 2 Hz over ~40 s of run time, each file a JPEG beside the log
    t_end = records[-1]["t"]
    assert abs(len(saved) - 2.0 * t_end) <= 2
    data = (slalom_run["folder"] / saved[0]["image"]).read_bytes()
    assert data[:2] == b"\xff\xd8"


def test_replay_at_a_time_shows_the_tree_and_panel_of_that_tick(
        slalom_run: dict[str, Any], capsys: pytest.CaptureFixture[str]) -> None:
    folder = slalom_run["folder"]
    assert main(["replay", str(folder), "--at", "14.2", "--tree", "ascii"]) == 0
    out = capsys.readouterr().out
    replay = Replay(slalom_run["records"])
    k = replay.index_at(14.2)
    assert f"t={replay.times[k]:.2f} s  tick {k}" in out
    live_status = slalom_run["live"][k][0]
    names = TreeState.from_structure(replay.info["tree"]).names
    running = [names[i] for i, s in enumerate(live_status) if s == "RUNNING"]
    assert running and all(name in out for name in running)
    # a finished waypoint: what it ended with, and when (the route has moved on from it)
    assert re.search(r"ok   \?\? Waypoint 1: red \(pass on its left\) :: -- at t=\d+\.\d\d s: "
                     r"passed red #1 on its left", out), out
    # the next status change after tick k is a tick where some node's status differs
    j = replay.next_change(k)
    assert j > k and live_status != slalom_run["live"][j][0]
    assert all(slalom_run["live"][i][0] == live_status for i in range(k, j))


def test_the_plot_is_redrawn_from_the_log(slalom_run: dict[str, Any], tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    from marknav.sim.plot import plot_data_from_log

    data = plot_data_from_log(slalom_run["records"])
    result = slalom_run["result"]
    assert len(data.plans) == len(result.plans)
    assert [m.label.split("\n")[0] for m in data.marks] == ["#1 red", "#2 green", "#3 red",
                                                            "#4 blue"]
    assert np.hypot(*(data.xy[-1] - result.environment.truth.xy[-1])) < 30.0
    assert data.title == "slalom: success (every waypoint passed)"
    png = tmp_path / "replayed.png"
    assert main(["replay", str(slalom_run["folder"]), "--plot", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_without_the_extra_the_viewer_options_exit_2_naming_it(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setitem(sys.modules, "rerun", None)  # import rerun -> ImportError
    for argv in (["run", str(SLALOM), "--viewer"], ["view", "x.mcap"]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert "pip install 'marknav[viewer]'" in err and "Traceback" not in err


def test_a_log_that_is_not_json_names_file_and_line(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "r.events.jsonl"
    bad.write_text(json.dumps({"t": 0, "kind": "start"}) + "\nnot json\n{}\n")
    assert main(["replay", str(bad), "--at", "0"]) == 2
    assert f"{bad}:2" in capsys.readouterr().err


def test_v_shows_marknav_info_but_not_library_chatter(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    main(["-v", "run", str(SLALOM), "--tree", "none", "--max-time", "1",
          "--report", str(tmp_path / "r.json")])
    err = capsys.readouterr().err
    assert "INFO marknav.robot.driver: connected to create2" in err
    assert "transitions" not in err


@pytest.mark.skipif(not hasattr(os, "openpty"), reason="needs POSIX ptys")
def test_a_robot_run_logs_run_relative_times_and_camera_frames(tmp_path: Path) -> None:
    """The real-robot path (driver over a pseudo-terminal, a still image as the camera, the
    monotonic clock): safety events in run time, not the raw monotonic clock; frames saved."""
    from marknav.core.clock import MonotonicClock
    from marknav.sim.pty import PtyServer
    from marknav.sim.simulated_create import SimulatedCreate

    image = ROOT / "tests" / "data" / "smarties.png"
    with PtyServer(SimulatedCreate(clock=MonotonicClock())) as server:
        port = server.start()
        code = main(["run", str(SLALOM), "--robot", port, "--camera", str(image),
                     "--tree", "none", "--max-time", "1.5", "--frames", "4",
                     "--report", str(tmp_path / "r.json")])
    assert code == 1  # the time limit: the still image shows no slalom marks
    records = read_log(tmp_path / "r.events.jsonl")
    times = [r["t"] for r in records]
    # run-relative: seconds since the start, not the raw monotonic clock (the machine's uptime);
    # generous, because a loaded machine stretches a 1.5 s run's start and shutdown
    assert times == sorted(times) and times[-1] < 120.0
    safety = [r for r in records if r["kind"] == "safety"]
    assert safety and all(0.0 <= r["t"] <= times[-1] for r in safety)
    report = json.loads((tmp_path / "r.json").read_text())
    assert all(0.0 <= e["t"] <= times[-1] for e in report["safety_events"])
    ticks = [r for r in records if r["kind"] == "tick"]
    assert ticks and all("pose" in r and "truth" not in r for r in ticks)
    saved = [r["image"] for r in records if r["kind"] == "frame" and "image" in r]
    # 4 Hz: never more than the run's length allows (it asks for frames at most every 0.25 s)
    frame_times = [r["t"] for r in records if r["kind"] == "frame" and "image" in r]
    assert 1 <= len(saved) <= 4 * (frame_times[-1] - frame_times[0]) + 1.5
    assert (tmp_path / saved[0]).read_bytes()[:2] == b"\xff\xd8"


@pytest.mark.skipif(not hasattr(os, "openpty"), reason="needs POSIX ptys")
def test_interactive_replay_steps_jumps_and_quits_on_a_terminal(
        slalom_run: dict[str, Any]) -> None:
    import select
    import time

    replay = Replay(slalom_run["records"])
    master, slave = os.openpty()
    proc = subprocess.Popen(
        [sys.executable, "-m", "marknav", "replay", str(slalom_run["folder"]), "--tree",
         "ascii"], stdin=slave, stdout=slave, stderr=slave,
        env={**os.environ, "TERM": "xterm", "COLUMNS": "160", "LINES": "50"})
    os.close(slave)
    seen = b""

    def wait_for(text: str) -> None:
        nonlocal seen
        deadline = time.monotonic() + 60
        while text.encode() not in seen:
            assert time.monotonic() < deadline, f"no {text!r} in {seen[-500:]!r}"
            ready, _, _ = select.select([master], [], [], 0.2)
            if ready:
                seen += os.read(master, 65536)

    try:
        wait_for("replay: tick 0/")
        os.write(master, b"\n")  # one tick
        wait_for("replay: tick 1/")
        os.write(master, b"c\n")  # the next status change
        wait_for(f"replay: tick {replay.next_change(1)}/")
        os.write(master, b"j 14.2\n")
        k = replay.index_at(14.2)
        wait_for(f"t={replay.times[k]:.2f} s  tick {k}")
        os.write(master, b"q\n")
        assert proc.wait(timeout=30) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
        os.close(master)
