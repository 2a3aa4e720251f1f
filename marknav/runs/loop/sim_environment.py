"""The closed-loop simulator: world + byte-level Create + camera on one simulated clock.

The real :class:`~marknav.robot.driver.CreateDriver` (with its safety layer) talks to the
:class:`~marknav.sim.simulated_create.SimulatedCreate` through the in-process ``createsim://``
serial port,
in lock-step: each 15 ms sub-step advances the clock, the simulated Create integrates its motion
and emits its stream frame, the world checks contacts (setting the bumper bits and keeping the
robot outside obstacles), and the driver parses the bytes and feeds the safety layer — so a bump
stops the wheels within one stream period, as on the real robot. The camera renders the world
from the robot's true pose. Nothing here reads the wall clock: a run is deterministic for a seed
and runs as fast as the machine allows.

The world's conditions reach the robot (acceleration, top speed, encoder scale and noise, command
delay, friction patches under each wheel) and the camera (frame rate, drops, exposure, printed
marks; frames placed at their capture time with the true pose then, :meth:`GroundTruth.pose_at`).
The world's timed fault events (:class:`~marknav.sim.world.FaultEvent`) are set on the simulated
Create's sensors when their time comes, so the driver reads them from the stream bytes as it
would read a real cliff or wheel drop.

Ground truth (robot pose at every sub-step, contacts) is recorded for the run report's
per-waypoint truth (:mod:`marknav.runs.metrics.truth`), ``truth_path``, ``collisions`` and the
top-down
plot.
"""

from __future__ import annotations

import bisect
import logging
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from marknav.core.clock import ManualClock
from marknav.planning.kinematics import Pose
from marknav.planning.pose_history import interpolate_pose
from marknav.robot.driver import FIRST_FRAME_TIMEOUT_S, CreateDriver
from marknav.robot.robot import Robot
from marknav.runs.metrics.truth import MarkTruth, course_truth
from marknav.sim.builtin_camera import CameraConfig, SimCamera
from marknav.sim.protocol_createsim import register, unregister
from marknav.sim.simulated_create import Body, SimulatedCreate
from marknav.sim.world.contacts import bumps, contacts, push_out
from marknav.sim.world.schema import CREATE_RADIUS_MM, FaultEvent, World
from marknav.vision.palette import Palette

if TYPE_CHECKING:
    from marknav.runs.records.report import RunReport

log = logging.getLogger(__name__)

STREAM_PERIOD_S = 0.015
#: How far the bumper travels: it reads pressed while an obstacle is this close to the rim.
BUMPER_TRAVEL_MM = 3.0


@dataclass
class GroundTruth:
    """What really happened: poses over time, collisions and where they were."""

    t: list[float] = field(default_factory=list)
    xy: list[tuple[float, float]] = field(default_factory=list)
    theta: list[float] = field(default_factory=list)
    collisions: list[dict[str, Any]] = field(default_factory=list)

    def record(self, t: float, pose: Pose) -> None:
        self.t.append(t)
        self.xy.append((pose.x, pose.y))
        self.theta.append(pose.theta)

    def pose_at(self, t: float) -> Pose:
        """The true pose at time ``t``, interpolated between the recorded sub-steps (the first
        pose before the first record, the last after the last)."""
        ts = self.t
        if not ts:
            raise ValueError("no pose recorded yet")
        k = bisect.bisect_right(ts, t)
        if k == 0:
            return Pose(*self.xy[0], self.theta[0])
        if k == len(ts):
            return Pose(*self.xy[-1], self.theta[-1])
        t0, t1 = ts[k - 1], ts[k]
        w = (t - t0) / (t1 - t0) if t1 > t0 else 1.0
        return interpolate_pose(Pose(*self.xy[k - 1], self.theta[k - 1]),
                                Pose(*self.xy[k], self.theta[k]), w)

    def trajectory(self, t0: float | None = None, t1: float | None = None) -> np.ndarray:
        """Positions (N×2) between times ``t0`` and ``t1`` (inclusive; None = open)."""
        ts = np.asarray(self.t)
        xy = np.asarray(self.xy, dtype=float).reshape(-1, 2)
        keep = np.ones(len(ts), dtype=bool)
        if t0 is not None:
            keep &= ts >= t0
        if t1 is not None:
            keep &= ts <= t1
        return xy[keep]


class SimEnvironment:
    """Robot, camera and clock of a simulated run (see the module docstring).

    ``engine`` moves the robot and draws the camera's frames: ``builtin`` (the kinematic body,
    :mod:`marknav.sim.world`'s contacts, :class:`~marknav.sim.builtin_camera.SimCamera`) or
    ``mujoco``
    (:mod:`marknav.sim.mujoco`: physics, contacts and rendering; ``shadows`` for its lamps).
    The simulated Create's Open Interface, the driver and the safety layer are the same.
    """

    name = "sim"

    def __init__(
        self,
        world: World,
        palette: Palette,
        *,
        model: str = "create2",
        camera: CameraConfig | None = None,
        seed: int = 0,
        robot_radius_mm: float = CREATE_RADIUS_MM,
        command_timeout_s: float = 0.3,
        sensor_timeout_s: float = 0.2,
        wheel_base_mm: float | None = None,
        engine: str = "builtin",
        shadows: bool = True,
        odometry_scale: float = 1.0,
    ) -> None:
        self.world = world
        self.palette = palette
        self.robot_radius_mm = robot_radius_mm
        self.engine = engine
        self.clock = ManualClock()
        self._held_bump: tuple[bool, bool] = (False, False)
        self._bumper: tuple[bool, bool] = (False, False)  # bits last set on the simulated Create
        c = world.conditions
        start = world.robot.pose()
        cam_config = camera or CameraConfig()
        self._mujoco: Any = None
        body: Body | None = None
        if engine == "mujoco":
            from marknav.sim.mujoco.body import MujocoBody
            from marknav.sim.mujoco.model import CreateSpec

            spec = CreateSpec(radius_mm=robot_radius_mm,
                              wheel_base_mm=wheel_base_mm or CreateSpec().wheel_base_mm)
            self._mujoco = body = MujocoBody(world, tuple(palette), camera=cam_config,
                                             robot=spec, shadows=shadows)
        elif engine != "builtin":
            raise ValueError(f"unknown simulator engine {engine!r} (builtin, mujoco)")
        self.create = SimulatedCreate(
            model=model, clock=self.clock, pose=start, wheel_base_mm=wheel_base_mm,
            left_scale=1.0 - c.wheel_slip,
            right_scale=(1.0 + c.wheel_mismatch) * (1.0 - c.wheel_slip),
            seed=seed, body=body,
            accel_mm_s2=c.accel_mm_s2 or None,
            top_speed_mm_s=c.top_speed_mm_s,
            encoder_scale=c.encoder_scale,
            encoder_noise_counts=c.encoder_noise_counts,
            command_delay_s=c.command_delay_ms / 1000.0,
            ground_fn=self._ground if world.patches else None,
        )
        self._events = sorted(world.events, key=lambda e: e.t_s)
        self._active: list[tuple[float, FaultEvent]] = []  # (end time, event)
        self._url = register(self.create)
        self.driver = CreateDriver(
            self._url, model=model, clock=self.clock, command_timeout_s=command_timeout_s,
            sensor_timeout_s=sensor_timeout_s, wheel_base_mm=wheel_base_mm, start_pose=start,
            # connect waits, on the simulated clock, for the stream request to cross the link
            # and the first frame to come back, as it does on a real port
            first_frame_timeout_s=FIRST_FRAME_TIMEOUT_S + self.create.command_delay_s,
            wait_input=self._wait_link, settle_s=0.0, reader_thread=False, wake_pulse_s=0.0,
            odometry_scale=odometry_scale,
        )
        self.truth = GroundTruth()
        self.camera: Any
        if self._mujoco is not None:
            from marknav.sim.mujoco.camera import MujocoCamera

            try:
                self.camera = MujocoCamera(self._mujoco, clock=self.clock, seed=seed)
            except BaseException:
                self.driver.close()
                unregister(self._url.split("://", 1)[1])
                raise
        else:
            # the frame of capture time t shows the true pose at t (latency, processing time)
            self.camera = SimCamera(world, palette, pose_fn=lambda: self.create.pose,
                                    clock=self.clock, config=cam_config, seed=seed,
                                    pose_at=self.truth.pose_at)
        self._in_contact = False
        self._closed = False
        self._event_dicts: list[dict[str, Any]] = []
        try:
            self.driver.connect()  # returns with the first sensor frame read
        except BaseException:
            self.close()
            raise

    @property
    def robot(self) -> Robot:
        return self.driver

    # -- Environment protocol -------------------------------------------------------------
    def poll(self) -> None:
        self.driver.process_input()

    def advance(self, until: float) -> None:
        while self.clock.now() < until - 1e-9:
            self._step(min(STREAM_PERIOD_S, until - self.clock.now()))
            self.truth.record(self.clock.now(), self.create.pose)

    def safety_events(self) -> list[dict[str, Any]]:
        # The layer only appends: convert the new events (the run loop asks every cycle).
        events, done = self.driver.safety_events, self._event_dicts
        if len(events) > len(done):
            done.extend(e.to_dict() for e in events[len(done):])
        return list(done)

    def finish(self, report: RunReport) -> None:
        report.collisions = len(self.truth.collisions)

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            self.driver.close()
        finally:
            self.camera.close()
            unregister(self._url.split("://", 1)[1])

    # -- internals ------------------------------------------------------------------------
    def _wait_link(self, dt: float) -> None:
        """The driver waits ``dt`` s for input: run the world to the later of that and the next
        15 ms sensor tick (no stream frame leaves the robot between ticks)."""
        self._step(max(dt, self.create.next_tick_time() - self.clock.now()))
        self.truth.record(self.clock.now(), self.create.pose)

    def _ground(self, pose: Pose) -> tuple[float, float]:
        """Each wheel's share of its travel that reaches the ground where it stands (1 off every
        friction patch): the wheels sit half the wheel base to each side of the centre."""
        half = 0.5 * self.create.wheel_base_mm
        lx, ly = -math.sin(pose.theta) * half, math.cos(pose.theta) * half
        out = []
        for sx, sy in ((pose.x + lx, pose.y + ly), (pose.x - lx, pose.y - ly)):
            f = 1.0
            for patch in self.world.patches:
                if patch.contains(sx, sy):
                    f = min(f, 1.0 - patch.slip)
            out.append(f)
        return (out[0], out[1])

    def _apply_events(self, now: float) -> None:
        """Start the fault events whose time has come, end those that lasted their duration."""
        changed = False
        while self._events and self._events[0].t_s <= now + 1e-9:
            ev = self._events.pop(0)
            end = math.inf if ev.duration_s is None else ev.t_s + ev.duration_s
            self._active.append((end, ev))
            log.warning("fault event at %.3f s: %s (%s)", now, ev.fault, ev.side)
            changed = True
        ended = [a for a in self._active if a[0] <= now + 1e-9]
        if ended:
            self._active = [a for a in self._active if a[0] > now + 1e-9]
            changed = True
        if changed:
            self._set_faults([ev for _, ev in self._active])

    def _set_faults(self, active: list[FaultEvent]) -> None:
        def on(fault: str, side: str) -> bool:
            return any(e.fault == fault and e.side in (side, "both") for e in active)

        sim = self.create
        sim.set_cliff(left=on("cliff", "left"), front_left=on("cliff", "front_left"),
                      front_right=on("cliff", "front_right"), right=on("cliff", "right"))
        sim.set_wheel_drop(left=on("wheel_drop", "left"), right=on("wheel_drop", "right"))
        sim.set_overcurrent(left_wheel=on("overcurrent", "left"),
                            right_wheel=on("overcurrent", "right"))
        sim.set_low_battery(any(e.fault == "low_battery" for e in active))
        self._held_bump = (on("bump", "left"), on("bump", "right"))
        # the bumper bits at once (contacts are added after the step's motion)
        left, right = self._held_bump
        if left or right or self._bumper != (False, False):
            sim.set_bump(left, right)
            self._bumper = (left, right)

    def _step(self, dt: float) -> None:
        self._apply_events(self.clock.now() + dt)
        if self._mujoco is not None:
            self._step_mujoco(dt)
            return
        self.create.step(dt)
        pose = self.create.pose
        r = self.robot_radius_mm
        # The bumper stays pressed while the robot rests against the obstacle (within its
        # travel), so the safety layer sees the bump until the robot has backed away.
        pressed = contacts(self.world, pose, robot_radius_mm=r + BUMPER_TRAVEL_MM)
        # Anything the robot's own disc touches is also within its bumper's travel, so when
        # nothing is (most steps) there is nothing to push out of either.
        if pressed:
            found = contacts(self.world, pose, robot_radius_mm=r)
            if any(c.depth_mm > 0.5 for c in found):
                # Touching is allowed, passing through is not: put the robot back outside.
                pose = push_out(self.world, pose, robot_radius_mm=r)
                self.create.set_pose(pose)
                pressed = contacts(self.world, pose,
                                            robot_radius_mm=r + BUMPER_TRAVEL_MM)
        held_left, held_right = self._held_bump  # a bump event: pinned, not a collision
        left, right = held_left, held_right
        if pressed:
            b = bumps(pressed)
            left, right = left or b.left, right or b.right
            if not self._in_contact:
                c = pressed[0]
                self.truth.collisions.append({
                    "t": round(self.clock.now(), 3), "kind": c.kind, "index": c.index,
                    "x_mm": round(pose.x, 1), "y_mm": round(pose.y, 1),
                    "bump": "both" if b.left and b.right else ("left" if b.left else "right"),
                })
                log.warning("collision with %s %d at (%.0f, %.0f)", c.kind, c.index,
                            pose.x, pose.y)
        self._in_contact = bool(pressed)
        if left or right or self._bumper != (left, right):
            self.create.set_bump(left, right)
            self._bumper = (left, right)
        self.driver.process_input()

    def _step_mujoco(self, dt: float) -> None:
        """One sub-step on MuJoCo: the physics keeps the robot out of obstacles; the bumper
        is the body's contacts within its travel."""
        self.create.step(dt)
        pressed = self._mujoco.bumper()
        front = [c for c in pressed if c.bump_left or c.bump_right]
        # the bumper: the body's contacts, or a bump event held (the world's fault events)
        left = any(c.bump_left for c in front) or self._held_bump[0]
        right = any(c.bump_right for c in front) or self._held_bump[1]
        if left or right or self._bumper != (left, right):
            self.create.set_bump(left, right)
            self._bumper = (left, right)
        if pressed and not self._in_contact:
            c = pressed[0]
            pose = self.create.pose
            self.truth.collisions.append({
                "t": round(self.clock.now(), 3), "kind": c.kind, "index": c.index,
                "x_mm": round(pose.x, 1), "y_mm": round(pose.y, 1),
                "bump": ("both" if c.bump_left and c.bump_right else "left" if c.bump_left
                         else "right" if c.bump_right else "none"),
            })
            log.warning("collision with %s %d at (%.0f, %.0f)", c.kind, c.index, pose.x, pose.y)
        self._in_contact = bool(pressed)
        self.driver.process_input()

    def __enter__(self) -> SimEnvironment:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def waypoint_truth(
    truth: GroundTruth,
    world: World,
    route: list[str],
    sides: list[str],
) -> list[MarkTruth]:
    """For each waypoint, its course mark and what the true path did there (see
    :mod:`marknav.runs.metrics.truth`: from the path alone, never from what the tree declared)."""
    return course_truth(truth.t, truth.xy, world, route, sides)
