"""``marknav bench recording``: size and speed ratios of a short recorded run."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("mcap_ros2")
pytest.importorskip("foxglove")


@pytest.mark.slow
def test_the_recording_bench_prints_sizes_and_ratios(capsys: pytest.CaptureFixture[str]) -> None:
    from marknav.cli.main import main

    assert main(["bench", "recording", "--quick", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)["recording"]
    assert out["repeats"] == 1 and out["sim_time_s"] == pytest.approx(5.0, abs=0.051)
    assert 0.05 < out["record"]["mcap_mb"] < 2.0  # 5 s: 25 images of ~20 kB and the rest
    assert out["record"]["metadata_bytes"] > 0
    assert out["foxglove"]["client"]["messages"] > 100  # every channel, 5 s at 20 Hz
    for setup in ("record", "foxglove"):
        ratios = out[f"{setup}_over_plain"]
        assert set(ratios) == {"wall_s", "loop_cpu_s", "loop_thread_cpu_s", "cycle_ms_p50",
                                "loop_cpu_s_least"}
        assert out[setup]["recording_cpu_s"] > 0  # the recording's own process did the work
        assert 0 < out[setup]["handover_share_of_loop_cpu"] < 0.5
        assert ratios["loop_cpu_s_least"] == ratios["loop_cpu_s"]  # one repeat: the same run
        for key, value in ratios.items():
            if key == "loop_cpu_s_least":
                continue
            assert value == pytest.approx(out[setup][key] / out["plain"][key], rel=0.01)
