"""The Create 2 as a MuJoCo body: what the simulated Create's Open Interface moves.

:class:`MujocoBody` is a :class:`marknav.sim.simulated_create.Body`: :meth:`~MujocoBody.drive` sets
the
two wheel actuators' target speeds (commanded mm/s over the nominal 36 mm tyre radius, as the
Create's own wheel controller regulates wheel rotation from its encoders) and steps the physics
for the time asked; it returns each wheel's joint rotation times the nominal radius — the
encoder's view, which sees neither slip nor a worn tyre. The true pose is the body's pose;
:meth:`~MujocoBody.bumper` reads the bumper from the body's contacts (within the bumper's
travel) with the same arcs as the built-in engine (:data:`marknav.sim.world.BUMPER_HALF_ARC_DEG`,
:data:`~marknav.sim.world.BOTH_BUMPS_HALF_ANGLE_DEG`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

from marknav.core.errors import InputError
from marknav.planning.kinematics import Pose, wrap_angle
from marknav.sim.builtin_camera import CameraConfig
from marknav.sim.lens import LensWarp, lens_warp
from marknav.sim.mujoco.gl import import_mujoco
from marknav.sim.mujoco.model import CREATE2, DEFAULT_CAMERA, TIMESTEP_S, CreateSpec, build_model
from marknav.sim.world.contacts import bumper_sides
from marknav.sim.world.schema import World
from marknav.vision.palette import ColourRange

__all__ = ["BumperContact", "MujocoBody"]

#: Time the robot is given to settle on its wheels and caster before the run starts.
SETTLE_S = 0.3


@dataclass(frozen=True)
class BumperContact:
    """The body touching an obstacle (``kind`` ``mark``, ``wall``, ``box``, ``occluder``,
    ``distractor``; ``index`` into the world's or scene's list, −1 for the room's walls):
    where (mm), its direction from the centre relative to the heading (rad, left positive) and
    the gap (mm; ≤ 0 touching)."""

    kind: str
    index: int
    x_mm: float
    y_mm: float
    angle_rad: float
    gap_mm: float

    @property
    def bump_left(self) -> bool:
        return bumper_sides(self.angle_rad)[0]

    @property
    def bump_right(self) -> bool:
        return bumper_sides(self.angle_rad)[1]


class MujocoBody:
    """A Create 2 in a MuJoCo model of ``world`` (see the module docstring).

    ``camera`` is the robot's camera; with a lens in the world's conditions, ``canvas`` is the
    larger ideal image MuJoCo renders and ``warp`` distorts it (``camera`` then carries the
    lens's principal point). ``shadows`` turns the lamps' shadows on. The model's data
    (``model``, ``data``) is shared with :class:`marknav.sim.mujoco.camera.MujocoCamera`.
    """

    def __init__(self, world: World, palette: tuple[ColourRange, ...], *,
                 camera: CameraConfig = DEFAULT_CAMERA, robot: CreateSpec = CREATE2,
                 shadows: bool = True, render: bool = True) -> None:
        mj = import_mujoco(rendering=render)
        self.mj = mj
        self.spec = robot
        self.world = world
        # A lens (world.conditions.lens): MuJoCo renders the ideal pinhole image on a larger
        # canvas, which the camera warps (as the built-in renderer does).
        lens = world.conditions.lens
        self.warp: LensWarp | None = None
        self.camera = self.canvas = camera
        if not lens.ideal:
            self.warp = lens_warp(camera.width, camera.height, camera.focal_px, lens,
                                  (camera.cx, camera.cy))
            intr = self.warp.intrinsics
            self.camera = replace(camera, principal=(intr.cx, intr.cy))
            cw, ch = self.warp.canvas_size
            self.canvas = replace(camera, width=cw, height=ch,
                                  principal=self.warp.canvas_principal)
        built = build_model(world, palette, camera=self.canvas, robot=robot, shadows=shadows)
        try:
            self.model: Any = mj.MjModel.from_xml_string(built.xml, built.assets)
        except ValueError as exc:
            raise InputError(f"MuJoCo cannot build this world: {exc}", field="--engine") from None
        self.data: Any = mj.MjData(self.model)
        m = self.model
        name = mj.mjtObj
        self._body = mj.mj_name2id(m, name.mjOBJ_BODY, "create")
        self._chassis = mj.mj_name2id(m, name.mjOBJ_GEOM, "chassis")
        jl = mj.mj_name2id(m, name.mjOBJ_JOINT, "left_wheel")
        jr = mj.mj_name2id(m, name.mjOBJ_JOINT, "right_wheel")
        jf = mj.mj_name2id(m, name.mjOBJ_JOINT, "create")
        self._ql, self._qr = int(m.jnt_qposadr[jl]), int(m.jnt_qposadr[jr])
        self._qfree, self._dfree = int(m.jnt_qposadr[jf]), int(m.jnt_dofadr[jf])
        self._al = mj.mj_name2id(m, name.mjOBJ_ACTUATOR, "left")
        self._ar = mj.mj_name2id(m, name.mjOBJ_ACTUATOR, "right")
        self._obstacles = {mj.mj_name2id(m, name.mjOBJ_GEOM, g): kind
                           for g, kind in built.obstacles.items()}
        self._r_nominal = robot.wheel_diameter_mm / 2.0
        self._odometer = 0.0
        mj.mj_forward(m, self.data)
        self._settle()

    # --- the Body protocol ----------------------------------------------------------------

    @property
    def pose(self) -> Pose:
        pos = self.data.xpos[self._body]
        r = self.data.xmat[self._body]
        return Pose(float(pos[0]) * 1000.0, float(pos[1]) * 1000.0,
                    math.atan2(float(r[3]), float(r[0])))

    @property
    def yaw_rate(self) -> float:
        """The body's turn rate about the vertical now, rad/s (counter-clockwise positive): the
        free joint's angular velocity, in the body's frame, about its z axis."""
        return float(self.data.qvel[self._dfree + 5])

    def set_pose(self, pose: Pose) -> None:
        q, d = self._qfree, self._dfree
        self.data.qpos[q:q + 2] = (pose.x / 1000.0, pose.y / 1000.0)
        self.data.qpos[q + 3:q + 7] = (math.cos(pose.theta / 2), 0.0, 0.0,
                                       math.sin(pose.theta / 2))
        self.data.qvel[d:d + 6] = 0.0
        self.mj.mj_forward(self.model, self.data)

    @property
    def odometer_mm(self) -> float:
        return self._odometer

    def drive(self, *, left: float, right: float, dt: float) -> tuple[float, float]:
        if dt <= 0:
            return 0.0, 0.0
        d = self.data
        d.ctrl[self._al] = left / self._r_nominal
        d.ctrl[self._ar] = right / self._r_nominal
        ql0, qr0 = float(d.qpos[self._ql]), float(d.qpos[self._qr])
        x0, y0 = float(d.xpos[self._body][0]), float(d.xpos[self._body][1])
        self._until += dt
        while d.time < self._until - 0.5 * TIMESTEP_S:
            self.mj.mj_step(self.model, d)
        self._odometer += math.hypot(float(d.xpos[self._body][0]) - x0,
                                     float(d.xpos[self._body][1]) - y0) * 1000.0
        return ((float(d.qpos[self._ql]) - ql0) * self._r_nominal,
                (float(d.qpos[self._qr]) - qr0) * self._r_nominal)

    # --- contacts -------------------------------------------------------------------------

    def bumper(self) -> list[BumperContact]:
        """The obstacles within the bumper's travel of the body now."""
        d = self.data
        out = []
        pose = self.pose
        for i in range(d.ncon):
            c = d.contact[i]
            g1, g2 = int(c.geom1), int(c.geom2)
            other = g2 if g1 == self._chassis else (g1 if g2 == self._chassis else -1)
            if other < 0 or other not in self._obstacles:
                continue
            kind, index = self._obstacles[other]
            x, y = float(c.pos[0]) * 1000.0, float(c.pos[1]) * 1000.0
            angle = wrap_angle(math.atan2(y - pose.y, x - pose.x) - pose.theta)
            out.append(BumperContact(kind, index, x, y, angle, float(c.dist) * 1000.0))
        return out

    # --- internals ------------------------------------------------------------------------

    def _settle(self) -> None:
        d = self.data
        d.ctrl[:] = 0.0
        while d.time < SETTLE_S:
            self.mj.mj_step(self.model, d)
        self._until = float(d.time)
