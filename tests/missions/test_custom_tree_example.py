"""The shipped custom-tree example (missions/pause-at-each-mark.yaml) runs in the simulator:
every waypoint passed on its side, and the robot stands still for the Pause after each one."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from marknav.runs.loop.checks import checked_mission
from marknav.runs.loop.run import RunRequest, execute, pass_times
from marknav.runs.loop.sim_environment import SimEnvironment

EXAMPLE = Path(__file__).resolve().parents[2] / "missions" / "pause-at-each-mark.yaml"


@pytest.mark.slow
def test_pause_at_each_mark_runs(tmp_path: Path) -> None:
    mission = checked_mission(EXAMPLE)
    assert mission.tree is not None
    waypoints = [c for c in mission.tree.children[3].children if c.type == "Waypoint"]
    assert [w.params["index"] for w in waypoints] == [0, 1, 2, 3]  # derived from the order

    result = execute(RunRequest(mission=mission, report_path=tmp_path / "report.json"))
    report = result.report
    assert report.outcome == "success", report.reason
    assert [w.outcome for w in report.waypoints] == ["passed"] * 4
    assert [w.passed_on for w in report.waypoints] == ["left", "right", "left", "left"]
    assert report.collisions == 0

    env = result.environment
    assert isinstance(env, SimEnvironment)
    times = pass_times(mission)
    assert all(t is not None for t in times)
    for i, t in enumerate(times):
        assert t is not None
        # stopped within the watchdog's 0.3 s, then still until the 2 s pause ends
        still = env.truth.trajectory(t + 0.35, t + 1.95)
        assert len(still) > 10
        moved = float(np.max(np.hypot(*(still - still[0]).T)))
        assert moved < 2.0, f"moved {moved:.1f} mm during the pause after t={t:.2f}"
        if i < len(times) - 1:  # and it moves on after the pause (the last one ends the run)
            after = env.truth.trajectory(t + 2.0, t + 4.0)
            assert math.dist(after[0], after[-1]) > 50.0
    assert report.sim_time_s > times[-1] + 2.0  # the last pause ran too
