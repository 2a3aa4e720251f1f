"""Wheel odometry from the Create's sensor stream.

- Create 2: from the cumulative encoder counts (packets 43/44, Create 2 OI spec "Left/Right
  Encoder Counts"): signed 16-bit counters that wrap, converted with
  mm = counts · π · 72 / 508.8. Packets 19/20 are not used: firmware before 3.3.0 (distance) and
  up to 3.4.0 (angle) reports them wrongly (spec Appendix B).
- Create 1: from distance (packet 19, mm) and angle (packet 20, degrees, CCW positive), each the
  motion since the previous report; the angle's 1° resolution limits slow turns.

Each update's wheel travel is integrated as one constant-curvature arc with
:func:`marknav.planning.kinematics.integrate_pose` (paper eqs. 25–30, integrated exactly).

Wheels whose effective diameters differ make the heading drift in a way encoders cannot see.
The right wheel's travel is multiplied by ``right_scale`` (1 until calibrated), and a shadow pose
integrated with a slightly larger scale gives :meth:`Odometry.sensitivity`, the pose's derivative
with respect to that scale since the last :meth:`Odometry.anchor`: what
:mod:`marknav.planning.wheel_ratio` needs to calibrate the scale from mark sightings.
"""

from __future__ import annotations

import math

from marknav.planning.kinematics import Pose, integrate_pose, wrap_angle
from marknav.robot.packets import Model, SensorState

__all__ = ["MM_PER_COUNT", "SHADOW_STEP", "Odometry", "counts_delta", "counts_to_mm",
           "default_start_pose"]

#: Create 2 encoder resolution: wheel circumference π·72 mm over 508.8 counts per revolution.
MM_PER_COUNT = math.pi * 72.0 / 508.8

#: Relative step of the right wheel's scale for the shadow pose (finite-difference sensitivity).
SHADOW_STEP = 0.01


def counts_delta(new: int, old: int) -> int:
    """Signed change of a 16-bit wrapping counter, in −32768..32767 (the short way round)."""
    return (new - old + 0x8000) % 0x10000 - 0x8000


def counts_to_mm(counts: float) -> float:
    """Encoder counts → mm of wheel travel."""
    return counts * MM_PER_COUNT


def default_start_pose() -> Pose:
    """(0, 0) facing +y (θ = π/2), the architecture's default start."""
    return Pose(0.0, 0.0, math.pi / 2)


class Odometry:
    """Dead reckoning from successive :class:`SensorState` values (one call per stream frame).

    ``wheel_base_mm`` defaults to the model's (235 mm Create 2, 258 mm Create 1). On Create 2 the
    first state with encoder counts only sets the reference; each later one adds the wrapped
    count differences. ``distance_mm`` is the total signed path length of the robot centre.
    """

    def __init__(self, model: Model, *, wheel_base_mm: float | None = None,
                 pose: Pose | None = None, scale: float = 1.0) -> None:
        if not (math.isfinite(scale) and 0.5 < scale < 2.0):
            raise ValueError(f"odometry scale must be in (0.5, 2), got {scale!r}")
        self.model = model
        #: Ground travel per reported mm, both wheels (``marknav calibrate-odometry``).
        self.scale = float(scale)
        self.wheel_base_mm = float(wheel_base_mm or model.wheel_base_mm)
        if self.wheel_base_mm <= 0:
            raise ValueError(f"wheel_base_mm must be positive, got {wheel_base_mm}")
        self._pose = pose or default_start_pose()
        self._shadow = self._pose
        self.right_scale = 1.0
        self._last_counts: tuple[int, int] | None = None
        self.distance_mm = 0.0
        self.updates = 0

    @property
    def pose(self) -> Pose:
        return self._pose

    def reset(self, pose: Pose | None = None) -> None:
        """Set the pose (default: the start pose) and zero ``distance_mm``. The encoder reference
        is kept, so motion reported by the next frame is not lost."""
        self._pose = pose or default_start_pose()
        self._shadow = self._pose
        self.distance_mm = 0.0

    def sensitivity(self) -> tuple[float, float, float]:
        """∂(x, y, θ)/∂s since the last :meth:`anchor`: how the pose would move per unit
        relative change of the right wheel's scale ``s``."""
        p, q = self._pose, self._shadow
        return ((q.x - p.x) / SHADOW_STEP, (q.y - p.y) / SHADOW_STEP,
                wrap_angle(q.theta - p.theta) / SHADOW_STEP)

    def anchor(self) -> None:
        """Restart :meth:`sensitivity` from zero at the current pose."""
        self._shadow = self._pose

    def scale_right_wheel(self, factor: float) -> None:
        """Multiply ``right_scale`` by ``factor`` (a calibration step) and re-anchor."""
        if not (math.isfinite(factor) and 0.5 < factor < 2.0):
            raise ValueError(f"wheel scale factor must be in (0.5, 2), got {factor!r}")
        self.right_scale *= factor
        self.anchor()

    def update(self, state: SensorState) -> Pose:
        """Integrate the motion reported by one frame's ``state``; return the new pose."""
        if self.model is Model.CREATE2:
            counts = (state.encoder_left, state.encoder_right)
            if self._last_counts is None:
                self._last_counts = counts
                return self._pose
            left = counts_to_mm(counts_delta(counts[0], self._last_counts[0]))
            right = counts_to_mm(counts_delta(counts[1], self._last_counts[1]))
            self._last_counts = counts
        else:
            dtheta = math.radians(state.angle_deg)
            half = 0.5 * dtheta * self.wheel_base_mm
            left = state.distance_mm - half
            right = state.distance_mm + half
        return self.advance(left_mm=left, right_mm=right)

    def advance(self, *, left_mm: float, right_mm: float) -> Pose:
        """Integrate wheel travels (mm) as one constant-curvature arc."""
        # Distances over a unit time step are speeds over that step: the arc is the same.
        left_mm *= self.scale
        right_mm *= self.right_scale * self.scale
        self._pose = integrate_pose(self._pose, left=left_mm, right=right_mm, dt=1.0,
                                    wheel_base_mm=self.wheel_base_mm)
        self._shadow = integrate_pose(self._shadow, left=left_mm,
                                      right=right_mm * (1.0 + SHADOW_STEP), dt=1.0,
                                      wheel_base_mm=self.wheel_base_mm)
        self.distance_mm += 0.5 * (left_mm + right_mm)
        self.updates += 1
        return self._pose
