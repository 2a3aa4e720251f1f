"""The closed-loop simulator: world + byte-level Create + camera on one simulated clock.

The real :class:`~marknav.robot.driver.CreateDriver` (with its safety layer) talks to the
:class:`~marknav.sim.create.SimulatedCreate` through the in-process ``createsim://`` serial port,
in lock-step: each 15 ms sub-step advances the clock, the simulated Create integrates its motion
and emits its stream frame, the world checks contacts (setting the bumper bits and keeping the
robot outside obstacles), and the driver parses the bytes and feeds the safety layer — so a bump
stops the wheels within one stream period, as on the real robot. The camera renders the world
from the robot's true pose. Nothing here reads the wall clock: a run is deterministic for a seed
and runs as fast as the machine allows.

Ground truth (robot pose at every sub-step, contacts) is recorded for the run report's
per-waypoint truth (:mod:`marknav.sim.truth`), ``truth_path``, ``collisions`` and the top-down
plot.
"""

from __future__ import annotations

import bisect
import logging
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from marknav.core.clock import ManualClock
from marknav.planning.kinematics import Pose
from marknav.planning.pose_history import interpolate_pose
from marknav.robot.driver import CreateDriver
from marknav.robot.robot import Robot
from marknav.sim import world as worldmod
from marknav.sim.camera import CameraConfig, SimCamera
from marknav.sim.create import Body, SimulatedCreate
from marknav.sim.protocol_createsim import register, unregister
from marknav.sim.truth import MarkTruth, course_truth
from marknav.vision.palette import Palette

if TYPE_CHECKING:
    from marknav.runs.report import RunReport

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
    :mod:`marknav.sim.world`'s contacts, :class:`~marknav.sim.camera.SimCamera`) or ``mujoco``
    (:mod:`marknav.sim.mujoco`: physics, contacts and rendering; ``shadows`` for its lamps).
    The simulated Create's Open Interface, the driver and the safety layer are the same.
    """

    name = "sim"

    def __init__(
        self,
        world: worldmod.World,
        palette: Palette,
        *,
        model: str = "create2",
        camera: CameraConfig | None = None,
        seed: int = 0,
        robot_radius_mm: float = worldmod.CREATE_RADIUS_MM,
        command_timeout_s: float = 0.3,
        sensor_timeout_s: float = 0.2,
        wheel_base_mm: float | None = None,
        engine: str = "builtin",
        shadows: bool = True,
    ) -> None:
        self.world = world
        self.palette = palette
        self.robot_radius_mm = robot_radius_mm
        self.engine = engine
        self.clock = ManualClock()
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
        )
        self._url = register(self.create)
        self.driver = CreateDriver(
            self._url, model=model, clock=self.clock, command_timeout_s=command_timeout_s,
            sensor_timeout_s=sensor_timeout_s, wheel_base_mm=wheel_base_mm, start_pose=start,
            first_frame_timeout_s=None, settle_s=0.0, reader_thread=False,
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
        self.driver.connect()
        self._step(STREAM_PERIOD_S)  # the first sensor frame
        self.truth.record(self.clock.now(), self.create.pose)

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
    def _step(self, dt: float) -> None:
        if self._mujoco is not None:
            self._step_mujoco(dt)
            return
        self.create.step(dt)
        pose = self.create.pose
        r = self.robot_radius_mm
        # The bumper stays pressed while the robot rests against the obstacle (within its
        # travel), so the safety layer sees the bump until the robot has backed away.
        pressed = worldmod.contacts(self.world, pose, robot_radius_mm=r + BUMPER_TRAVEL_MM)
        # Anything the robot's own disc touches is also within its bumper's travel, so when
        # nothing is (most steps) there is nothing to push out of either.
        if pressed:
            found = worldmod.contacts(self.world, pose, robot_radius_mm=r)
            if any(c.depth_mm > 0.5 for c in found):
                # Touching is allowed, passing through is not: put the robot back outside.
                pose = worldmod.push_out(self.world, pose, robot_radius_mm=r)
                self.create.set_pose(pose)
                pressed = worldmod.contacts(self.world, pose,
                                            robot_radius_mm=r + BUMPER_TRAVEL_MM)
        if pressed:
            b = worldmod.bumps(pressed)
            self.create.set_bump(b.left, b.right)
            if not self._in_contact:
                c = pressed[0]
                self.truth.collisions.append({
                    "t": round(self.clock.now(), 3), "kind": c.kind, "index": c.index,
                    "x_mm": round(pose.x, 1), "y_mm": round(pose.y, 1),
                    "bump": "both" if b.left and b.right else ("left" if b.left else "right"),
                })
                log.warning("collision with %s %d at (%.0f, %.0f)", c.kind, c.index,
                            pose.x, pose.y)
            self._in_contact = True
        elif self._in_contact:
            self.create.set_bump(False, False)
            self._in_contact = False
        self.driver.process_input()

    def _step_mujoco(self, dt: float) -> None:
        """One sub-step on MuJoCo: the physics keeps the robot out of obstacles; the bumper
        is the body's contacts within its travel."""
        self.create.step(dt)
        pressed = self._mujoco.bumper()
        front = [c for c in pressed if c.bump_left or c.bump_right]
        if front:
            left = any(c.bump_left for c in front)
            right = any(c.bump_right for c in front)
            self.create.set_bump(left, right)
        elif self._in_contact:
            self.create.set_bump(False, False)
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
    world: worldmod.World,
    route: list[str],
    sides: list[str],
) -> list[MarkTruth]:
    """For each waypoint, its course mark and what the true path did there (see
    :mod:`marknav.sim.truth`: from the path alone, never from what the tree declared)."""
    return course_truth(truth.t, truth.xy, world, route, sides)
