"""Quadratic Bézier primitives (eq. 22/23): the closest-point cubic against dense sampling (an
oracle used only here), curvature, length and arc-length sampling."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from marknav.planning.bezier import (
    QuadraticBezier,
    closest_point,
    min_distance,
    sample_curves,
)

coord = st.floats(-2000, 2000)
point = st.tuples(coord, coord)


def dense_min_distance(
    curve: QuadraticBezier, p: tuple[float, float], n: int
) -> tuple[float, float]:
    """Oracle: the minimum over n samples, and an upper bound of what sampling can overshoot."""
    pts = curve.points(np.linspace(0.0, 1.0, n))
    d = np.hypot(pts[:, 0] - p[0], pts[:, 1] - p[1])
    gap = float(np.max(np.hypot(*np.diff(pts, axis=0).T)))
    return float(d.min()), 0.5 * gap


def test_points_and_derivative() -> None:
    c = QuadraticBezier((0.0, 0.0), (100.0, 0.0), (100.0, 100.0))
    assert c.point(0.0) == (0.0, 0.0)
    assert c.point(1.0) == (100.0, 100.0)
    assert c.point(0.5) == (75.0, 25.0)  # 0.25·P0 + 0.5·P1 + 0.25·P2
    assert c.derivative(0.0) == (200.0, 0.0)  # 2(P1 − P0)
    assert c.derivative(1.0) == (0.0, 200.0)  # 2(P2 − P1)
    np.testing.assert_allclose(c.points([0.0, 0.5, 1.0]), [[0, 0], [75, 25], [100, 100]])


@settings(max_examples=300)
@given(point, point, point, point)
def test_closest_point_matches_dense_sampling(p0: tuple[float, float], p1: tuple[float, float],
                                              p2: tuple[float, float],
                                              m: tuple[float, float]) -> None:
    curve = QuadraticBezier(p0, p1, p2)
    cp = closest_point(curve, m)
    sampled, overshoot = dense_min_distance(curve, m, 20001)
    # exact is never above what any sample achieves, and sampling can only overshoot by half a gap
    assert cp.distance <= sampled + 1e-9
    assert cp.distance >= sampled - overshoot - 1e-9
    assert 0.0 <= cp.t <= 1.0
    assert cp.point == pytest.approx(curve.point(cp.t), abs=1e-9)
    assert math.dist(cp.point, m) == pytest.approx(cp.distance, abs=1e-9)


def test_closest_point_interior_root() -> None:
    # The parabola y = x²/200 (vertex at the origin) from x = -100 to 100, and M = (0, 130):
    # d/dx [x² + (x²/200 − 130)²] = 0 gives x² = 6000 besides x = 0, so the nearest points are
    # (±77.46, 30) at distance sqrt(6000 + 100²) = sqrt(16000), not the vertex (130 away).
    curve = QuadraticBezier((-100.0, 50.0), (0.0, -50.0), (100.0, 50.0))
    cp = closest_point(curve, (0.0, 130.0))
    assert cp.distance == pytest.approx(math.sqrt(16000.0), rel=1e-12)
    assert abs(cp.point[0]) == pytest.approx(math.sqrt(6000.0), rel=1e-9)
    assert cp.point[1] == pytest.approx(30.0, rel=1e-9)


def test_straight_segment_b_zero() -> None:
    # P1 the midpoint: B = 0, a uniformly parametrised segment.
    seg = QuadraticBezier((0.0, 0.0), (50.0, 0.0), (100.0, 0.0))
    cp = closest_point(seg, (30.0, 40.0))
    assert cp.t == pytest.approx(0.3)
    assert cp.distance == pytest.approx(40.0)
    assert closest_point(seg, (130.0, 40.0)).distance == pytest.approx(50.0)  # beyond the end
    assert closest_point(seg, (-30.0, -40.0)).distance == pytest.approx(50.0)  # before the start


def test_collinear_backtracking_curve() -> None:
    # P1 beyond P2 on one line: the curve goes out to x = 66.67 and comes back to 50.
    c = QuadraticBezier((0.0, 0.0), (100.0, 0.0), (50.0, 0.0))
    assert closest_point(c, (90.0, 0.0)).distance == pytest.approx(90.0 - 200.0 / 3.0, abs=1e-9)
    assert closest_point(c, (60.0, 10.0)).distance == pytest.approx(10.0, abs=1e-9)


def test_degenerate_single_point() -> None:
    c = QuadraticBezier((5.0, 5.0), (5.0, 5.0), (5.0, 5.0))
    assert closest_point(c, (8.0, 9.0)).distance == pytest.approx(5.0)


def test_min_distance_over_a_chain() -> None:
    a = QuadraticBezier((0.0, 0.0), (50.0, 0.0), (100.0, 0.0))
    b = QuadraticBezier((100.0, 0.0), (150.0, 0.0), (200.0, 0.0))
    assert min_distance([a, b], (170.0, 30.0)) == pytest.approx(30.0)


def exact_peak_curvature(curve: QuadraticBezier) -> tuple[float, float] | None:
    """Oracle, in exact rational arithmetic: the largest |κ| over t ∈ [0, 1], and the rounding
    a float computation of it cannot avoid (the cross product's cancellation).

    With A = P1 − P0 and B = P0 − 2·P1 + P2, C'(t) = 2(A + tB) and C'' = 2B, so
    |κ(t)| = |A × B| / (2·|A + tB|³): largest where the quadratic |A + tB|² is least on [0, 1].
    None for a straight line whose speed reaches 0 (A × B = 0 and A + tB = 0 on [0, 1])."""
    p0, p1, p2 = ([Fraction(v) for v in p] for p in (curve.p0, curve.p1, curve.p2))
    a = (p1[0] - p0[0], p1[1] - p0[1])
    b = (p0[0] - 2 * p1[0] + p2[0], p0[1] - 2 * p1[1] + p2[1])
    cross = a[0] * b[1] - a[1] * b[0]
    bb = b[0] * b[0] + b[1] * b[1]
    t = Fraction(0)
    if bb != 0:
        t = min(Fraction(1), max(Fraction(0), -(a[0] * b[0] + a[1] * b[1]) / bb))
    q = (a[0] + t * b[0]) ** 2 + (a[1] + t * b[1]) ** 2  # |A + tB|², least on [0, 1]
    if q == 0:
        return None if bb != 0 else (0.0, 0.0)
    kappa = math.sqrt(float(cross * cross / (4 * q ** 3)))
    # floats round the cross product (cancellation) and |A + tB| (least near a turn): the
    # relative error of each, times its power in κ
    size_a, size_b = math.hypot(*map(float, a)), math.hypot(*map(float, b))
    rounding = 1e-13 * (float(abs(a[0] * b[1]) + abs(a[1] * b[0])) / max(abs(float(cross)), 1e-300)
                        + 3.0 * (size_a + size_b) / math.sqrt(float(q)))
    return (kappa, rounding)


#: points on a micrometre grid (mm): no sub-normal coordinates, whose float arithmetic
#: underflows in ways no robot meets
grid_point = st.tuples(*[st.integers(-2_000_000, 2_000_000).map(lambda n: n / 1000)] * 2)


@settings(max_examples=100)
@given(grid_point, grid_point, grid_point)
@example((0.0, 0.0), (100.0, 0.0), (0.0, 0.0))  # out and back on a line: a turn at t = 1/2
@example((-100.0, 50.0), (0.0, -50.0), (100.0, 50.0))  # the parabola: κ = 1/100 at t = 1/2
@example((0.0, 0.0), (10.0, 100.0), (-300.0, 20.0))  # the least |C'| past the end: t* → 1
def test_peak_curvature_is_exact(p0: tuple[float, float], p1: tuple[float, float],
                                 p2: tuple[float, float]) -> None:
    curve = QuadraticBezier(p0, p1, p2)
    peak = curve.max_abs_curvature()
    exact = exact_peak_curvature(curve)
    if exact is None:
        # A line whose speed reaches 0 (where it turns back, or at P1 = P2): κ is 0/0 there,
        # and the float t* lands on the line's 0, inf or 1/rounding. Only "a number" holds.
        assert not math.isnan(peak)
        return
    kappa, rounding = exact
    assert peak == pytest.approx(kappa, rel=1e-9 + rounding, abs=1e-15)
    # and no sample of the curve turns more sharply than the peak (a check without the algebra)
    ts = np.linspace(0.0, 1.0, 2001)
    sampled = max(abs(curve.curvature(float(t))) for t in ts)
    assert peak >= sampled * (1 - 1e-9) - 1e-12


def test_curvature_sign_and_value() -> None:
    # a left turn has positive curvature; the parabola y = x²/200 has κ = 1/100 at its vertex.
    c = QuadraticBezier((-100.0, 50.0), (0.0, -50.0), (100.0, 50.0))
    assert c.curvature(0.5) == pytest.approx(1 / 100)
    assert c.max_abs_curvature() == pytest.approx(1 / 100)
    mirrored = QuadraticBezier((100.0, 50.0), (0.0, -50.0), (-100.0, 50.0))
    assert mirrored.curvature(0.5) == pytest.approx(-1 / 100)


def test_length() -> None:
    assert QuadraticBezier((0.0, 0.0), (30.0, 40.0), (60.0, 80.0)).length() == pytest.approx(100.0)
    # backtracking on a line: out to x = 1.8 (t = 0.6) and back to 1: 1.8 + 0.8
    assert QuadraticBezier((0.0, 0.0), (3.0, 0.0), (1.0, 0.0)).length() == pytest.approx(2.6)
    # parabola y = x²/200 for x in [-100, 100]: closed form of ∫ sqrt(1 + (x/100)²) dx
    exact = 100.0 * (math.sqrt(2.0) + math.asinh(1.0))
    c = QuadraticBezier((-100.0, 50.0), (0.0, -50.0), (100.0, 50.0))
    assert c.length() == pytest.approx(exact, rel=1e-12)


@settings(max_examples=100)
@given(point, point, point)
def test_length_matches_dense_polyline(p0: tuple[float, float], p1: tuple[float, float],
                                       p2: tuple[float, float]) -> None:
    curve = QuadraticBezier(p0, p1, p2)
    pts = curve.points(np.linspace(0.0, 1.0, 100_001))
    polyline = float(np.sum(np.hypot(*np.diff(pts, axis=0).T)))
    assert curve.length() >= polyline - 1e-6 * max(1.0, polyline)  # chords never exceed arcs
    assert curve.length() == pytest.approx(polyline, rel=1e-6, abs=1e-6)


@settings(deadline=None)  # no time limit per example: the machine may be loaded
@given(point, point, point, st.floats(1.0, 200.0))
@example((0.0, 0.0), (0.0, 1.0), (0.0, -1.19e-7), 1.0)  # found by Hypothesis in a full run
@example((-0.4, 1.1), (-0.4, -0.4), (-0.4, -1.9), 1.25)  # P1 mid-chord: B is rounding error
def test_sample_spacing(p0: tuple[float, float], p1: tuple[float, float],
                        p2: tuple[float, float], step: float) -> None:
    curve = QuadraticBezier(p0, p1, p2)
    pts = sample_curves([curve], step)
    assert tuple(pts[0]) == pytest.approx(p0)
    assert tuple(pts[-1]) == pytest.approx(p2)
    gaps = np.hypot(*np.diff(pts, axis=0).T)
    assert np.all(gaps <= step * 1.02 + 1e-9)
    # As many steps as the length needs; where length/step is within rounding of a whole number
    # (the sampler measures a fine polyline, not the exact length) either count is right: the
    # example below is 1.00000006 long and gets two gaps of 0.5 for a step of 1.
    ratio = curve.length() / step
    assert max(1, math.ceil(ratio - 1e-6)) <= len(gaps) <= max(1, math.ceil(ratio + 1e-6))
    # even spacing where the curve is smooth on the scale of a step (chords ≈ arcs)
    speeds = [math.hypot(*curve.derivative(float(t))) for t in np.linspace(0, 1, 101)]
    no_cusp = min(speeds) >= 0.1 * max(speeds)
    if len(gaps) > 2 and no_cusp and curve.max_abs_curvature() * step < 0.1:
        assert gaps.max() - gaps.min() <= 0.05 * step + 1e-9


def test_sample_rejects_bad_step() -> None:
    with pytest.raises(ValueError, match="step_mm"):
        sample_curves([QuadraticBezier((0, 0), (1, 0), (2, 0))], 0.0)
