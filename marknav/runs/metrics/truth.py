"""Ground truth of a route from the true path alone: was each course mark passed, in order, on
its side?

The behaviour tree's own claims (when it declared a waypoint passed, which mark it steered by)
play no part: the verdict is computed from the robot's true positions over time and the world's
course (:attr:`marknav.sim.world.World.course`, one physical mark per waypoint), so anyone can
re-check it from a run report's ``truth_path``.

Definitions (issue 11):

- **The path** is resampled by travel: a point is kept once the robot centre has moved at least
  :data:`RESAMPLE_MM` from the last kept one. Turning on the spot (a search) is not travel, so its
  wobble never counts as passing anything.
- **A crossing** of a mark is the path crossing the line through the mark perpendicular to the
  direction of travel, the mark going from ahead to behind (:func:`marknav.sim.world.
  pass_crossings`), at any lateral distance up to :data:`PASS_RADIUS_MM` (2 m): passing a mark
  950 mm away on its wrong side is a wrong-side pass, not "no pass"; a mark never come within
  2 m of was not passed at all.
- **Waypoint i's pass** is the first crossing of its course mark after waypoint i−1's pass (the
  start for the first). Its **window** runs from waypoint i−1's pass to waypoint i+1's pass
  (exclusive; the end of the path for the last). Its **side** is the side of the crossing with the
  smallest lateral distance in the window — the side at its closest approach — and its
  ``min_clearance_mm`` the closest approach of the robot centre to the mark in the window.
- Verdicts, in this order:
  ``skipped`` — no crossing of the mark after the previous pass, and none before it either;
  ``out_of_order`` — crossed only before the previous waypoint's pass, or only after the next
  course mark was crossed (for these two, only crossings within :data:`ORDER_RADIUS_MM` count,
  and not the next mark's when it is also the previous one: going round the mark just passed);
  ``off_course`` — another mark of the same colour (not this waypoint's mark, nor the previous or
  next waypoint's) was passed closer than this one within the window: the robot went round the
  wrong mark;
  ``wrong_side`` — the side at closest approach is not the waypoint's side;
  ``passed`` — all is well. A run's route is true only if every waypoint is ``passed``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from marknav.runs.metrics.passes import min_clearance_mm, pass_crossings
from marknav.sim.world.schema import World

__all__ = [
    "PASSED",
    "RESAMPLE_MM",
    "VERDICTS",
    "MarkTruth",
    "course_truth",
    "resample_path",
    "truth_path",
]

#: Path points closer together than this (mm of travel) are merged (turning on the spot is not
#: travel).
RESAMPLE_MM = 20.0
#: A crossing this far (mm) or nearer is a pass, on one side or the other: far beyond any
#: clearance (so a mark left 950 mm away on the wrong side is a wrong-side pass), near enough that
#: a mark metres away, swept from ahead to behind while the robot circles elsewhere, is not.
PASS_RADIUS_MM = 2000.0
#: Evidence of passing marks out of order counts only from crossings this near (mm): turning
#: toward the next mark, the robot can sweep a mark two metres away from ahead to behind
#: without going past it. (The side and the pass of a waypoint's own mark: any distance.)
ORDER_RADIUS_MM = 1200.0
#: Rate of the report's ``truth_path`` (the brief asks for at least 5 Hz).
TRUTH_PATH_HZ = 10.0

PASSED = "passed"
Verdict = Literal["passed", "wrong_side", "skipped", "out_of_order", "off_course"]
VERDICTS: tuple[str, ...] = ("passed", "wrong_side", "skipped", "out_of_order", "off_course")


@dataclass(frozen=True)
class MarkTruth:
    """One waypoint's ground truth: its physical mark and what the path did there."""

    mark_index: int
    mark_x_mm: float
    mark_y_mm: float
    truth: Verdict
    passed_on: Literal["left", "right"] | None
    min_clearance_mm: float | None
    t_pass: float | None
    detail: str = ""

    def mark_dict(self) -> dict[str, Any]:
        return {"index": self.mark_index, "x_mm": self.mark_x_mm, "y_mm": self.mark_y_mm}


def resample_path(
    t: Sequence[float] | npt.NDArray[np.float64],
    xy: Sequence[tuple[float, float]] | npt.NDArray[np.float64],
    step_mm: float = RESAMPLE_MM,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """(times, positions) keeping a point only once the robot moved ``step_mm`` from the last
    kept one. The last point too: a path that ends in a turn on the spot ends where the turn
    began (a last few millimetres of wobble after a search turn are not a direction of travel:
    kept, they made a corner whose "way out" put every mark ahead of the robot behind it, so a
    mark still ahead counted as passed)."""
    ts = np.asarray(t, dtype=float)
    p = np.asarray(xy, dtype=float).reshape(-1, 2)
    if len(p) == 0:
        return ts[:0], p
    keep = [0]
    last = p[0]
    for k in range(1, len(p)):
        if math.hypot(p[k, 0] - last[0], p[k, 1] - last[1]) >= step_mm:
            keep.append(k)
            last = p[k]
    idx = np.asarray(keep)
    return ts[idx], p[idx]


def truth_path(t: Sequence[float], xy: Sequence[tuple[float, float]],
               rate_hz: float = TRUTH_PATH_HZ) -> list[list[float]]:
    """``[[t, x_mm, y_mm], ...]`` at ``rate_hz`` (the first sample at or after each tick), plus
    the last sample: the true path a report carries."""
    out: list[list[float]] = []
    next_t = -math.inf
    for k, (tk, (x, y)) in enumerate(zip(t, xy, strict=True)):
        if tk >= next_t - 1e-9 or k == len(t) - 1:
            out.append([round(float(tk), 3), round(float(x), 1), round(float(y), 1)])
            next_t = tk + 1.0 / rate_hz
    return out


@dataclass(frozen=True)
class _Cross:
    t: float
    lateral_mm: float
    side: Literal["left", "right"]


def _crossings(ts: npt.NDArray[np.float64], p: npt.NDArray[np.float64],
               mark_xy: tuple[float, float]) -> list[_Cross]:
    out = []
    for c in pass_crossings(p, mark_xy, within_mm=PASS_RADIUS_MM):
        t = float(ts[c.index] + c.fraction * (ts[c.index + 1] - ts[c.index]))
        out.append(_Cross(t, abs(c.lateral_mm), c.side))
    return out


def _window_clearance(ts: npt.NDArray[np.float64], p: npt.NDArray[np.float64],
                      mark_xy: tuple[float, float], t0: float, t1: float) -> float | None:
    keep = (ts >= t0) & (ts <= t1)
    seg = p[keep]
    if len(seg) == 0:
        return None
    return round(float(min_clearance_mm(seg, mark_xy)), 1)


class _Crossings:
    """The crossings of each mark's pass line by the resampled path, computed once per mark."""

    def __init__(self, ts: npt.NDArray[np.float64], p: npt.NDArray[np.float64],
                 world: World) -> None:
        self.ts, self.p, self.world = ts, p, world
        self._cache: dict[int, list[_Cross]] = {}

    def __call__(self, i: int) -> list[_Cross]:
        if i not in self._cache:
            self._cache[i] = _crossings(self.ts, self.p, self.world.marks[i].xy)
        return self._cache[i]


def _passed_next_first(marks: Sequence[int], crossings: _Crossings, w: int, t_prev: float,
                       first: float) -> bool:
    """Whether the next waypoint's mark was passed between the previous pass and ``first``.
    (Not when the next mark is also the previous one — a figure-eight: going round the mark
    just passed, on the way to this one, is not passing the next waypoint early.)"""
    if w + 1 >= len(marks) or marks[w + 1] == marks[w]:
        return False
    if w > 0 and marks[w + 1] == marks[w - 1]:
        return False
    return any(t_prev < c.t < first and c.lateral_mm <= ORDER_RADIUS_MM
               for c in crossings(marks[w + 1]))


def _pass_times(marks: Sequence[int], crossings: _Crossings, t_start: float,
                ) -> tuple[list[float | None], list[str]]:
    """Each waypoint's pass time (``None``: not passed after the previous one) and its order:
    "ok", "skipped", "before" (passed only before the previous pass) or "late" (only after the
    next waypoint's mark was passed)."""
    passes: list[float | None] = []
    order: list[str] = []
    t_prev = t_start
    t_prev_prev = t_start
    for w, mi in enumerate(marks):
        # (A mark level with the previous waypoint's — a gate — is crossed at the very time of
        # that pass; the same mark again is not.)
        gate = w > 0 and mi != marks[w - 1]
        after = [c for c in crossings(mi) if c.t > t_prev or (c.t == t_prev and gate)]
        if not after:
            passes.append(None)
            before = any(t_prev_prev <= c.t <= t_prev and c.lateral_mm <= ORDER_RADIUS_MM
                         for c in crossings(mi))
            order.append("before" if before and w > 0 else "skipped")
            continue
        first = after[0].t
        passes.append(first)
        order.append("late" if _passed_next_first(marks, crossings, w, t_prev, first) else "ok")
        t_prev_prev, t_prev = t_prev, first
    return passes, order


def _rival(world: World, crossings: _Crossings, w: int, marks: Sequence[int],
           closest: _Cross, lo: float, hi: float) -> str | None:
    """Why the pass of waypoint ``w`` was of another mark of its colour passed closer inside
    its window (``None``: none was). The adjacent waypoints' own marks are not rivals: their
    passes bound the window, and a path that wiggles past the mark just passed re-crosses its
    line just inside."""
    mi = marks[w]
    colour = world.marks[mi].colour
    adjacent = {marks[k] for k in (w - 1, w + 1) if 0 <= k < len(marks)}
    for j, other in enumerate(world.marks):
        if j == mi or j in adjacent or other.colour != colour:
            continue
        rivals = [c for c in crossings(j) if lo < c.t < hi]
        if rivals and min(c.lateral_mm for c in rivals) < closest.lateral_mm:
            near = min(rivals, key=lambda c: c.lateral_mm)
            return (f"passed mark {j} ({other.colour} at {other.x_mm:g}, "
                    f"{other.y_mm:g}) at {near.lateral_mm:.0f} mm instead "
                    f"(this one at {closest.lateral_mm:.0f} mm)")
    return None


def _judge(world: World, crossings: _Crossings, w: int, marks: Sequence[int],
           sides: Sequence[str], passes: Sequence[float | None], order: Sequence[str],
           t_start: float, t_end: float) -> MarkTruth:
    """Waypoint ``w``'s verdict, within the window between its neighbours' passes."""
    mi = marks[w]
    mark = world.marks[mi]
    prev_t = next((x for x in reversed(passes[:w]) if x is not None), t_start)
    next_t = next((x for x in passes[w + 1:] if x is not None), None)
    lo, hi = prev_t, (next_t if next_t is not None else t_end)
    clearance = _window_clearance(crossings.ts, crossings.p, mark.xy, lo, hi)
    base = (mi, mark.x_mm, mark.y_mm)
    t_pass = passes[w]
    if t_pass is None:
        verdict: Verdict = "out_of_order" if order[w] == "before" else "skipped"
        detail = ("passed only before the previous waypoint's mark" if verdict ==
                  "out_of_order" else "never passed")
        return MarkTruth(*base, verdict, None, clearance, None, detail)
    inside = [c for c in crossings(mi) if lo < c.t < hi or c.t == t_pass]
    closest = min(inside, key=lambda c: c.lateral_mm)
    rival = None if order[w] == "late" else _rival(world, crossings, w, marks, closest, lo, hi)
    if order[w] == "late":
        verdict, detail = "out_of_order", "passed only after the next waypoint's mark"
    elif rival is not None:
        verdict, detail = "off_course", rival
    elif closest.side != sides[w]:
        verdict = "wrong_side"
        detail = f"passed on its {closest.side} at {closest.lateral_mm:.0f} mm"
    else:
        verdict, detail = "passed", ""
    return MarkTruth(*base, verdict, closest.side, clearance, round(t_pass, 3), detail)


def course_truth(
    t: Sequence[float] | npt.NDArray[np.float64],
    xy: Sequence[tuple[float, float]] | npt.NDArray[np.float64],
    world: World,
    route: Sequence[str],
    sides: Sequence[str],
    course: Sequence[int] | None = None,
) -> list[MarkTruth]:
    """Each waypoint's :class:`MarkTruth` from the true path (times ``t``, positions ``xy``) and
    the course (default: the world's, :meth:`World.course_for`). See the module docstring."""
    if len(sides) != len(route):
        raise ValueError(f"{len(sides)} sides for a route of {len(route)}")
    marks = list(course) if course is not None else world.course_for(len(route))
    if len(marks) != len(route):
        raise ValueError(f"a course of {len(marks)} marks for a route of {len(route)}")
    ts, p = resample_path(t, xy)
    if len(ts) == 0:
        return [MarkTruth(i, *world.marks[i].xy, "skipped", None, None, None, "no path")
                for i in marks]
    t_start, t_end = float(ts[0]), float(ts[-1])
    crossings = _Crossings(ts, p, world)
    passes, order = _pass_times(marks, crossings, t_start)
    return [_judge(world, crossings, w, marks, sides, passes, order, t_start, t_end)
            for w in range(len(marks))]
