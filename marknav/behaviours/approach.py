"""Drive toward the target while keeping it in the middle of the image (paper §4.6, first step).

"If the distance between the mobile robot and the nearest mark is greater than a desired
threshold then the mobile robot is moving straight to the mark with an effort to hold the center
of the mark (in the image) in the center of the image."

Steering is proportional to the angle of the mark's centre off the optical axis, taken from the
pixel error e = x_px − c_x: α = atan(−e / f) (positive to the left), ω = K·α with K =
``steer_gain`` (1/s), capped at ``max_turn_rate_deg_s``. The forward speed ramps from
``approach_speed_mm_s`` down to ``min_speed_fraction`` of it over the last ``slow_band_mm`` before
the bypass threshold, and is multiplied by cos α so the robot turns before it runs. Wheel speeds
are v ∓ ω·b/2 (eqs. 25–27), scaled together when one exceeds ``robot.max_speed_mm_s``
(:func:`marknav.planning.kinematics.scale_to_limit`).

With ``navigation.approach_aim: side`` the aim moves from the mark's centre to the point
``clearance_mm`` beside it on its pass side: α is shifted by σ·atan(clearance / d) (σ = +1 to the
left for a mark passed on its left). The robot then heads for where it will pass instead of at
the mark, which keeps it clear of a mark it just passed when the route turns back past it.

Other marks are obstacles on the way to the target: when the heading toward the aim would bring
the robot's centre within ``clearance_mm + bypass_margin_mm`` of a mark ahead of it and nearer
than the target — one already passed (as recorded when it was passed) or one remembered from the
camera (``/marknav/known``) — the heading turns to the tangent of that circle on the aim's side
(:func:`keep_clear`). A route that doubles back past a mark (a figure eight) then skirts it
instead of grazing it, and a far target is not approached through a nearer mark.

The pixels steer only while they show the present: a sighting from a frame processed in the tick
it was captured (no latency). A late frame shows where the mark was relative to where the robot
was at capture time; then, as between frames, the mark's world estimate (placed with the pose at
capture time) and the odometry pose now give its distance and bearing. SUCCESS when the
estimated distance along the heading (the paper's d_yp) is at most ``bypass_distance_mm``;
FAILURE when the frames of the last ``lost_after_s`` (by capture time) have not shown the target.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.base import DrivingBehaviour, SetupError, check_positive, pick
from marknav.behaviours.target import MEMORY_MIN_SEEN
from marknav.planning.kinematics import WheelSpeeds, scale_to_limit, to_robot_frame

__all__ = ["THRESHOLD_SPEED_FRACTION", "UNSETTLED_THRESHOLD_FLOOR", "ApproachWhileCentring",
           "centring_command", "keep_clear", "unsettled_factor"]

#: A sighting at most this old (s) is the present: its pixels steer (a tick takes no time in
#: the simulator; on a real robot a frame is always some milliseconds old, and then the
#: odometry since capture, not the pixels, says where the mark is now).
FRESH_S = 1e-3

#: A passed or remembered mark this close to the target's estimate is the target itself.
SAME_MARK_MM = 400.0

#: Speed at the bypass threshold as a fraction of the approach speed; the bypass cruises at the
#: same fraction by default, so the hand-over is smooth.
THRESHOLD_SPEED_FRACTION = 0.8


#: While the range law is still being learnt, the bypass threshold shrinks to at most this
#: fraction of ``bypass_distance_mm`` (see :func:`unsettled_factor`).
UNSETTLED_THRESHOLD_FLOOR = 0.75


def unsettled_factor(frame: keys.FrameInfo | None) -> float:
    """How much closer than ``bypass_distance_mm`` the bypass starts while the range law is
    uncertain: ``exp(−σ)`` of the law's scale σ (``FrameInfo.range_sigma``), at least
    :data:`UNSETTLED_THRESHOLD_FLOOR`; 1 for a fixed law.

    A law that reads short (the mark is farther than it says) reaches the threshold early, on
    the least driven distance, so the learner has the least to learn from; a law that reads
    long has driven farther (by the same factor) and is usually settled by then. Holding the
    decision a little while σ is large gives the short law the metres it needs (a law 25 %
    short, its first mark 1.4 m ahead: no fit before the bypass, three bumps), and costs a
    settled law nothing (σ ≈ 0.02: 2 %)."""
    sigma = frame.range_sigma if frame is not None else 0.0
    if not sigma > 0.0:
        return 1.0
    return max(UNSETTLED_THRESHOLD_FLOOR, math.exp(-sigma))


def centring_command(
    *,
    angle_rad: float,
    forward_mm: float,
    speed_mm_s: float,
    bypass_distance_mm: float,
    steer_gain: float,
    max_turn_rate: float,
    slow_band_mm: float,
    min_speed_fraction: float,
    wheel_base_mm: float,
    max_wheel_mm_s: float,
) -> WheelSpeeds:
    """Wheel speeds that steer toward a mark ``angle_rad`` off the heading (positive left).

    ω = clamp(K·α, ±ω_max); v = speed · ramp · max(cos α, 0), ramp going linearly from 1 at
    ``slow_band_mm`` beyond the threshold to ``min_speed_fraction`` at it. Pure function.
    """
    omega = max(-max_turn_rate, min(max_turn_rate, steer_gain * angle_rad))
    beyond = (forward_mm - bypass_distance_mm) / slow_band_mm if slow_band_mm > 0 else 1.0
    ramp = min(1.0, max(min_speed_fraction,
                        min_speed_fraction + (1.0 - min_speed_fraction) * beyond))
    v = speed_mm_s * ramp * max(math.cos(angle_rad), 0.0)
    half = 0.5 * wheel_base_mm
    return scale_to_limit(WheelSpeeds(left=v - omega * half, right=v + omega * half),
                          max_wheel_mm_s)


def keep_clear(angle_rad: float, obstacles: list[tuple[float, float]], keep_mm: float,
               reach_mm: float) -> float:
    """The heading (robot frame, positive left) nearest ``angle_rad`` whose ray keeps
    ``keep_mm`` from every obstacle point ``(forward, left)`` ahead within ``reach_mm``.

    An obstacle whose closest approach along the ray is behind the robot or beyond ``reach_mm``
    is ignored. Otherwise, if the ray passes within ``keep_mm``, the heading turns to the tangent
    of the keep-out circle on the side the ray was heading (the nearest such obstacle wins);
    from inside the circle, it turns straight away from it. Pure function.
    """
    best = angle_rad
    nearest = math.inf
    for f, lft in obstacles:
        rho = math.hypot(f, lft)
        if rho > reach_mm or rho >= nearest:
            continue
        along = f * math.cos(angle_rad) + lft * math.sin(angle_rad)
        if along <= 0.0:
            continue
        across = -f * math.sin(angle_rad) + lft * math.cos(angle_rad)  # > 0: obstacle left
        if abs(across) >= keep_mm:
            continue
        bearing = math.atan2(lft, f)
        if rho <= keep_mm:
            turned = bearing - math.copysign(0.5 * math.pi, across)
        else:
            turned = bearing - math.copysign(math.asin(keep_mm / rho), across)
        best, nearest = turned, rho
    return best


class ApproachWhileCentring(DrivingBehaviour):
    """Approach the target, keeping it centred in the image; SUCCESS at the bypass threshold.

    Args (each ``None`` takes the mission's value):
        speed_mm_s: cruising speed (``navigation.approach_speed_mm_s``).
        bypass_distance_mm: threshold (``navigation.bypass_distance_mm``).
        lost_after_s: FAILURE when the target is unseen this long (``navigation.lost_after_s``).
        steer_gain: turn rate per radian off-centre, 1/s (2.0: the error halves in ~0.35 s).
        max_turn_rate_deg_s: cap on the turn rate.
        slow_band_mm: slow down over this distance before the threshold.
        min_speed_fraction: speed at the threshold, as a fraction of ``speed_mm_s`` (0.8, the
            bypass's default cruising fraction).

    Setup: ``robot``, ``clock``, ``mission`` (wheel base, speed limit, focal length).
    """

    READS: ClassVar[tuple[str, ...]] = (keys.TARGET, keys.FRAME, keys.PASSED, keys.KNOWN)

    def __init__(
        self,
        name: str = "Approach",
        *,
        speed_mm_s: float | None = None,
        bypass_distance_mm: float | None = None,
        lost_after_s: float | None = None,
        steer_gain: float = 2.0,
        max_turn_rate_deg_s: float = 60.0,
        slow_band_mm: float = 500.0,
        min_speed_fraction: float = THRESHOLD_SPEED_FRACTION,
    ) -> None:
        super().__init__(name)
        self._speed = check_positive(speed_mm_s, "speed_mm_s")
        self._threshold = check_positive(bypass_distance_mm, "bypass_distance_mm")
        self._lost = check_positive(lost_after_s, "lost_after_s")
        self.steer_gain = float(check_positive(steer_gain, "steer_gain") or 0.0)
        self.max_turn_rate = math.radians(
            check_positive(max_turn_rate_deg_s, "max_turn_rate_deg_s") or 0.0)
        if not (math.isfinite(slow_band_mm) and slow_band_mm >= 0):
            raise ValueError(f"slow_band_mm must be a number >= 0, got {slow_band_mm!r}")
        if not 0.0 < min_speed_fraction <= 1.0:
            raise ValueError(f"min_speed_fraction must be in (0, 1], got {min_speed_fraction!r}")
        self.slow_band_mm = float(slow_band_mm)
        self.min_speed_fraction = float(min_speed_fraction)
        self.settings: dict[str, float] = {}

    def configure(self, **kwargs: Any) -> None:
        m = self.mission
        owner = self._owner
        self.settings = {
            "speed_mm_s": pick(self._speed, m.navigation.approach_speed_mm_s if m else None,
                               owner=owner, what="approach speed"),
            "bypass_distance_mm": pick(self._threshold,
                                       m.navigation.bypass_distance_mm if m else None,
                                       owner=owner, what="bypass_distance_mm"),
            "lost_after_s": pick(self._lost, m.navigation.lost_after_s if m else None,
                                 owner=owner, what="lost_after_s"),
            "wheel_base_mm": pick(None, m.robot.wheel_base_mm if m else None, owner=owner,
                                  what="robot.wheel_base_mm"),
            "max_wheel_mm_s": pick(None, m.robot.max_speed_mm_s if m else None, owner=owner,
                                   what="robot.max_speed_mm_s"),
            "focal_px": pick(None, m.camera.focal_px if m else None, owner=owner,
                             what="camera.focal_px"),
            "aim_offset_mm": (m.navigation.clearance_mm
                              if m is not None and m.navigation.approach_aim == "side" else 0.0),
            "keep_mm": (m.navigation.clearance_mm + m.navigation.bypass_margin_mm
                        if m is not None else 0.0),
        }

    def initialise(self) -> None:
        self.feedback_message = "starting"

    def update(self) -> Status:
        if not self.settings:
            raise SetupError(f"{self._owner}: not set up (tree.setup(mission=...))")
        s = self.settings
        target = self.target()
        if target is None:
            return self.fail("no target selected")
        seen = target.sighting
        if seen is None or target.world is None:
            return self.fail(f"{target.label} not seen")
        frame: keys.FrameInfo | None = self.read(keys.FRAME)
        now = self.now()
        age = keys.unseen_s(seen, frame, now)
        if age > s["lost_after_s"]:
            return self.fail(f"lost {target.label}: unseen for {age:.2f} s")
        if frame is not None and seen.t >= frame.t and now - seen.t <= FRESH_S:
            forward = seen.forward_mm
            angle = math.atan2(-seen.pixel_error, s["focal_px"])
        else:  # between frames: dead-reckon the mark from odometry
            forward, left = to_robot_frame(self.robot.pose(), target.world)
            angle = math.atan2(left, forward)
        # not on a mark mostly out of view: its range is of a part (random missions 91, 119)
        if (forward <= s["bypass_distance_mm"] * unsettled_factor(frame)
                and not keys.centre_outside_image(seen)):
            self.feedback_message = (f"{target.label} at {forward / 1000.0:.2f} m: "
                                     "bypass threshold reached")
            return Status.SUCCESS
        if s["aim_offset_mm"] > 0.0:  # aim beside the mark, on its pass side
            sigma = 1.0 if target.side == "left" else -1.0
            angle += sigma * math.atan2(s["aim_offset_mm"], forward)
        if s["keep_mm"] > 0.0:
            angle = self._around_others(angle, target, forward)
        cmd = centring_command(
            angle_rad=angle, forward_mm=forward, speed_mm_s=s["speed_mm_s"],
            bypass_distance_mm=s["bypass_distance_mm"], steer_gain=self.steer_gain,
            max_turn_rate=self.max_turn_rate, slow_band_mm=self.slow_band_mm,
            min_speed_fraction=self.min_speed_fraction, wheel_base_mm=s["wheel_base_mm"],
            max_wheel_mm_s=s["max_wheel_mm_s"],
        )
        self.drive(left=cmd.left, right=cmd.right)
        deg = math.degrees(angle)
        self.feedback_message = (f"{target.label}: {forward / 1000.0:.2f} m ahead, "
                                 f"{abs(deg):.0f}° {'left' if deg > 0 else 'right'}, "
                                 f"{cmd.linear:.0f} mm/s")
        return Status.RUNNING

    def _around_others(self, angle: float, target: keys.Target, forward: float) -> float:
        """Turn ``angle`` around the marks passed or remembered (not the target itself)."""
        passed: tuple[keys.PassedWaypoint, ...] = self.read(keys.PASSED, ()) or ()
        known: tuple[keys.KnownMark, ...] = self.read(keys.KNOWN, ()) or ()
        if not passed and not known:
            return angle
        assert target.world is not None
        tx, ty = target.world
        pose = self.robot.pose()
        reach2 = forward * forward
        points = [(p.mark_x, p.mark_y) for p in passed] + [
            k.world for k in known if k.seen >= MEMORY_MIN_SEEN]
        obstacles = [to_robot_frame(pose, xy) for xy in points
                     if (xy[0] - pose.x) ** 2 + (xy[1] - pose.y) ** 2 <= reach2
                     and math.hypot(xy[0] - tx, xy[1] - ty) >= SAME_MARK_MM]
        return keep_clear(angle, obstacles, self.settings["keep_mm"], reach_mm=forward)
