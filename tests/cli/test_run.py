"""``marknav run`` end to end in the simulator: success, report, tree view, bad input, limits
and interruption (Ctrl-C / SIGTERM stop the wheels and still write the report)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from marknav.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
SLALOM = ROOT / "missions" / "slalom.yaml"


@pytest.mark.slow
def test_slalom_completes_with_report_tree_and_plot(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    report_path = tmp_path / "report.json"
    plot = tmp_path / "run.png"
    code = main(["run", str(SLALOM), "--report", str(report_path), "--plot", str(plot)])
    out = capsys.readouterr().out
    assert code == 0, out[-2000:]
    report = json.loads(report_path.read_text())
    assert report["outcome"] == "success"
    assert report["collisions"] == 0
    assert [w["outcome"] for w in report["waypoints"]] == ["passed"] * 4
    for w in report["waypoints"]:
        assert w["passed_on"] == w["side"], w
        assert w["min_clearance_mm"] >= 300 - 50, w
    assert report["ticks"] > 100
    assert set(report["tick_ms"]) == {"p50", "p99", "max"}
    assert report["sim_final"] == {"wheels_mm_s": [0, 0], "oi_mode": "passive", "stream": False}
    # Not a terminal: the compact tree is printed when a status changes, not every tick, with
    # the status line under it; finished waypoints are folded to one line with their result.
    prints = out.count("▶ → Mission\n")
    assert 5 < prints < report["ticks"]
    assert "✔ ? Waypoint 1: red (pass on its left) ▸ — passed red #1 on its left" in out
    assert "safety driving" in out
    screens = out.split("\n\n")
    assert max(len(s.splitlines()) for s in screens if "Mission" in s) <= 26
    assert "[o]" not in out and "[-]" not in out  # py_trees' symbols are not used
    assert "slalom: success — every waypoint passed (4/4 waypoints, 0 collisions" in out
    events = [json.loads(line) for line in
              (tmp_path / "report.events.jsonl").read_text().splitlines()]
    assert events[0]["kind"] == "start" and events[-1]["kind"] == "end"
    assert events[-1]["outcome"] == "success"
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_time_limit_fails_with_exit_1(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    report_path = tmp_path / "r.json"
    code = main(["run", str(SLALOM), "--tree", "none", "--max-time", "2",
                 "--report", str(report_path)])
    err = capsys.readouterr().err
    assert code == 1
    assert "marknav run: failed: time limit: 2 s" in err
    report = json.loads(report_path.read_text())
    assert (report["outcome"], report["reason"]) == ("failed", "time limit: 2 s")
    assert report["waypoints"][0]["outcome"] == "failed"
    assert report["sim_final"]["wheels_mm_s"] == [0, 0]


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["run", "nope.yaml"], "nope.yaml: no such file"),
        (["run", str(SLALOM), "--robot", "/dev/ttyUSB0"], "--camera: --camera sim needs --robot"),
        (["run", str(SLALOM), "--camera", "0"], "--camera: --camera must be 'sim' with --robot"),
        (["run", str(SLALOM), "--max-time", "-1"], "--max-time: must be positive, got -1.0"),
        (["run", str(SLALOM), "--world", "missing-world.yaml"],
         "missing-world.yaml: no such file"),
    ],
)
def test_bad_input_exits_2(argv: list[str], message: str,
                           capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err
    assert "Traceback" not in err


def test_invalid_mission_names_file_line_and_field(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nroute: [red, purple]\nmarks:\n  radius_mm: 100\n  colours:\n"
                   "    red: {hue: [170, 10], side: left}\n")
    assert main(["run", str(bad)]) == 2
    err = capsys.readouterr().err
    assert f"{bad}:2:14: route[1]:" in err
    assert "purple" in err


def test_unreachable_robot_port_exits_2_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    image = ROOT / "tests" / "data" / "smarties.png"
    port = str(tmp_path / "no-such-tty")
    assert main(["run", str(SLALOM), "--robot", port, "--camera", str(image)]) == 2
    err = capsys.readouterr().err
    assert port in err
    assert "Traceback" not in err


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_interrupt_stops_the_wheels_and_writes_the_report(tmp_path: Path, sig: int) -> None:
    report_path = tmp_path / "r.json"
    events_path = tmp_path / "r.events.jsonl"
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "marknav", "run", str(SLALOM), "--realtime", "--tree", "none",
         "--report", str(report_path)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
    )
    try:
        deadline = time.monotonic() + 60
        # Wait until the robot is moving (a status line in the event log), then interrupt.
        while time.monotonic() < deadline:
            if events_path.exists() and '"kind": "status"' in events_path.read_text():
                break
            time.sleep(0.05)
        time.sleep(1.0)
        proc.send_signal(sig)
        _out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    assert "wheels stopped" in err
    # one line says it (the command's, with what was written), not a second generic one
    assert [line for line in err.splitlines() if "interrupted" in line] == [
        next(line for line in err.splitlines() if line.startswith("marknav run: interrupted"))]
    report = json.loads(report_path.read_text())
    assert report["outcome"] == "aborted"
    assert report["reason"].startswith("interrupted")
    assert report["sim_final"] == {"wheels_mm_s": [0, 0], "oi_mode": "passive", "stream": False}
    assert events_path.read_text().splitlines()[-1].startswith('{"t"')
    records = [json.loads(line) for line in events_path.read_text().splitlines()]
    # The run log ends with the abort: the last tick, the wheels' stop, the report, the end.
    kinds = [r["kind"] for r in records]
    last_tick = max(i for i, k in enumerate(kinds) if k == "tick")
    assert kinds[-2:] == ["report", "end"]
    assert set(kinds[last_tick + 1:-2]) == {"safety"}
    assert records[-3]["event"] == "stop"
    assert records[-1]["outcome"] == "aborted"
    assert records[-1]["reason"].startswith("interrupted")
    assert records[-2]["report"]["outcome"] == "aborted"
    assert records[-1]["ticks"] == records[last_tick]["n"] + 1 == report["ticks"]
