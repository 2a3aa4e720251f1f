"""Position accuracy against ground truth: the paper's Fig. 13 in the simulator."""

from __future__ import annotations

import pytest

from marknav.runs.metrics.position_accuracy import accuracy_table
from marknav.sim.calibration import sim_calibration_fit
from marknav.sim.world import Conditions
from marknav.vision.estimate import PowerLaw

XS = (-600.0, 0.0, 600.0)
YS = (500.0, 1000.0, 2000.0, 3000.0)


def test_default_conditions_meet_the_targets_with_the_pinhole_model() -> None:
    table = accuracy_table(xs_mm=XS, ys_mm=YS, frames=4, seed=1)
    assert table.model == "pinhole f=590 px R=100 mm"
    assert [r.y_mm for r in table.rows] == list(YS)
    # x = ±600 mm is out of view at 500 and 1000 mm (u = 319.5 ± 708 / ± 354 px).
    assert [r.skipped for r in table.rows] == [2, 2, 0, 0]
    assert [r.points for r in table.rows] == [1, 1, 3, 3]
    assert [r.frames for r in table.rows] == [4, 4, 12, 12]
    assert table.skipped == 4 and table.missed == 0
    for row in table.rows:
        limit = 0.02 if row.y_mm <= 2000 else 0.05
        assert row.median_rel <= limit, row
        assert row.median_mm <= row.p95_mm <= row.max_mm
    assert table.to_dict()["rows"][0]["y_mm"] == 500.0


def test_the_sim_calibrations_law_also_meets_them_under_harder_conditions() -> None:
    law = sim_calibration_fit().model
    table = accuracy_table(xs_mm=(-300.0, 300.0), ys_mm=(1500.0, 3000.0), frames=4, model=law,
                           conditions=Conditions(noise_sigma=5.0, blur_sigma_px=1.0,
                                                 lighting_gain=0.7), seed=2)
    assert table.model.startswith("power a=")
    assert table.rows[0].median_rel <= 0.02
    assert table.rows[1].median_rel <= 0.05


def test_a_wrong_range_law_shows_up_as_error() -> None:
    # The paper's own camera law (eq. 19) does not fit the simulated f = 590 px camera.
    table = accuracy_table(xs_mm=(0.0,), ys_mm=(1000.0, 2000.0), frames=2,
                           model=PowerLaw(58958.0, -0.9434))
    for row in table.rows:
        assert row.median_rel > 0.1


def test_bad_frame_count() -> None:
    with pytest.raises(ValueError):
        accuracy_table(frames=0)
