"""The paper's Table 1 calibration reproduced in the simulator (marknav.sim.calibration)."""

from __future__ import annotations

import json

import pytest

from marknav.cli.main import main
from marknav.sim.builtin_camera import CameraConfig
from marknav.sim.calibration import TABLE1_DISTANCES_MM, sim_calibration_fit, sim_calibration_table
from marknav.sim.world import Conditions
from marknav.vision.calibrate import fit_power_law


def test_table_has_the_papers_distances_and_pinhole_radii() -> None:
    rows = sim_calibration_table()
    assert [d for _, d in rows] == list(TABLE1_DISTANCES_MM)
    assert TABLE1_DISTANCES_MM[0] == 2000.0 and TABLE1_DISTANCES_MM[-1] == 300.0
    assert len(rows) == 18
    for r, d in rows:
        assert r == pytest.approx(590.0 * 100.0 / d, abs=0.5)  # eq. 2, as measured


def test_fitted_law_is_within_two_percent() -> None:
    fit = sim_calibration_fit()
    assert fit.max_rel_error <= 0.02
    assert fit.b == pytest.approx(-1.0, abs=0.02)  # a pinhole camera: d ∝ 1/r
    assert fit.model.distance_mm(59.0) == pytest.approx(1000.0, rel=0.01)


def test_calibration_follows_the_camera_and_conditions() -> None:
    cam = CameraConfig(width=320, height=240, focal_px=295.0)
    rows = sim_calibration_table(camera=cam, distances_mm=[1500.0, 1000.0, 500.0],
                                 conditions=Conditions(noise_sigma=4.0, blur_sigma_px=0.8),
                                 frames=3)
    for r, d in rows:
        assert r == pytest.approx(295.0 * 100.0 / d, rel=0.02)
    fit = fit_power_law([r for r, _ in rows], [d for _, d in rows])
    assert fit.max_rel_error <= 0.02


def test_cli_calibrate_sim_prints_the_usual_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["calibrate", "--sim", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out) == {"model", "a", "b", "r2", "max_rel_error", "rows"}
    assert out["model"] == "power" and out["max_rel_error"] <= 0.02
    assert [row["distance_mm"] for row in out["rows"]] == list(TABLE1_DISTANCES_MM)


def test_cli_calibrate_needs_a_table_or_sim(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["calibrate"]) == 2
    assert "give either a TABLE.csv or --sim" in capsys.readouterr().err
