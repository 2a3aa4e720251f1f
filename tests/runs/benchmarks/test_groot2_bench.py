"""``marknav bench groot2``: three arms of a short simulated slalom, the client's replies
counted, the server's CPU read from its own thread, the tick split by the client's phases."""

from __future__ import annotations

import pytest

pytest.importorskip("zmq")


@pytest.mark.slow
def test_the_groot2_bench_measures_server_and_loop() -> None:
    from marknav.runs.benchmarks.groot2 import bench_groot2

    out = bench_groot2(max_time_s=4.0, repeats=1)
    assert out["replies_hz"] > 10  # the client was answered while the loop ran
    assert out["server_cpu_ms_per_request"] > 0
    for arm in ("no_server", "server", "polled"):
        assert out[f"loop_cpu_ms_per_cycle_{arm}"] > 0
    assert out["tick_ms_polling"] is not None and out["tick_ms_silent"] is not None
    assert out["slowdown_bound_at_rate"] == pytest.approx(
        out["server_cpu_ms_per_cycle_at_rate"] / out["loop_cpu_ms_per_cycle_polled"], rel=0.01)
