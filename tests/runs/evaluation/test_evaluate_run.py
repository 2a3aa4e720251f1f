"""``marknav evaluate`` for real: a tiny mission in the simulator, in one and in two processes,
and the ``--accuracy`` experiment on a coarse grid."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from marknav.cli.main import main
from tests.tiny_mission import TINY


@pytest.fixture(scope="module")
def tiny(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("evaluate") / "tiny.yaml"
    path.write_text(yaml.safe_dump(TINY), encoding="utf-8")
    return path


def evaluate_json(argv: list[str], capsys: pytest.CaptureFixture[str],
                  min_success: str = "0") -> dict[str, object]:
    assert main(["evaluate", *argv, "--json", "--min-success", min_success]) == 0
    out: dict[str, object] = json.loads(capsys.readouterr().out)
    return out


@pytest.mark.slow
def test_runs_in_one_or_two_processes_give_the_same_results(
        tiny: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # The tiny mission passes its one mark on every seed: both runs must succeed (exit 0 at
    # --min-success 1), in one process and in two.
    one = evaluate_json([str(tiny), "--runs", "2", "--max-time", "30"], capsys, "1")
    two = evaluate_json([str(tiny), "--runs", "2", "--max-time", "30", "--jobs", "2"], capsys,
                        "1")
    for key in ("runs", "success_rate", "success_ci95", "collisions", "wrong_side",
                "min_clearance_mm", "clearance_p05_mm", "failures", "sim_time_s",
                "wall_time_s"):
        assert key in one, key
    assert one["runs"] == 2 and one["seeds"] == [0, 1]
    assert one["jobs"] == 1 and two["jobs"] == 2

    def per_seed(d: dict[str, object]) -> list[dict[str, object]]:
        results = d["results"]
        assert isinstance(results, list)
        return [{k: v for k, v in r.items() if k != "wall_time_s"} for r in results]

    assert per_seed(one) == per_seed(two)
    for key in ("success_rate", "collisions", "wrong_side", "min_clearance_mm", "failures",
                "sim_time_s"):
        assert one[key] == two[key], key
    # Every run is accounted for: a success, or a failure with its replay command.
    results = one["results"]
    failures = one["failures"]
    assert isinstance(results, list) and isinstance(failures, list)
    assert [r["seed"] for r in results if r["outcome"] != "success"] == [
        f["seed"] for f in failures]
    for f in failures:
        assert f["replay"] == f"marknav run {tiny} --world random --seed {f['seed']} --max-time 30"
    assert one["success_rate"] == 1.0 and failures == []
    assert one["collisions"] == 0 and one["wrong_side"] == 0
    for r in results:
        assert r["outcome"] == "success" and r["reason"] == "every waypoint passed"
        assert 0 < r["sim_time_s"] < 30.0  # done well before the time cap
        assert r["waypoints_passed"] == 1 and r["collisions"] == 0 and r["wrong_side"] == 0
        # clearance 300 mm planned (+ the drift margin); the true path keeps most of it
        assert r["min_clearance_mm"] > 270.0


def test_accuracy_table_and_plot(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    png = tmp_path / "acc.png"
    assert main(["evaluate", "--accuracy", "--grid", "coarse", "--frames", "2", "--json",
                 "--plot", str(png)]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["model"] == "pinhole f=590 px R=100 mm" and d["source"] == "default camera"
    assert [r["y_mm"] for r in d["rows"]] == [500.0, 1000.0, 2000.0, 3000.0]
    # x = ±300 mm at 500 mm projects 354 px off-centre: out of a 640 px image.
    assert [r["points"] for r in d["rows"]] == [1, 3, 3, 3]
    assert [r["frames"] for r in d["rows"]] == [2, 6, 6, 6]
    for row in d["rows"]:
        assert row["median_mm"] <= row["p95_mm"] <= row["max_mm"]
        assert row["median_rel"] < 0.05
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_accuracy_with_a_mission_uses_its_camera(tiny: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["evaluate", "--accuracy", str(tiny), "--grid", "coarse", "--frames",
                 "1"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith(f"Position error (paper eq. 40) against ground truth, {tiny}: "
                               "pinhole f=295 px R=100 mm, 1 frames per point, grid coarse")
    assert lines[1].split() == ["y", "mm", "points", "median", "mm", "p95", "mm", "max", "mm",
                                "median", "%", "missed"]
    assert [line.split()[:2] for line in lines[2:6]] == [
        ["500", "1"], ["1000", "3"], ["2000", "3"], ["3000", "3"]]
    assert lines[6].startswith("grid points not wholly in view (skipped): 2;")


def test_accuracy_bad_input(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["evaluate", "--accuracy", "--frames", "0"]) == 2
    assert capsys.readouterr().err == "marknav evaluate: error: --frames: must be at least 1, " \
                                      "got 0\n"
    assert main(["evaluate", "--accuracy", "--runs", "3"]) == 2
    assert "--runs: does not apply with --accuracy" in capsys.readouterr().err
