"""The Dask throughput benchmark: real local clusters of one and two workers evaluate the same
seeds (issue 16). No timing assertions: the machine is shared."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from tests.tiny_mission import TINY

pytest.importorskip("distributed")



@pytest.mark.slow
def test_one_and_two_workers_evaluate_the_same_seeds(tmp_path: Path) -> None:
    from marknav.runs.benchmarks.cluster import bench_dask

    mission = tmp_path / "tiny.yaml"
    mission.write_text(yaml.safe_dump(TINY), encoding="utf-8")
    out = bench_dask(mission=mission, runs=3, seed=7, max_time_s=2.0, workers=(1, 2))
    assert (out["mission"], out["runs"], out["seeds"]) == ("tiny.yaml", 3, "7-9")
    assert [c["workers"] for c in out["clusters"]] == [1, 2]
    for c in out["clusters"]:
        assert len(c["worker_cpu_s"]) == c["workers"]
        assert c["evaluation_s"] > 0 and c["start_s"] > 0 and c["warmup_s"] > 0
        assert c["runs_per_min"] == pytest.approx(60.0 * 3 / c["evaluation_s"], rel=0.02)
        assert c["cpu_s_per_run"] > 0  # the runs' CPU time was counted in the workers
        assert c["scheduler_client_cpu_s"] >= 0
    assert out["identical"] is True
    assert out["speedup_2_vs_1"] == pytest.approx(
        out["clusters"][0]["evaluation_s"] / out["clusters"][1]["evaluation_s"], rel=0.02)


def test_bad_sizes_are_refused() -> None:
    from marknav.runs.benchmarks.cluster import bench_dask

    with pytest.raises(ValueError):
        bench_dask(runs=0)
    with pytest.raises(ValueError):
        bench_dask(workers=(0,))
