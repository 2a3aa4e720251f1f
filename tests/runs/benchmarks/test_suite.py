"""The tree, loop and safety benchmarks run with tiny sizes and report their keys (no timing
assertions: the machine is shared)."""

from __future__ import annotations

import pytest

from marknav.runs.benchmarks.suite import bench_loop, bench_safety, bench_tree
from marknav.testing import make_mission


def test_tree_bench_times_the_requested_ticks() -> None:
    out = bench_tree(waypoints=6, ticks=30, slalom_ticks=20, warmup=3)
    assert set(out) == {"waypoints", "ticks", "waypoints_passed", "tick_us_p50", "tick_us_p99",
                        "tick_us_max", "tick_cpu_us_p50", "tick_cpu_us_p99", "slalom_ticks",
                        "slalom_waypoints_passed", "slalom_tick_us_p50", "slalom_tick_us_p99"}
    assert out["waypoints"] == 6 and out["ticks"] == 30 and out["slalom_ticks"] == 20
    # 33 ticks of 50 ms: the robot is still approaching its first mark.
    assert out["waypoints_passed"] == 0
    assert 0 < out["tick_us_p50"] <= out["tick_us_p99"] <= out["tick_us_max"]
    assert 0 < out["slalom_tick_us_p50"] <= out["slalom_tick_us_p99"]
    assert 0 < out["tick_cpu_us_p50"] <= out["tick_cpu_us_p99"]


def test_tree_bench_stops_when_the_route_is_done() -> None:
    out = bench_tree(waypoints=1, ticks=5000, slalom_ticks=10, warmup=0)
    assert out["waypoints_passed"] == 1
    assert out["ticks"] < 5000  # ended with the route, not at the tick budget


def test_loop_bench_runs_the_simulator_to_the_time_cap() -> None:
    mission = make_mission(name="tiny", route=["red"],
                           camera={"width": 320, "height": 240, "focal_px": 295,
                                   "range": {"model": "pinhole", "focal_px": 295}})
    out = bench_loop(mission=mission, max_time_s=0.5, seed=3)
    assert out["mission"] == "tiny" and (out["width"], out["height"]) == (320, 240)
    assert out["outcome"] == "failed"  # the time cap, half a second into the approach
    assert out["sim_time_s"] == pytest.approx(0.5, abs=0.051)
    assert out["cycles"] == 11  # t = 0, 0.05, ..., 0.5 at 20 Hz
    assert out["speedup"] > 0
    # The CPU-time speed-up is simulated time over the process's CPU time (both rounded to
    # 0.01 s in the output, a large share of a 0.5 s run's tenths of a second).
    assert out["cpu_time_s"] > 0
    assert out["speedup_cpu"] == pytest.approx(out["sim_time_s"] / out["cpu_time_s"], rel=0.2)
    assert 0 < out["cycle_ms_p50"] <= out["cycle_ms_p99"] <= out["cycle_ms_max"]
    # An overrun is a cycle longer than the 50 ms period: the count agrees with the cycle times
    # (whatever this shared machine's speed today; 1 µs slack for the report's rounding).
    assert 0 <= out["overruns"] <= out["cycles"]
    if out["cycle_ms_max"] < 50.0 - 1e-3:
        assert out["overruns"] == 0
    if out["cycle_ms_max"] > 50.0 + 1e-3:
        assert out["overruns"] >= 1
    if out["cycle_ms_p50"] > 50.0 + 1e-3:
        assert out["overruns"] >= (out["cycles"] + 1) // 2
    # Where the wall time went, ms per cycle: every part was timed (each method exists), the
    # parts are positive and add up to the run's wall time (rounding: 1 µs each).
    parts = out["breakdown_ms_per_cycle"]
    assert list(parts) == ["detector", "render", "tick_other", "simulation", "other", "total"]
    assert all(parts[k] > 0 for k in ("detector", "render", "tick_other", "simulation"))
    # (the report's wall time is rounded to 10 ms: half of that spread over the cycles)
    assert parts["total"] == pytest.approx(out["wall_time_s"] * 1e3 / out["cycles"],
                                           abs=5.0 / out["cycles"] + 1e-3)
    assert sum(parts[k] for k in ("detector", "render", "tick_other", "simulation", "other")) \
        == pytest.approx(parts["total"], abs=0.01)
    assert parts["other"] >= 0 and parts["detector"] + parts["render"] < parts["total"]


def test_loop_bench_times_its_parts_only_while_it_runs() -> None:
    from marknav.sim.builtin_camera import Renderer

    before = Renderer.render
    bench_loop(mission=make_mission(name="tiny", route=["red"]), max_time_s=0.1, seed=3)
    assert Renderer.render is before  # the timing wrappers are gone again


def test_safety_bench_measures_both_paths() -> None:
    out = bench_safety(n=20, e2e_n=5)
    assert out["n"] == 20 and out["e2e_n"] == 5
    assert 0 < out["bump_to_stop_ms_p50"] <= out["bump_to_stop_ms_p99"] <= out["max_ms"]
    assert 0 < out["bump_to_stop_e2e_ms_p50"] <= out["bump_to_stop_e2e_ms_p99"] <= out["max_ms"]
    assert out["stream_period_ms"] == 15.0
    assert out["within_one_period"] == (out["max_ms"] < 15.0)


@pytest.mark.parametrize("kwargs", [{"n": 0}, {"e2e_n": 0}])
def test_safety_bench_needs_one_bump(kwargs: dict[str, int]) -> None:
    with pytest.raises(ValueError):
        bench_safety(**kwargs)


def test_loop_and_tree_bench_bad_sizes() -> None:
    with pytest.raises(ValueError):
        bench_loop(max_time_s=0)
    with pytest.raises(ValueError):
        bench_tree(waypoints=0)


# ------------------------------------------------------------------------------ marknav bench


@pytest.mark.slow
def test_bench_all_prints_one_json_object_with_machine_once(
        capsys: pytest.CaptureFixture[str]) -> None:
    import json

    from marknav.cli.main import main

    assert main(["bench", "all", "--quick", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert list(out) == ["machine", "vision", "tree", "loop", "safety", "render"]
    for key in ("cpu", "cores", "python", "numpy", "opencv"):
        assert key in out["machine"], key
    assert all("machine" not in section for name, section in out.items() if name != "machine")
    assert out["tree"]["waypoints"] == 50 and "slalom_tick_us_p50" in out["tree"]
    for key in ("speedup", "cycle_ms_p50", "cycle_ms_p99", "cycle_ms_max", "overruns",
                "sim_time_s"):
        assert key in out["loop"], key
    assert out["loop"]["sim_time_s"] == pytest.approx(5.0, abs=0.051)
    for key in ("bump_to_stop_ms_p50", "bump_to_stop_ms_p99", "n", "bump_to_stop_e2e_ms_p50",
                "bump_to_stop_e2e_ms_p99"):
        assert key in out["safety"], key
    assert out["render"]["frames"] == 20 and out["render"]["frame_ms_p50"] > 0


def test_bench_one_section_as_text(capsys: pytest.CaptureFixture[str]) -> None:
    from marknav.cli.main import main

    assert main(["bench", "safety", "--quick"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "machine:"
    assert "safety:" in lines and "  n: 200" in lines and "  e2e_n: 50" in lines
    assert not any(line in ("tree:", "loop:", "vision:") for line in lines)


def test_bench_unknown_section_is_a_usage_error() -> None:
    from marknav.cli.main import main

    with pytest.raises(SystemExit) as exc:
        main(["bench", "nope"])
    assert exc.value.code == 2


def test_bench_profile_prints_the_top_costs(capsys: pytest.CaptureFixture[str]) -> None:
    import json

    from marknav.cli.main import main

    assert main(["bench", "safety", "--quick", "--json", "--profile", "4"]) == 0
    captured = capsys.readouterr()
    assert "safety" in json.loads(captured.out)  # stdout stays one JSON object
    err = captured.err.splitlines()
    own = err.index("top 4 by own time:")
    cum = err.index("top 4 by cumulative time:")
    assert cum - own == 6  # header + 4 rows
    assert any("marknav/runs/benchmarks/suite.py" in line for line in err[cum:])
    assert main(["bench", "safety", "--quick", "--profile", "0"]) == 2
