"""The ground truth (marknav/runs/metrics/truth.py) at edges mutation testing found unasserted
(docs/mutation.md): argument checks, an empty path, the resampling's and the report path's
bounds. Public functions only, on synthetic paths, as tests/runs/metrics/test_truth.py."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from marknav.runs.metrics.truth import course_truth, resample_path, truth_path
from marknav.sim.world import MarkSpec, World


def world(*marks: tuple[str, float, float], course: tuple[int, ...] | None = None) -> World:
    return World(marks=tuple(MarkSpec(colour=c, x_mm=x, y_mm=y) for c, x, y in marks),
                 course=course)


def test_mismatched_route_sides_and_course_are_refused_with_their_sizes() -> None:
    w = world(("red", 0, 1500), ("green", 0, 3000))
    t, p = [0.0, 1.0], [(0.0, 0.0), (0.0, 200.0)]
    with pytest.raises(ValueError, match=r"^1 sides for a route of 2$"):
        course_truth(t, p, w, ["red", "green"], ["left"])
    with pytest.raises(ValueError, match=r"^a course of 1 marks for a route of 2$"):
        course_truth(t, p, w, ["red", "green"], ["left", "left"], course=[0])


def test_an_empty_path_skips_every_waypoint_at_its_mark() -> None:
    w = world(("red", 0, 1500), ("green", 100, 3000))
    out = course_truth([], [], w, ["red", "green"], ["left", "right"])
    assert [(m.mark_index, m.mark_x_mm, m.mark_y_mm, m.truth, m.passed_on, m.min_clearance_mm,
             m.t_pass, m.detail) for m in out] == [
        (0, 0, 1500, "skipped", None, None, None, "no path"),
        (1, 100, 3000, "skipped", None, None, None, "no path")]
    ts, q = resample_path([], [])
    assert ts.shape == (0,) and q.shape == (0, 2)
    assert np.asarray(q).dtype == np.float64


def line(x: float, y0: float, y1: float, *, speed_mm_s: float = 200.0, step_mm: float = 10.0,
         t0: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """A straight leg along y at ``x`` (samples every ``step_mm``, steady speed)."""
    n = int(abs(y1 - y0) / step_mm) + 1
    y = np.linspace(y0, y1, n)
    p = np.column_stack([np.full(n, x), y])
    return t0 + np.abs(y - y0) / speed_mm_s, p


def legs(*points: tuple[float, float], speed_mm_s: float = 200.0,
         step_mm: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
    """Straight legs through ``points`` at a steady speed (as test_truth.py's polyline)."""
    xy = []
    for a, b in itertools.pairwise(points):
        n = max(2, int(np.hypot(b[0] - a[0], b[1] - a[1]) / step_mm))
        xy.append(np.linspace(a, b, n, endpoint=False))
    xy.append(np.asarray([points[-1]], dtype=float))
    p = np.vstack(xy)
    d = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(p, axis=0).T))])
    return d / speed_mm_s, p


# -- resampling and the report's path ------------------------------------------------------------


def test_resampling_keeps_the_first_point_and_each_step() -> None:
    t = [0, 1, 2, 3, 4]
    ts, q = resample_path(t, [(0, 0), (0, 5), (0, 25), (0, 40), (0, 46)])
    assert ts.tolist() == [0.0, 2.0, 4.0] and q.tolist() == [[0, 0], [0, 25], [0, 46]]
    assert ts.dtype == np.float64 and q.dtype == np.float64  # integer input, float output
    # a step exactly the resampling distance counts; no point is kept twice
    ts, q = resample_path([0.0, 1.0, 2.0], [(0.0, 0.0), (0.0, 20.0), (0.0, 40.0)])
    assert ts.tolist() == [0.0, 1.0, 2.0]
    # the last point too only once it moved a step: 5 mm of wobble is not a direction
    ts, q = resample_path([0.0, 1.0, 2.0], [(0.0, 0.0), (0.0, 30.0), (0.0, 35.0)])
    assert ts.tolist() == [0.0, 1.0]
    ts, q = resample_path([0.0, 1.0, 2.0], [(0.0, 0.0), (0.0, 30.0), (0.0, 60.0)])
    assert ts.tolist() == [0.0, 1.0, 2.0]
    # with no minimum step every point is kept, once
    ts, _ = resample_path([0.0, 1.0, 2.0], [(0.0, 0.0), (0.0, 1.0), (0.0, 2.0)], step_mm=0.0)
    assert ts.tolist() == [0.0, 1.0, 2.0]


@pytest.mark.parametrize("path", [
    [(1000.0, 500.0), (1015.0, 500.0), (1030.0, 500.0), (1045.0, 500.0)],   # along x, off origin
    [(700.0, -900.0), (700.0, -885.0), (700.0, -870.0), (700.0, -855.0)],  # along y, off origin
])
def test_resampling_measures_travel_from_the_last_kept_point_in_both_coordinates(path) -> None:
    ts, q = resample_path([0.0, 1.0, 2.0, 3.0], path)
    assert ts.tolist() == [0.0, 2.0]  # 15 mm: not yet; 30 mm: kept; 15 mm more: not yet
    assert q.tolist() == [list(path[0]), list(path[2])]


def test_the_report_path_rounds_and_keeps_one_sample_per_tick() -> None:
    t = [0.0, 0.015, 0.03, 0.045, 0.06, 0.075, 0.09, 0.105, 0.12345678, 0.2, 0.21]
    xy = [(1.23456, -7.65432)] * len(t)
    path = truth_path(t, xy)
    assert [row[0] for row in path] == [0.0, 0.105, 0.21]  # first at/after each 0.1 s, the last
    assert path[0] == [0.0, 1.2, -7.7]
    # samples at exactly the rate (as decimal literals, a float hair below the tick) are all kept
    ticks = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7]
    assert [row[0] for row in truth_path(ticks, [(0.0, 0.0)] * 8)] == ticks
    # the nanosecond slack: a sample 1 ns before its tick still counts as that tick's
    assert [row[0] for row in truth_path([0.0, 0.1 - 1e-9, 0.15], [(0.0, 0.0)] * 3)] == [
        0.0, 0.1, 0.15]
    odd = truth_path([0.12345678], [(1.23456, 2.34567)])
    assert odd == [[0.123, 1.2, 2.3]]
    with pytest.raises(ValueError):
        truth_path([0.0, 0.1], [(0.0, 0.0)])


# -- the window, its clearance and the times ------------------------------------------------------


def test_pass_time_and_clearance_are_interpolated_and_rounded() -> None:
    # 170 mm/s past a mark at y = 1500, 312.345 mm to the robot's right
    t, p = line(-312.345, 0.0, 3000.0, speed_mm_s=170.0)
    (out,) = course_truth(t, p, world(("red", 0, 1500)), ["red"], ["left"])
    assert out.truth == "passed" and out.detail == ""
    assert out.t_pass == round(1500.0 / 170.0, 3) == 8.824
    assert out.min_clearance_mm == 312.3


def test_a_skipped_mark_keeps_its_closest_approach_including_the_path_ends() -> None:
    # red behind the start (closest at the first sample, 500 mm), green beyond the end
    # (closest at the last sample, 700 mm): neither is ever drawn level with
    w = world(("red", 0, -500), ("green", 0, 3700))
    t, p = line(0.0, 0.0, 3000.0)
    out = course_truth(t, p, w, ["red", "green"], ["left", "left"])
    assert [(m.truth, m.min_clearance_mm, m.detail) for m in out] == [
        ("skipped", 500.0, "never passed"), ("skipped", 700.0, "never passed")]
    # a path of one sample: that sample is the closest approach
    (one,) = course_truth([0.0], [(0.0, 0.0)], world(("red", 300, 400)), ["red"], ["left"])
    assert (one.truth, one.min_clearance_mm) == ("skipped", 500.0)


# -- out of order --------------------------------------------------------------------------------


def test_out_of_order_details_name_which_way_round() -> None:
    w = world(("red", 0, 1500), ("green", 0, 3000), course=(1, 0))
    t, p = line(-300.0, 0.0, 4000.0)
    out = course_truth(t, p, w, ["green", "red"], ["left", "left"])
    assert [(m.truth, m.detail) for m in out] == [
        ("out_of_order", "passed only after the next waypoint's mark"),
        ("out_of_order", "passed only before the previous waypoint's mark")]
    assert out[1].min_clearance_mm is not None and out[1].t_pass is None


def test_a_middle_waypoint_passed_after_the_next_one_is_out_of_order() -> None:
    # red, green, blue; the path goes by red, then blue, then back round to green
    w = world(("red", 0, 1000), ("green", 600, 3000), ("blue", 0, 2000))
    t, p = legs((-300, 0), (-300, 2400), (300, 2400), (300, 3400))
    out = course_truth(t, p, w, ["red", "green", "blue"], ["left", "left", "left"])
    assert out[1].truth == "out_of_order"
    assert out[1].detail == "passed only after the next waypoint's mark"


def test_order_evidence_counts_up_to_the_order_radius_inclusive() -> None:
    # green's only crossing comes before red's pass: at 1200 mm it is evidence of passing out
    # of order; at 1600 mm (still a crossing, within 2 m) it is not, and green was skipped
    t, p = line(-300.0, 0.0, 4000.0)
    for green_x, verdict in [(900.0, "out_of_order"), (1300.0, "skipped")]:
        w = world(("red", 0, 3000), ("green", green_x, 1500))
        out = course_truth(t, p, w, ["red", "green"], ["left", "right"])
        assert out[1].truth == verdict, green_x
    # the next mark crossed at exactly 1200 mm before this one's pass: this one was late
    w = world(("red", 0, 3000), ("green", 900, 1500), course=(0, 1))
    out = course_truth(t, p, w, ["red", "green"], ["left", "right"])
    assert out[0].truth == "out_of_order"


def test_a_loop_back_to_the_first_mark_still_checks_the_first_waypoints_order() -> None:
    # course red, green, red (the same red first and last): green crossed first is evidence that
    # red's first pass came late, as on any course
    w = world(("red", 0, 3000), ("green", 0, 1500), course=(0, 1, 0))
    t, p = line(-300.0, 0.0, 4000.0)
    out = course_truth(t, p, w, ["red", "green", "red"], ["left", "left", "left"])
    assert out[0].truth == "out_of_order"


# -- the side, and rivals -----------------------------------------------------------------------


def test_the_side_is_the_one_at_the_closest_crossing_not_the_first() -> None:
    # up 900 mm to red's right (wrong side for "left"), round far away, then up 300 mm to its
    # left: the closest crossing decides
    w = world(("red", 0, 1500))
    t, p = legs((900, 0), (900, 2500), (2600, 2500), (2600, -200), (-300, -200), (-300, 3000))
    (out,) = course_truth(t, p, w, ["red"], ["left"])
    assert (out.truth, out.passed_on) == ("passed", "left")
    assert out.min_clearance_mm == pytest.approx(300.0, abs=1.0)


def test_a_rival_as_near_as_the_course_mark_is_not_passed_instead() -> None:
    # two reds 600 mm apart, the robot exactly between them: the course mark was passed
    w = world(("red", 0, 1500), ("red", 600, 1500), course=(0,))
    t, p = line(300.0, 0.0, 3000.0)
    (out,) = course_truth(t, p, w, ["red"], ["right"])
    assert out.truth == "passed"


def test_other_colours_are_no_rivals() -> None:
    w = world(("red", 0, 1500), ("blue", 500, 1500), course=(0,))
    t, p = line(400.0, 0.0, 3000.0)
    (out,) = course_truth(t, p, w, ["red"], ["right"])
    assert out.truth == "passed"


def test_the_off_course_detail_names_the_rivals_nearest_crossing() -> None:
    # the off-course red at (1500, 1500) crossed twice inside the window: 500 mm, then 200 mm
    w = world(("red", 0, 1500), ("red", 1500, 1500), course=(0,))
    t, p = legs((1000, 0), (1000, 2500), (2900, 2500), (2900, 0), (1300, 0), (1300, 3000))
    (out,) = course_truth(t, p, w, ["red"], ["right"])
    assert out.truth == "off_course"
    assert out.detail == "passed mark 1 (red at 1500, 1500) at 200 mm instead (this one at 1000 mm)"


def test_the_previous_waypoints_mark_crossed_again_is_no_rival() -> None:
    # three reds in a row; after passing the first at 300 mm the robot turns back across its
    # line at 450 mm and then passes the second at 600 mm: the second waypoint is passed
    # (3.5 m apart, so that turning back sweeps no other mark within 2 m)
    w = world(("red", 0, 1000), ("red", 0, 4500), ("red", 0, 8000))
    t, p = legs((-300, 0), (-300, 1400), (-450, 1400), (-450, 600), (-600, 600), (-600, 5000),
                (-300, 5000), (-300, 8500))
    out = course_truth(t, p, w, ["red"] * 3, ["left"] * 3)
    assert [m.truth for m in out] == ["passed", "passed", "passed"]


def test_a_gate_of_two_level_marks_is_passed_through_in_order() -> None:
    # red and green side by side, the robot between them: both are crossed at the same instant,
    # which is no reason to call the second "passed only before the previous waypoint's mark"
    # (found through a surviving mutant of the "after the previous pass" test; the same mark
    # twice in a row still needs two passes)
    t, p = line(0.0, 0.0, 3000.0)
    gate = world(("red", -300, 1500), ("green", 300, 1500))
    out = course_truth(t, p, gate, ["red", "green"], ["right", "left"])
    assert [(m.truth, m.passed_on, m.t_pass) for m in out] == [
        ("passed", "right", 7.5), ("passed", "left", 7.5)]
    # a gate followed by a third mark: nothing is late either
    three = world(("red", -300, 1500), ("green", 300, 1500), ("blue", -300, 2500))
    assert [m.truth for m in course_truth(t, p, three, ["red", "green", "blue"],
                                          ["right", "left", "right"])] == ["passed"] * 3
    twice = world(("red", -300, 1500), course=(0, 0))
    assert [m.truth for m in course_truth(t, p, twice, ["red", "red"], ["right", "right"])] == [
        "passed", "out_of_order"]


def test_rivals_crossed_at_the_window_bounds_do_not_count() -> None:
    # the window is exclusive at both ends: an off-course red level with the previous course
    # mark (crossed at the instant of its pass) is no rival of the next waypoint
    t, p = line(500.0, 0.0, 4000.0)
    w = world(("red", 0, 1500), ("red", 2000, 3000), ("red", 1000, 1500), course=(0, 1))
    out = course_truth(t, p, w, ["red", "red"], ["right", "left"])
    assert [m.truth for m in out] == ["passed", "passed"]
    # ... nor one level with the next course mark, of the waypoint before it
    w = world(("red", 2000, 1500), ("red", 0, 3000), ("red", 1000, 3000), course=(0, 1))
    out = course_truth(t, p, w, ["red", "red"], ["left", "right"])
    assert [m.truth for m in out] == ["passed", "passed"]


def test_a_mark_truth_names_its_mark() -> None:
    (out,) = course_truth(*line(-300.0, 0.0, 3000.0), world(("red", 10, 1500)), ["red"],
                          ["left"])
    assert out.mark_dict() == {"index": 0, "x_mm": 10, "y_mm": 1500}


def test_the_next_waypoints_mark_crossed_early_but_far_is_no_rival() -> None:
    # red 1 is passed 1.5 m away; on the way the robot crossed red 2's line 1.3 m away (too far
    # to say it went out of order), and went back round red 2 at 300 mm after red 1: the next
    # waypoint's own mark is not an off-course mark of this one
    w = world(("red", 1500, 3000), ("red", -1300, 1000))
    t, p = legs((0, 0), (0, 3500), (-1600, 3500), (-1600, 0))
    out = course_truth(t, p, w, ["red", "red"], ["left", "right"])
    assert [(m.truth, m.passed_on) for m in out] == [("passed", "left"), ("passed", "right")]


def test_a_mark_in_a_gate_with_the_waypoint_two_back_was_passed_before_the_previous() -> None:
    # course red, blue, green; red and green side by side (crossed at one instant), blue later:
    # blue is no later than its predecessor's pass, and green came before blue
    w = world(("red", -300, 1500), ("green", 300, 1500), ("blue", -300, 3000))
    t, p = line(0.0, 0.0, 4000.0)
    out = course_truth(t, p, w, ["red", "blue", "green"], ["right", "right", "left"],
                       course=[0, 2, 1])
    assert [(m.truth, m.detail) for m in out] == [
        ("passed", ""), ("passed", ""),
        ("out_of_order", "passed only before the previous waypoint's mark")]


def test_the_same_mark_twice_is_judged_from_its_second_pass_only() -> None:
    # course red, red: passed 300 mm on its left, then round and 500 mm on its right; the
    # second waypoint's window starts at the first pass, exclusive
    w = world(("red", 0, 1500), course=(0, 0))
    t, p = legs((-300, 0), (-300, 2500), (2600, 2500), (2600, 0), (500, 0), (500, 3000))
    out = course_truth(t, p, w, ["red", "red"], ["left", "right"])
    assert [(m.truth, m.passed_on) for m in out] == [("passed", "left"), ("passed", "right")]


def test_a_crossing_at_the_next_pass_is_outside_the_window() -> None:
    # red passed 400 mm away with it on the robot's right; round far below, then up through a
    # red|green gate: red's line is crossed again (200 mm, its other side) at the very instant
    # of green's first pass — that crossing is at the end of red's window, which is exclusive
    w = world(("red", -300, 1500), ("green", 300, 1500))
    t, p = legs((-100, 1100), (-1800, 1100), (-1800, -1000), (-100, -1000), (-100, 2500))
    out = course_truth(t, p, w, ["red", "green"], ["left", "left"])
    assert [(m.truth, m.passed_on) for m in out] == [("passed", "left"), ("passed", "left")]
    assert out[0].t_pass is not None and out[1].t_pass is not None
    assert out[0].t_pass < out[1].t_pass
