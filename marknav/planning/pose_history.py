"""A short history of odometry poses, to ask where the robot was when a frame was taken.

A camera frame is older than the tick that processes it (capture to arrival: the camera, a
network; arrival to command: the processing). A mark found in a frame must be placed in the
world with the pose the robot had at the frame's *capture* time: placed with the pose at
processing time, a frame τ old puts the mark v·τ too far along the robot's motion.

:class:`PoseHistory` keeps (time, pose, extra) samples for ``span_s`` seconds and interpolates
between the two samples around the asked time: linearly in position and in the wrapped heading
difference (over one control period a drive arc is a straight chord to within
κ·s²/8: 0.05 mm for a 20 mm step on a 1 m radius), and linearly in the optional ``extra``
numbers (e.g. odometry's sensitivities to a wheel scale). Outside the history the nearest sample
stands in, and :meth:`at` says so. Pure data structure: no clock, no I/O.
"""

from __future__ import annotations

import bisect
from collections import deque
from dataclasses import dataclass

from marknav.planning.kinematics import Pose, wrap_angle

__all__ = ["DEFAULT_SPAN_S", "PoseAt", "PoseHistory", "interpolate_pose"]

#: How long a history keeps its samples (s): longer than any frame latency worth correcting
#: (Wi-Fi MJPEG is 0.13–0.3 s; a frame older than the camera timeout is not used at all).
DEFAULT_SPAN_S = 2.0


def interpolate_pose(a: Pose, b: Pose, w: float) -> Pose:
    """The pose a fraction ``w`` (0..1) of the way from ``a`` to ``b``: position linearly,
    heading along the shorter turn."""
    return Pose(a.x + w * (b.x - a.x), a.y + w * (b.y - a.y),
                wrap_angle(a.theta + w * wrap_angle(b.theta - a.theta)))


@dataclass(frozen=True)
class PoseAt:
    """The pose at an asked time: ``pose``, the interpolated ``extra`` numbers, and
    ``clamped_s``: how far the time lay outside the history (0 when inside it)."""

    pose: Pose
    extra: tuple[float, ...] = ()
    clamped_s: float = 0.0


class PoseHistory:
    """Poses by time (seconds of one clock, added in time order), kept for ``span_s``."""

    def __init__(self, span_s: float = DEFAULT_SPAN_S) -> None:
        if not span_s > 0:
            raise ValueError(f"span_s must be positive, got {span_s!r}")
        self.span_s = float(span_s)
        self._t: deque[float] = deque()
        self._samples: deque[tuple[Pose, tuple[float, ...]]] = deque()

    def __len__(self) -> int:
        return len(self._t)

    def clear(self) -> None:
        self._t.clear()
        self._samples.clear()

    def set_extra(self, extra: tuple[float, ...]) -> None:
        """Give every sample the same ``extra`` (e.g. odometry re-anchored: the sensitivities of
        the poses already driven become zero)."""
        self._samples = deque((pose, extra) for pose, _ in self._samples)

    def add(self, t: float, pose: Pose, extra: tuple[float, ...] = ()) -> None:
        """Record ``pose`` at ``t``. A time not after the newest replaces the newest sample (the
        same tick asked twice); samples older than ``span_s`` before ``t`` are dropped."""
        if self._t and t <= self._t[-1]:
            self._t.pop()
            self._samples.pop()
        self._t.append(t)
        self._samples.append((pose, extra))
        while len(self._t) > 2 and self._t[1] <= t - self.span_s:
            self._t.popleft()
            self._samples.popleft()

    def at(self, t: float) -> PoseAt | None:
        """The pose at ``t`` (see the module docstring); ``None`` while the history is empty."""
        ts = self._t
        if not ts:
            return None
        if t >= ts[-1]:
            pose, extra = self._samples[-1]
            return PoseAt(pose, extra, t - ts[-1])
        if t <= ts[0]:
            pose, extra = self._samples[0]
            return PoseAt(pose, extra, ts[0] - t)
        k = bisect.bisect_right(ts, t)  # ts[k-1] <= t < ts[k]
        t0, t1 = ts[k - 1], ts[k]
        (p0, e0), (p1, e1) = self._samples[k - 1], self._samples[k]
        w = (t - t0) / (t1 - t0)
        extra = tuple(a + w * (b - a) for a, b in zip(e0, e1, strict=False))
        return PoseAt(interpolate_pose(p0, p1, w), extra, 0.0)
