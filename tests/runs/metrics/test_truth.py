"""Ground truth from the true path alone (issue 11): synthetic paths through small worlds, each
built to show one way a route can go wrong, and what the verdict must then be."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest

from marknav.core.errors import InputErrors
from marknav.runs.metrics.truth import course_truth, resample_path, truth_path
from marknav.sim.world import MarkSpec, World, check_course, load_world


def polyline(*points: tuple[float, float], step_mm: float = 10.0,
             speed_mm_s: float = 200.0) -> tuple[np.ndarray, np.ndarray]:
    """Times and positions along straight legs through ``points`` at a steady speed."""
    xy: list[np.ndarray] = []
    for a, b in itertools.pairwise(points):
        n = max(2, int(math.dist(a, b) / step_mm))
        seg = np.linspace(a, b, n, endpoint=False)
        xy.append(seg)
    xy.append(np.asarray([points[-1]], dtype=float))
    p = np.vstack(xy)
    d = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(p, axis=0).T))])
    return d / speed_mm_s, p


def world(*marks: tuple[str, float, float], course: tuple[int, ...] | None = None) -> World:
    return World(marks=tuple(MarkSpec(colour=c, x_mm=x, y_mm=y) for c, x, y in marks),
                 course=course)


def verdicts(t: np.ndarray, p: np.ndarray, w: World, route: list[str],
             sides: list[str]) -> list[str]:
    return [m.truth for m in course_truth(t, p, w, route, sides)]


def test_a_clean_zigzag_is_passed_in_order_on_each_side() -> None:
    w = world(("yellow", -250, 1500), ("purple", 250, 3000), ("yellow", -250, 4500))
    t, p = polyline((0, 0), (0, 1000), (50, 1500), (0, 2000), (0, 2500), (-50, 3000), (0, 3500),
                    (0, 4000), (50, 4500), (0, 5000))
    # The robot keeps yellow on its left (passes on yellow's right), purple on its right.
    out = course_truth(t, p, w, ["yellow", "purple", "yellow"], ["right", "left", "right"])
    assert [m.truth for m in out] == ["passed", "passed", "passed"]
    assert [m.passed_on for m in out] == ["right", "left", "right"]
    assert [(m.mark_index, m.mark_x_mm, m.mark_y_mm) for m in out] == [
        (0, -250, 1500), (1, 250, 3000), (2, -250, 4500)]
    assert out[0].min_clearance_mm == pytest.approx(300.0, abs=2.0)
    assert out[0].t_pass is not None and out[1].t_pass is not None
    assert out[0].t_pass < out[1].t_pass < (out[2].t_pass or 0.0)


def test_a_far_wrong_side_pass_is_a_wrong_side_pass() -> None:
    # The zigzag: the fourth mark (purple, pass on its right) left 950 mm to the right of
    # the robot: the robot went by on its left.
    w = world(("purple", 250, 6000), ("purple", -250, 7500))
    t, p = polyline((-700, 4500), (-700, 7000), (-550, 7500), (-700, 8000))
    out = course_truth(t, p, w, ["purple", "purple"], ["right", "right"])
    assert out[0].truth == "wrong_side" and out[0].passed_on == "left"
    assert "950 mm" in out[0].detail
    assert out[0].min_clearance_mm == pytest.approx(950.0, abs=1.0)
    assert out[1].truth == "wrong_side"  # purple at -250 passed with it on the robot's right too


def test_a_skipped_mark_is_skipped_and_the_next_one_still_counts() -> None:
    # The second course mark stands beyond the end of the path: the robot never drew level.
    w = world(("red", 0, 1500), ("green", 0, 9000), ("blue", 0, 4500))
    t, p = polyline((-300, 0), (-300, 6000))
    out = course_truth(t, p, w, ["red", "green", "blue"], ["left", "left", "left"])
    assert [m.truth for m in out] == ["passed", "skipped", "passed"]
    assert out[1].passed_on is None and out[1].t_pass is None


def test_marks_passed_out_of_order() -> None:
    # Course: the far mark first, then the near one; the path passes the near one first.
    w = world(("red", 0, 1500), ("green", 0, 3000), course=(1, 0))
    t, p = polyline((-300, 0), (-300, 4000))
    assert verdicts(t, p, w, ["green", "red"], ["left", "left"]) == [
        "out_of_order", "out_of_order"]
    # The same path is true for the course in its own order.
    assert verdicts(t, p, w.model_copy(update={"course": (0, 1)}), ["red", "green"],
                    ["left", "left"]) == ["passed", "passed"]


def test_an_off_course_mark_of_the_route_colour_passed_instead() -> None:
    # The course's red is passed on its right 1.2 m away (its side!), but the robot went round
    # the off-course red beside it at 300 mm: not a pass of the course mark.
    w = world(("red", 0, 3000), ("red", 1500, 3000), course=(0,))
    t, p = polyline((1200, 0), (1200, 5000))
    (out,) = course_truth(t, p, w, ["red"], ["right"])
    assert out.truth == "off_course" and out.passed_on == "right"
    assert "mark 1" in out.detail
    # Without the off-course mark the same path passes the course mark (on its right, far).
    (alone,) = course_truth(t, p, world(("red", 0, 3000)), ["red"], ["right"])
    assert alone.truth == "passed"


def test_the_window_ends_at_the_next_pass() -> None:
    # Red passed on its left at 400 mm, then green; then the robot turns back and goes by red
    # again, 200 mm away on its right, after green's pass. That later, closer pass belongs to
    # no window of red's waypoint: red's waypoint stays passed on its left, 400 mm.
    w = world(("red", 0, 1500), ("green", 0, 3500))
    t, p = polyline((-400, 0), (-400, 3500), (-400, 4500), (200, 4500), (200, 0))
    out = course_truth(t, p, w, ["red", "green"], ["left", "left"])
    assert [m.truth for m in out] == ["passed", "passed"]
    assert out[0].passed_on == "left"
    assert out[0].min_clearance_mm == pytest.approx(400.0, abs=1.0)


def test_a_repeated_mark_is_judged_pass_by_pass() -> None:
    # A figure-eight-like course: red, green, red; the second red pass is on the wrong side.
    w = world(("red", 0, 1500), ("green", 0, 3500), course=(0, 1, 0))
    good = polyline((-300, 0), (-300, 3500), (-300, 4000), (300, 4000), (300, 3500),
                    (-300, 1500), (-300, 500))
    bad = polyline((-300, 0), (-300, 3500), (-300, 4000), (300, 4000), (300, 0))
    sides = ["left", "left", "right"]
    assert verdicts(*good, w, ["red", "green", "red"], sides) == ["passed", "passed", "passed"]
    assert verdicts(*bad, w, ["red", "green", "red"], sides) == [
        "passed", "passed", "wrong_side"]


def test_turning_on_the_spot_passes_nothing() -> None:
    # A search turn with a wheel mismatch wobbles the centre in 5 mm circles: no travel, so a
    # mark 3 m away is not "crossed" once per turn.
    w = world(("red", 0, 3000))
    a = np.linspace(0.0, 6 * math.pi, 600)
    p = np.column_stack([5.0 * np.cos(a), 5.0 * np.sin(a)])
    (out,) = course_truth(np.linspace(0.0, 30.0, 600), p, w, ["red"], ["left"])
    assert out.truth == "skipped"
    _, q = resample_path(np.linspace(0.0, 30.0, 600), p)
    assert len(q) <= 2


def test_a_search_turn_at_the_end_of_a_run_passes_nothing_ahead() -> None:
    """Slalom seed 55: the robot drove toward its mark, stopped 950 mm short, turned a full
    search turn on the spot and the run ended, its centre 1 mm behind where the turn began. That
    last millimetre was kept as the path's final direction — a reversal — so the mark ahead was
    "behind along the way out" and counted passed at the corner (and the next mark, 2.5 m
    ahead, passed on its wrong side)."""
    w = world(("green", -300, 3800), ("red", 350, 5360))
    t, p = polyline((0, 0), (-60, 2873), step_mm=25.0)  # every sample a step of travel
    a = np.linspace(0.0, 2 * math.pi, 180)
    spin = np.column_stack([-60.0 + 3.0 * np.sin(a), 2873.0 - 3.0 + 3.0 * np.cos(a)])
    p = np.vstack([p, spin, [[-60.0, 2872.0]]])
    t = np.concatenate([t, t[-1] + np.linspace(0.05, 9.0, 180), [t[-1] + 9.05]])
    assert verdicts(t, p, w, ["green", "red"], ["right", "left"]) == ["skipped", "skipped"]


def test_truth_path_rate_and_recheck() -> None:
    t, p = polyline((-300, 0), (-300, 3000), step_mm=3.0)  # 15 ms samples at 200 mm/s
    path = truth_path(list(t), [tuple(x) for x in p])
    ts = np.array([row[0] for row in path])
    assert np.all(np.diff(ts[:-1]) <= 0.2 + 1e-9)  # at least 5 Hz
    assert path[-1][0] == pytest.approx(t[-1], abs=1e-3)
    xy = np.array([row[1:] for row in path])
    w = world(("red", 0, 1500))
    assert verdicts(ts, xy, w, ["red"], ["left"]) == verdicts(t, p, w, ["red"], ["left"])


def test_course_defaults_and_checks(tmp_path: Path) -> None:
    w = world(("red", 0, 1500), ("green", 0, 3000))
    assert w.course_for(2) == [0, 1]
    check_course(w, ["red", "green"])
    f = tmp_path / "w.yaml"
    f.write_text("marks:\n  - {colour: red, x_mm: 0, y_mm: 1500}\n"
                 "  - {colour: green, x_mm: 0, y_mm: 3000}\ncourse: [0, 1, 1]\n")
    loaded = load_world(f)
    with pytest.raises(InputErrors) as exc:
        check_course(loaded, ["red", "green", "red"])
    assert str(exc.value.errors[0]).startswith(f"{f}:4:")
    assert "course[2]" in str(exc.value.errors[0]) and "'green'" in str(exc.value.errors[0])
    with pytest.raises(InputErrors) as exc:
        check_course(loaded, ["red", "green"])
    assert "3 entries for a route of 2" in str(exc.value.errors[0])
    with pytest.raises(InputErrors) as exc:
        check_course(load_world(f), ["red"] * 3)
    with pytest.raises(ValueError, match="course\\[0\\] is mark 5"):
        world(("red", 0, 1500), course=(5,))
