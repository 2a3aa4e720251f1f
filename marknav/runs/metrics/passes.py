"""Run-report measures from the true path: how close the robot came to a mark and on which side
it passed it.

- :func:`min_clearance_mm`: robot centre to mark centre, the minimum along the path, between
  samples too.
- :func:`pass_crossings`: each time the path crosses the line through the mark perpendicular to
  the direction of travel (the mark going from ahead to behind), with the mark's lateral offset.
- :func:`passed_on`: which side of the mark the robot was on at its first crossing — ``"left"``
  when the mark was on the robot's right (the architecture's pass-side words).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

from marknav.planning.kinematics import Pose

__all__ = ["REARM_BEARING_DEG", "Crossing", "Trajectory", "min_clearance_mm", "pass_crossings",
           "passed_on"]

Trajectory = Sequence[Pose] | Sequence[tuple[float, float]] | npt.NDArray[np.float64]


def _xy(trajectory: Trajectory) -> npt.NDArray[np.float64]:
    if isinstance(trajectory, np.ndarray):
        arr = np.asarray(trajectory, dtype=float)
    else:
        rows = [(p.x, p.y) if isinstance(p, Pose) else (p[0], p[1]) for p in trajectory]
        arr = np.asarray(rows, dtype=float).reshape(-1, 2)
    if arr.ndim != 2 or arr.shape[1] < 2:
        raise ValueError(f"a trajectory is a sequence of (x, y) points, got shape {arr.shape}")
    return arr[:, :2]


def min_clearance_mm(trajectory: Trajectory, mark_xy: tuple[float, float]) -> float:
    """Smallest distance (mm) between the robot's centre and the mark's centre along the path,
    the path taken as straight segments between the samples. ``inf`` for an empty path."""
    p = _xy(trajectory)
    if len(p) == 0:
        return math.inf
    m = np.asarray(mark_xy, dtype=float)
    if len(p) == 1:
        return float(np.hypot(*(p[0] - m)))
    a, b = p[:-1], p[1:]
    ab = b - a
    den = np.einsum("ij,ij->i", ab, ab)
    t = np.where(den > 0, np.einsum("ij,ij->i", m - a, ab) / np.where(den > 0, den, 1.0), 0.0)
    t = np.clip(t, 0.0, 1.0)
    closest = a + t[:, None] * ab
    return float(np.min(np.hypot(*(closest - m).T)))


@dataclass(frozen=True)
class Crossing:
    """The robot crossing the line through the mark perpendicular to its direction of travel.

    ``index`` is the sample the crossing segment starts at, ``fraction`` how far along it;
    ``lateral_mm`` is the mark's distance to the robot's left at that moment (negative: right);
    ``side`` is the side of the mark the robot passed on.
    """

    index: int
    fraction: float
    lateral_mm: float

    @property
    def side(self) -> Literal["left", "right"]:
        # Mark on the robot's right (lateral < 0) = robot on the mark's left.
        return "left" if self.lateral_mm < 0 else "right"


#: A crossing counts again only after the mark has come back within this angle of the direction
#: of travel (so circling a mark, which keeps it abeam, is one pass, not one per sample).
REARM_BEARING_DEG = 80.0


def pass_crossings(
    trajectory: Trajectory, mark_xy: tuple[float, float], *, within_mm: float = 1000.0
) -> list[Crossing]:
    """The passes of a mark along a path, in order.

    A pass is the path crossing the line through the mark perpendicular to the direction of
    travel (the mark going from ahead to behind), by a segment within ``within_mm`` of the mark
    (farther crossings are not a pass) — or at a corner of the path (a turn on the spot), when
    the mark is ahead along the way in and behind along the way out. After a pass, the next one
    counts only once the mark has been back within ``REARM_BEARING_DEG`` of the direction of
    travel.
    """
    p = _xy(trajectory)
    m = np.asarray(mark_xy, dtype=float)
    rearm = math.cos(math.radians(REARM_BEARING_DEG))
    armed = True
    out: list[Crossing] = []
    prev_d: npt.NDArray[np.float64] | None = None
    for k in range(len(p) - 1):
        d = p[k + 1] - p[k]
        dd = float(d @ d)
        if dd <= 0.0:
            continue
        to_mark = m - p[k]
        dist = float(np.hypot(*to_mark))
        s0 = float((p[k] - m) @ d)
        s1 = float((p[k + 1] - m) @ d)
        if armed and prev_d is not None and float(to_mark @ prev_d) > 0.0 and s0 > 0.0:
            # A corner (the robot turned on the spot there): the mark was ahead along the way in
            # and is behind along the way out, so it was passed at the corner.
            u = prev_d / math.sqrt(float(prev_d @ prev_d)) + d / math.sqrt(dd)
            nu = float(np.hypot(*u))
            if nu > 1e-9:
                u = u / nu
                lateral = float(u[0] * to_mark[1] - u[1] * to_mark[0])
                if abs(lateral) <= within_mm:
                    out.append(Crossing(index=k, fraction=0.0, lateral_mm=lateral))
                    armed = False
        prev_d = d
        if dist > 0 and float(to_mark @ d) / (dist * math.sqrt(dd)) >= rearm:
            armed = True
        if not (armed and s0 < 0.0 <= s1):
            continue
        t = -s0 / dd
        at = p[k] + t * d
        u = d / math.sqrt(dd)
        rel = m - at
        lateral = float(u[0] * rel[1] - u[1] * rel[0])  # + : mark on the robot's left
        if abs(lateral) <= within_mm:
            out.append(Crossing(index=k, fraction=t, lateral_mm=lateral))
            armed = False
    return out


def passed_on(
    trajectory: Trajectory, mark_xy: tuple[float, float], *, within_mm: float = 1000.0
) -> Literal["left", "right"] | None:
    """The side of the mark the robot passed on at its first crossing (see
    :func:`pass_crossings`), or ``None`` if it never passed the mark."""
    found = pass_crossings(trajectory, mark_xy, within_mm=within_mm)
    return found[0].side if found else None
