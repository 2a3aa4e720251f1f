"""``evaluate --set``: parsed and checked before any run, passed to every run, in the replay
command and the JSON (the hook only; the evaluation runner itself is tested elsewhere)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from marknav.cli.main import main
from marknav.runs.evaluation.evaluate import replay_command

SLALOM = Path(__file__).resolve().parents[3] / "missions" / "slalom.yaml"


def test_a_bad_setting_exits_2_before_any_run(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["evaluate", str(SLALOM), "--runs", "3", "--set",
                 "navigation.clearance_mm=-1"]) == 2
    err = capsys.readouterr().err
    assert err == ("marknav evaluate: error: --set navigation.clearance_mm=-1: "
                   "navigation.clearance_mm: Input should be greater than 0\n")
    assert main(["evaluate", "--accuracy", "--set", "camera.width=320"]) == 2
    assert "--set: does not apply with --accuracy" in capsys.readouterr().err


def test_every_run_uses_the_setting_and_the_replay_repeats_it(
    capsys: pytest.CaptureFixture[str]
) -> None:
    # 1 s of mission time cannot pass a mark: the run fails, and its replay command is shown.
    assert main(["evaluate", str(SLALOM), "--runs", "1", "--max-time", "1", "--min-success", "0",
                 "--json", "--set", "navigation.approach_speed_mm_s=120"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["overrides"] == ["navigation.approach_speed_mm_s=120"]
    [failure] = data["failures"]
    assert failure["replay"] == (f"marknav run {SLALOM} --world random --seed 0 --set "
                                 "navigation.approach_speed_mm_s=120 --max-time 1")
    assert replay_command("m.yaml", 4, None, ["route=[red, blue]"]) == (
        "marknav run m.yaml --world random --seed 4 --set 'route=[red, blue]'")
