"""The online range-law learner (marknav.vision.range_learning) on synthetic approaches."""

from __future__ import annotations

import math

import numpy as np
import pytest

from marknav.vision.estimate import PowerLaw
from marknav.vision.range_learning import RangeLawLearner

TRUE = PowerLaw(59752.0, -1.00242)


def _rel_error(law: PowerLaw, distance_mm: float) -> float:
    return law.distance_mm(TRUE.radius_px(distance_mm)) / distance_mm - 1.0


def _approach(learner: RangeLawLearner, *, mark: tuple[float, float] = (150.0, 2600.0),
              start: float = 0.0, stop: float = 1700.0, step: float = 12.5,
              noise_px: float = 0.25, seed: int = 0, colour: str = "red",
              jump_at: float | None = None) -> list[float]:
    """Drive along +y toward ``mark`` (robot heading +y), one sighting per ``step`` mm;
    ``jump_at``: from there on the odometry is 300 mm off (a bump that moved the robot)."""
    rng = np.random.default_rng(seed)
    th = math.pi / 2
    errors = []
    for y in np.arange(start, stop, step):
        fwd, left = mark[1] - y, -(mark[0] - 0.0)
        r = TRUE.radius_px(fwd) + rng.normal(0.0, noise_px)
        odo_y = y + (300.0 if jump_at is not None and y >= jump_at else 0.0)
        learner.add(colour, (0.0, float(odo_y), th), r, left + rng.normal(0.0, 3.0))
        learner.update()
        errors.append(_rel_error(learner.law, 1000.0))
    return errors


@pytest.mark.parametrize("prior", [PowerLaw(58958.0, -0.9434),  # the paper's eq. 19
                                   PowerLaw(0.75 * 59752.0, -1.00242),
                                   PowerLaw(1.25 * 59752.0, -1.00242)],
                         ids=["paper", "minus25", "plus25"])
def test_a_law_25_percent_off_is_learnt_on_one_approach(prior: PowerLaw) -> None:
    learner = RangeLawLearner(prior=prior)
    assert abs(_rel_error(learner.law, 1000.0)) > 0.15
    errors = _approach(learner)
    assert learner.steps, "no fit accepted"
    # One approach from 2.6 m to 0.9 m: from 25 % off to within 5 % (the exponent is still
    # uncertain from one approach; the second mark pins it, see below).
    assert abs(errors[-1]) < 0.05
    for d in (800.0, 1500.0, 2200.0):
        assert abs(_rel_error(learner.law, d)) < 0.06
    assert learner.rejected == 0
    step = learner.steps[-1]
    assert step.fit.samples > 60 and step.fit.marks == 1 and step.fit.chi < 2.0
    assert step.sigma_scale < 0.5 * learner.prior_sigma_scale  # conservative: chi < 1


def test_second_mark_sharpens_the_exponent() -> None:
    learner = RangeLawLearner(prior=PowerLaw(58958.0, -0.9434))
    _approach(learner)
    _approach(learner, mark=(-200.0, 5200.0), start=2600.0, stop=4400.0, colour="green",
              seed=1)
    assert learner.law.b == pytest.approx(TRUE.b, abs=0.03)
    assert max(abs(_rel_error(learner.law, d)) for d in (600, 1000, 2000, 2500)) < 0.02


def test_scale_only_keeps_the_exponent() -> None:
    learner = RangeLawLearner(prior=PowerLaw(0.8 * 59752.0, -1.00242), learn_exponent=False)
    _approach(learner)
    assert learner.law.b == pytest.approx(-1.00242, abs=1e-4)
    assert abs(_rel_error(learner.law, 1000.0)) < 0.02


def test_standing_still_teaches_nothing() -> None:
    learner = RangeLawLearner(prior=PowerLaw(1.25 * 59752.0, -1.00242))
    th = math.pi / 2
    for _ in range(300):
        learner.add("red", (0.0, 0.0, th), TRUE.radius_px(1500.0), 0.0)
        assert learner.update() is None
    assert not learner.steps
    assert learner.law.a == pytest.approx(learner.prior.a) and learner.law.b == learner.prior.b


def test_a_bump_is_not_taken_for_a_range_error() -> None:
    # Odometry jumps 300 mm mid-approach. Without the interrupt the jump would be "explained"
    # by a wrong law; with it, sightings after the bump are a new mark.
    guarded = RangeLawLearner(prior=PowerLaw(59752.0, -1.00242))
    rng_errors = []
    th = math.pi / 2
    rng = np.random.default_rng(3)
    for y in np.arange(0.0, 1700.0, 12.5):
        if y == 800.0:
            guarded.interrupt()
        odo_y = y + (300.0 if y >= 800.0 else 0.0)
        r = TRUE.radius_px(2600.0 - y) + rng.normal(0.0, 0.25)
        guarded.add("red", (0.0, odo_y, th), r, -150.0)
        guarded.update()
        rng_errors.append(abs(_rel_error(guarded.law, 1000.0)))
    assert max(rng_errors) < 0.03
    unguarded = RangeLawLearner(prior=PowerLaw(59752.0, -1.00242))
    _approach(unguarded, jump_at=800.0)
    # Without it the jump makes the sightings disagree: the fit is rejected, or too scattered
    # (χ > 1 widens its σ) to replace the law, or it moves the law more than the guarded one.
    assert (unguarded.rejected > 0 or not unguarded.steps
            or abs(_rel_error(unguarded.law, 1000.0)) > max(rng_errors))


def test_far_and_too_near_sightings_are_ignored() -> None:
    learner = RangeLawLearner(prior=TRUE)
    learner.add("red", (0.0, 0.0, 0.0), TRUE.radius_px(4000.0), 0.0)
    learner.add("red", (0.0, 0.0, 0.0), TRUE.radius_px(150.0), 0.0)
    learner.add("red", (0.0, 0.0, 0.0), float("nan"), 0.0)
    assert learner.samples == 0
    learner.add("red", (0.0, 0.0, 0.0), TRUE.radius_px(1500.0), 0.0)
    assert learner.samples == 1


def _corridor(learner: RangeLawLearner, *, excess_px: float, seed: int = 0) -> list[float]:
    """Six marks down a corridor, each approached from 3 m to 0.9 m. The radius reads up to
    ``excess_px`` large below 29 px (beyond ~2 m): what the simulator's detector does through
    a webcam lens (long course, seed 5: +1-2 px at 21-27 px)."""
    rng = np.random.default_rng(seed)
    th = math.pi / 2
    errors = []
    for k in range(6):
        mark = (150.0 * (-1) ** k, 3000.0 + 2500.0 * k)
        for y in np.arange(2500.0 * k, 2500.0 * k + 2100.0, 12.5):
            r = TRUE.radius_px(mark[1] - y)
            r += excess_px * min(max((29.0 - r) / 5.0, 0.0), 1.0) + rng.normal(0.0, 0.25)
            learner.add("red" if k % 2 else "green", (0.0, float(y), th), r,
                        -mark[0] + rng.normal(0.0, 3.0))
            learner.update()
            errors.append(_rel_error(learner.law, 1000.0))
    return errors


def test_small_marks_do_not_pull_a_correct_law() -> None:
    # Started from the true law: a radius bias that grows with range is what a steeper law
    # explains, so without the guard the law drifts (the long course's 16 % short at 1 m).
    unguarded = _corridor(RangeLawLearner(prior=TRUE), excess_px=2.0)
    assert abs(unguarded[-1]) > 0.1
    guarded = _corridor(RangeLawLearner(prior=TRUE, min_radius_px=29.0), excess_px=2.0)
    # (one approach pins the law's slope over its radii better than its scale: the first fits
    # move a correct law by up to ~5 %)
    assert max(abs(e) for e in guarded) < 0.06
    assert abs(guarded[-1]) < 0.04


def test_small_and_off_axis_marks_are_not_added() -> None:
    learner = RangeLawLearner(prior=TRUE, min_radius_px=29.0)
    learner.add("red", (0.0, 0.0, 0.0), TRUE.radius_px(2200.0), 0.0)  # 27 px
    learner.add("red", (0.0, 0.0, 0.0), TRUE.radius_px(1200.0),
                1200.0 * math.tan(0.25))  # 0.25 rad off the axis
    assert learner.samples == 0
    learner.add("red", (0.0, 0.0, 0.0), TRUE.radius_px(1200.0), 1200.0 * math.tan(0.15))
    assert learner.samples == 1


def test_a_short_approach_learns_the_scale_only() -> None:
    # Small marks reach the radius floor only near the bypass distance: an approach from
    # 1.45 m to 1.2 m (ln r spreads 0.19, under min_log_spread) still learns the scale, and
    # holds the exponent it cannot pin.
    learner = RangeLawLearner(prior=PowerLaw(0.75 * 59752.0, -1.00242))
    errors = _approach(learner, start=1200.0, stop=1450.0, step=10.0)
    assert learner.steps and learner.rejected == 0
    assert learner.law.b == pytest.approx(-1.00242, abs=1e-4)
    assert abs(errors[-1]) < 0.05
