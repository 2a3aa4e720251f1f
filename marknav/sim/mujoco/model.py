"""A marknav world as a MuJoCo model (MJCF): the room, the marks on their stands, a Create 2.

Frames: MuJoCo's world frame is marknav's (x east, y north, z up), in metres; the robot's body
frame is REP 103 (x forward, y left, z up) with its origin on the wheels' axle, midway between
them.

- **Marks** are thin discs (2 mm) of the world's radius, their centres at the camera's height
  (:data:`CAMERA_HEIGHT_MM`), faces turned by ``yaw_deg`` (normal (sin yaw, −cos yaw, 0)), matte,
  coloured as the built-in simulator paints them (:func:`marknav.sim.builtin_camera.mark_bgr`: the
  middle of the colour's hue range at full value, each mark's printed saturation and hue offset
  from :func:`~marknav.sim.builtin_camera.mark_inks`), lifted by ``mark_height_offset_mm``.
  Each stands on a thin pole behind the disc and a round base of the mark's radius,
  :data:`MARK_BASE_HEIGHT_MM` high: the base is what the robot's bumper can touch, so a collision
  happens where the built-in engine's (a mark is a circle of its radius in the top view).
- **Walls** and **boxes** of the world are boxes :data:`OBSTACLE_HEIGHT_MM` high; the **room** is
  a floor and four walls :data:`ROOM_MARGIN_MM` beyond the course, so the camera sees a room.
- **The robot** (:class:`CreateSpec`, a Create 2): a 3.6 kg cylinder body (the mission's robot
  radius, 70 mm high, 15 mm above the floor), two wheels 72 mm across on hinges the wheel base
  apart, each driven by a velocity actuator (the wheel controller: gain :attr:`CreateSpec.kv`,
  torque limited to :attr:`CreateSpec.max_torque_nm`, speed limited to the OI's 500 mm/s), and a
  frictionless front caster. The body's collision shape only meets obstacles (not the floor);
  wheels and caster only meet the floor. The bumper is the body's contacts within
  :attr:`CreateSpec.bumper_travel_mm` (a detection margin: MuJoCo reports them without pushing).
  Wheel mismatch and slip of the world's conditions are effective tyre radii: the encoders count
  the nominal 72 mm tyre, the ground moves by the effective one.
- **The camera** is fixed to the body at the camera height and ``forward_offset_mm``, looking
  along the heading (turned up by ``camera_pitch_deg`` and about its axis by ``camera_roll_deg``),
  with the camera's focal length and principal point as MJCF intrinsics
  (``focalpixel``, ``principalpixel``; the ``fovy`` is then 2·atan(h / 2f)).

:func:`build_model` returns the MJCF text and the in-memory assets (textures) for
``mujoco.MjModel.from_xml_string``; it imports no ``mujoco``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from marknav.sim.builtin_camera import CameraConfig, mark_bgr, mark_inks, tilt_rotation
from marknav.sim.mujoco.scene import Light, MujocoScene, near_hue
from marknav.sim.scenery import room_photo
from marknav.sim.world.schema import World
from marknav.vision.palette import ColourRange

__all__ = ["CAMERA_HEIGHT_MM", "CREATE2", "DEFAULT_CAMERA", "CreateSpec", "MjcfModel",
           "build_model"]

#: Height of the camera and of the marks' centres above the floor (a webcam on a laptop on the
#: Create's deck; the paper's set-up has both at one height).
CAMERA_HEIGHT_MM = 300.0
#: Mark discs are this thick.
MARK_THICKNESS_MM = 2.0
#: The round base each mark stands on (what the bumper touches), and its pole's radius.
MARK_BASE_HEIGHT_MM = 60.0
MARK_POLE_RADIUS_MM = 8.0
#: Height of the world's walls and boxes.
OBSTACLE_HEIGHT_MM = 600.0
#: The room's walls stand this far beyond the course's extent; their height.
ROOM_MARGIN_MM = 3000.0
ROOM_HEIGHT_MM = 2600.0
#: Physics step: 2 ms resolves the wheels' 30 ms speed response and contact with a 3.6 kg body.
TIMESTEP_S = 0.002
#: The body's centre of mass lies this far ahead of the axle, so the robot rests on its front
#: caster (the Create has no rear one).
COM_AHEAD_MM = 30.0
#: Half the width of a tyre's contact with the floor (a rounded tread: a narrow patch; a wide
#: flat one scrubs in turns and slows the wheels).
TYRE_HALF_WIDTH_MM = 4.0
#: Time constant of the tyre-floor contact (s; MuJoCo's solref, at least two physics steps).
#: MuJoCo's default 20 ms lets a 3.6 kg robot sink 0.16 mm into the floor, which shortens the
#: rolling radius by 0.45 % and makes every turn that much short of what odometry counts; at
#: 10 ms the sink is 0.015 mm (measured: a 140° arc turns 0.3 % short). Stiffer (4 ms) chatters
#: at the 2 ms step and slips more (2.7 % short).
TYRE_SOLREF_S = 0.01
#: Collision groups: the floor and what rolls on it; the body and the obstacles.
_FLOOR_BITS, _OBSTACLE_BITS = 1, 2


@dataclass(frozen=True)
class CreateSpec:
    """A Create 2 for the physics (OI spec: 235 mm wheel base, 72 mm wheels, 500 mm/s).

    ``max_torque_nm`` per wheel limits acceleration to about 2 m/s² on 3.6 kg (0.5 m/s in a
    quarter second; the OI spec gives no figure, this is an assumption); ``kv`` (N·m per rad/s)
    is the wheel speed controller's gain: the Create regulates wheel speed from its encoders,
    so under the few hundredths of a N·m a turn costs the speed error stays near 1 mm/s
    (torque / kv × 36 mm), and below the torque limit the speed settles in a few ms (the
    wheel's share of the robot's inertia, 1.8 kg × (36 mm)², over kv). ``left_scale`` and
    ``right_scale`` scale the tyres' effective radii (wheel mismatch, slip).
    """

    radius_mm: float = 165.0
    wheel_base_mm: float = 235.0
    wheel_diameter_mm: float = 72.0
    mass_kg: float = 3.6
    body_height_mm: float = 70.0
    ground_clearance_mm: float = 15.0
    max_speed_mm_s: float = 500.0
    max_torque_nm: float = 0.13
    kv: float = 1.0
    bumper_travel_mm: float = 3.0
    caster_radius_mm: float = 15.0
    left_scale: float = 1.0
    right_scale: float = 1.0
    wheel_mass_kg: float = 0.15


#: The Create 2 with the defaults above, and the simulator's default camera.
CREATE2 = CreateSpec()
DEFAULT_CAMERA = CameraConfig()


@dataclass
class MjcfModel:
    """MJCF text, its in-memory assets, and how marknav's objects are named in it."""

    xml: str
    assets: dict[str, bytes] = field(default_factory=dict)
    #: geom name → (kind, index): the obstacles a contact can be with.
    obstacles: dict[str, tuple[str, int]] = field(default_factory=dict)


def _m(mm: float) -> str:
    return f"{mm / 1000.0:.6g}"


def _v(*values: float) -> str:
    return " ".join(f"{v:.6g}" for v in values)


def _rgb(bgr: tuple[float, float, float]) -> str:
    return _v(bgr[2] / 255.0, bgr[1] / 255.0, bgr[0] / 255.0)


def _hsv_rgb(hue: float, sat: float, val: float) -> tuple[float, float, float]:
    hsv = np.array([[[hue * 2.0, sat, val]]], dtype=np.float32)
    b, g, r = cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)[0, 0]
    return (float(r), float(g), float(b))


def _png(image: np.ndarray) -> bytes:
    ok, buf = cv2.imencode(".png", cv2.cvtColor(image, cv2.COLOR_BGR2RGB))
    if not ok:
        raise ValueError("cannot encode a texture")
    return bytes(buf)


def _extent(world: World) -> tuple[float, float, float, float]:
    xs = [0.0, world.robot.x_mm] + [m.x_mm for m in world.marks]
    ys = [0.0, world.robot.y_mm] + [m.y_mm for m in world.marks]
    for w in world.walls:
        xs += [w.x1_mm, w.x2_mm]
        ys += [w.y1_mm, w.y2_mm]
    for b in world.boxes:
        xs.append(b.x_mm)
        ys.append(b.y_mm)
    return min(xs), min(ys), max(xs), max(ys)


def _textures(scene: MujocoScene, palette: tuple[ColourRange, ...],
              floor_size: tuple[float, float], assets: dict[str, bytes]) -> tuple[str, str, str]:
    """The <asset> block and the floor's and walls' material names."""
    rng = np.random.default_rng([scene.texture_seed, 0x7E47])
    ranges = tuple((c.hue_lo, c.hue_hi) for c in palette)
    out = []
    floor_mat, wall_mat = "floor_plain", "wall_plain"
    # plain colours: floors darker and a little more saturated than walls
    fh, fs, fv = (float(rng.uniform(0, 180)), float(rng.uniform(0.05, 0.25)),
                  float(rng.uniform(0.35, 0.6)))
    wh, ws, wv = (float(rng.uniform(0, 180)), float(rng.uniform(0.03, 0.15)),
                  float(rng.uniform(0.6, 0.8)))
    out.append(f'<material name="floor_plain" rgba="{_v(*_hsv_rgb(fh, fs, fv), 1)}" '
               f'specular="0.1" shininess="0.1"/>')
    out.append(f'<material name="wall_plain" rgba="{_v(*_hsv_rgb(wh, ws, wv), 1)}" '
               f'specular="0" shininess="0"/>')
    if scene.floor == "checker":
        c1 = _hsv_rgb(fh, fs, fv)
        c2 = _hsv_rgb(float(rng.uniform(0, 180)), fs, fv * float(rng.uniform(0.5, 0.8)))
        out.append(f'<texture name="floor_checker" type="2d" builtin="checker" '
                   f'rgb1="{_v(*c1)}" rgb2="{_v(*c2)}" width="256" height="256"/>')
        reps = (floor_size[0] / (2 * scene.checker_mm), floor_size[1] / (2 * scene.checker_mm))
        out.append(f'<material name="floor_checker" texture="floor_checker" '
                   f'texrepeat="{_v(*reps)}" specular="0.1" shininess="0.1"/>')
        floor_mat = "floor_checker"
    elif scene.floor == "photo":
        assets["floor.png"] = _png(room_photo(int(rng.integers(1 << 30)), ranges))
        out.append('<texture name="floor_photo" type="2d" file="floor.png"/>')
        out.append(f'<material name="floor_photo" texture="floor_photo" '
                   f'texrepeat="{_v(floor_size[0] / 2000.0, floor_size[1] / 2000.0)}" '
                   f'specular="0.1"/>')
        floor_mat = "floor_photo"
    if scene.wall == "gradient":
        top = _hsv_rgb(wh, ws, wv)
        bottom = _hsv_rgb(float(rng.uniform(0, 180)), float(rng.uniform(0.05, 0.3)),
                          float(rng.uniform(0.3, 0.6)))
        out.append(f'<texture name="wall_gradient" type="2d" builtin="gradient" '
                   f'rgb1="{_v(*top)}" rgb2="{_v(*bottom)}" width="128" height="128"/>')
        out.append('<material name="wall_gradient" texture="wall_gradient" specular="0"/>')
        wall_mat = "wall_gradient"
    elif scene.wall == "photo":
        assets["wall.png"] = _png(room_photo(int(rng.integers(1 << 30)), ranges))
        out.append('<texture name="wall_photo" type="2d" file="wall.png"/>')
        out.append('<material name="wall_photo" texture="wall_photo" texuniform="true" '
                   'texrepeat="0.4 0.4" specular="0"/>')
        wall_mat = "wall_photo"
    return "\n    ".join(out), floor_mat, wall_mat


def _lights(scene: MujocoScene, extent: tuple[float, float, float, float], gains_rgb:
            tuple[float, float, float], shadows: bool) -> list[str]:
    x0, y0, x1, y1 = extent
    lights = scene.lights if scene.lights is not None else (
        Light(x_mm=0.5 * (x0 + x1), y_mm=0.5 * (y0 + y1), rgb=(0.55, 0.55, 0.55)),)
    out = []
    for i, light in enumerate(lights):
        rgb = tuple(min(2.0, c * g) for c, g in zip(light.rgb, gains_rgb, strict=True))
        out.append(
            f'<light name="lamp{i}" pos="{_m(light.x_mm)} {_m(light.y_mm)} {_m(light.z_mm)}" '
            f'dir="0 0 -1" directional="false" cutoff="80" exponent="1" '
            f'diffuse="{_v(*rgb)}" specular="0.05 0.05 0.05" '
            f'castshadow="{str(light.shadows and shadows).lower()}" attenuation="1 0 0"/>')
    return out


def build_model(
    world: World,
    palette: tuple[ColourRange, ...],
    *,
    camera: CameraConfig = DEFAULT_CAMERA,
    robot: CreateSpec = CREATE2,
    shadows: bool = True,
    shadow_size: int = 1024,
) -> MjcfModel:
    """The MJCF of ``world`` with a Create 2 (``robot``) at its start pose and a camera named
    ``eye`` (see the module docstring). ``palette`` colours the marks; ``render_size`` (w, h)
    is the off-screen buffer (default the camera's size)."""
    scene = world.mujoco if world.mujoco is not None else MujocoScene()
    by_name = {c.name: c for c in palette}
    model = MjcfModel(xml="")
    x0, y0, x1, y1 = _extent(world)
    x0, y0 = x0 - ROOM_MARGIN_MM, y0 - ROOM_MARGIN_MM
    x1, y1 = x1 + ROOM_MARGIN_MM, y1 + ROOM_MARGIN_MM
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    hx, hy = 0.5 * (x1 - x0), 0.5 * (y1 - y0)
    assets_xml, floor_mat, wall_mat = _textures(scene, palette, (2 * hx, 2 * hy), model.assets)
    b, g, r = world.conditions.channel_gains_bgr()
    w, h = camera.width, camera.height
    obstacle = f'contype="{_OBSTACLE_BITS}" conaffinity="{_OBSTACLE_BITS}"'
    ghost = 'contype="0" conaffinity="0"'
    body: list[str] = []

    # the room
    body.append(f'<geom name="floor" type="plane" pos="{_m(cx)} {_m(cy)} 0" '
                f'size="{_m(hx)} {_m(hy)} 0.1" material="{floor_mat}" '
                f'contype="{_FLOOR_BITS}" conaffinity="{_FLOOR_BITS}" condim="3"/>')
    t = 50.0  # wall half-thickness, mm
    for name, (px, py, sx, sy) in {
        "room_s": (cx, y0 - t, hx + 2 * t, t), "room_n": (cx, y1 + t, hx + 2 * t, t),
        "room_w": (x0 - t, cy, t, hy), "room_e": (x1 + t, cy, t, hy),
    }.items():
        body.append(f'<geom name="{name}" type="box" material="{wall_mat}" {obstacle} '
                    f'pos="{_m(px)} {_m(py)} {_m(ROOM_HEIGHT_MM / 2)}" '
                    f'size="{_m(sx)} {_m(sy)} {_m(ROOM_HEIGHT_MM / 2)}"/>')
        model.obstacles[name] = ("room", -1)
    body.append(f'<geom name="ceiling" type="box" material="{wall_mat}" contype="0" '
                f'conaffinity="0" pos="{_m(cx)} {_m(cy)} {_m(ROOM_HEIGHT_MM + t)}" '
                f'size="{_m(hx + 2 * t)} {_m(hy + 2 * t)} {_m(t)}"/>')
    body += _lights(scene, (x0 + ROOM_MARGIN_MM, y0 + ROOM_MARGIN_MM, x1 - ROOM_MARGIN_MM,
                            y1 - ROOM_MARGIN_MM), (r, g, b), shadows)

    # the marks, printed as the built-in engine paints them (each one's saturation and hue)
    centre_z = CAMERA_HEIGHT_MM + world.conditions.mark_height_offset_mm
    for i, (mark, (sat, hue)) in enumerate(zip(world.marks, mark_inks(world), strict=True)):
        rad = mark.radius()
        nx, ny = mark.normal
        rgb = (_rgb(mark_bgr(by_name[mark.colour], saturation=sat, hue_offset=hue))
               if mark.colour in by_name else "0.5 0.5 0.5")
        mx, my = mark.x_mm, mark.y_mm
        body.append(f'<geom name="mark{i}" type="cylinder" {ghost} '
                    f'pos="{_m(mx)} {_m(my)} {_m(centre_z)}" zaxis="{_v(nx, ny, 0)}" '
                    f'size="{_m(rad)} {_m(MARK_THICKNESS_MM / 2)}" rgba="{rgb} 1" '
                    f'material="matte"/>')
        # the pole behind the disc, from the base to the disc's centre
        pole_top = max(centre_z, MARK_BASE_HEIGHT_MM)
        px, py = mx - nx * (MARK_POLE_RADIUS_MM + MARK_THICKNESS_MM), my - ny * (
            MARK_POLE_RADIUS_MM + MARK_THICKNESS_MM)
        body.append(f'<geom name="mark{i}_pole" type="cylinder" {ghost} rgba="0.3 0.3 0.3 1" '
                    f'pos="{_m(px)} {_m(py)} {_m(pole_top / 2)}" '
                    f'size="{_m(MARK_POLE_RADIUS_MM)} {_m(pole_top / 2)}"/>')
        body.append(f'<geom name="mark{i}_base" type="cylinder" {obstacle} '
                    f'rgba="0.22 0.22 0.22 1" '
                    f'pos="{_m(mx)} {_m(my)} {_m(MARK_BASE_HEIGHT_MM / 2)}" '
                    f'size="{_m(rad)} {_m(MARK_BASE_HEIGHT_MM / 2)}"/>')
        model.obstacles[f"mark{i}_base"] = ("mark", i)

    # walls and boxes of the world
    for i, wall in enumerate(world.walls):
        (ax, ay), (bx, by) = wall.segment()
        length = math.dist((ax, ay), (bx, by))
        yaw = math.atan2(by - ay, bx - ax)
        body.append(f'<geom name="wall{i}" type="box" {obstacle} rgba="0.7 0.7 0.68 1" '
                    f'pos="{_m((ax + bx) / 2)} {_m((ay + by) / 2)} {_m(OBSTACLE_HEIGHT_MM / 2)}" '
                    f'euler="0 0 {yaw:.6g}" size="{_m(length / 2)} {_m(10.0)} '
                    f'{_m(OBSTACLE_HEIGHT_MM / 2)}"/>')
        model.obstacles[f"wall{i}"] = ("wall", i)
    for i, box in enumerate(world.boxes):
        body.append(f'<geom name="box{i}" type="box" {obstacle} rgba="0.55 0.5 0.45 1" '
                    f'pos="{_m(box.x_mm)} {_m(box.y_mm)} {_m(OBSTACLE_HEIGHT_MM / 2)}" '
                    f'euler="0 0 {math.radians(box.yaw_deg):.6g}" size="{_m(box.width_mm / 2)} '
                    f'{_m(box.depth_mm / 2)} {_m(OBSTACLE_HEIGHT_MM / 2)}"/>')
        model.obstacles[f"box{i}"] = ("box", i)

    # the MuJoCo-only extras: occluders and distractors (obstacles too: they are real objects)
    for i, occ in enumerate(scene.occluders):
        body.append(f'<geom name="occluder{i}" type="cylinder" {obstacle} '
                    f'rgba="{_v(occ.grey, occ.grey, occ.grey)} 1" '
                    f'pos="{_m(occ.x_mm)} {_m(occ.y_mm)} {_m(occ.height_mm / 2)}" '
                    f'size="{_m(occ.radius_mm)} {_m(occ.height_mm / 2)}"/>')
        model.obstacles[f"occluder{i}"] = ("occluder", i)
    for i, dis in enumerate(scene.distractors):
        colour = by_name.get(dis.near)
        if colour is None:
            continue
        hue = near_hue(colour.hue_lo, colour.hue_hi, dis.hue_offset)
        rgb = _v(*_hsv_rgb(hue, 1.0, 1.0))
        size = dis.size_mm / 2
        z = max(dis.z_mm, size)
        shape = (f'type="sphere" size="{_m(size)}"' if dis.shape == "ball"
                 else f'type="box" size="{_m(size)} {_m(size)} {_m(size)}"')
        body.append(f'<geom name="distractor{i}" {shape} {ghost} rgba="{rgb} 1" '
                    f'material="matte" pos="{_m(dis.x_mm)} {_m(dis.y_mm)} {_m(z)}"/>')
        if z > size + 1.0:  # on a stand
            body.append(f'<geom name="distractor{i}_stand" type="cylinder" {obstacle} '
                        f'rgba="0.3 0.3 0.3 1" pos="{_m(dis.x_mm)} {_m(dis.y_mm)} '
                        f'{_m((z - size) / 2)}" size="{_m(MARK_POLE_RADIUS_MM)} '
                        f'{_m((z - size) / 2)}"/>')
        model.obstacles[f"distractor{i}_stand"] = ("distractor", i)

    body.append(_robot_xml(world, robot, camera))
    fovy = fovy_deg(camera)
    xml = f"""<mujoco model="marknav">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{TIMESTEP_S}" integrator="implicitfast" cone="elliptic"/>
  <visual>
    <global offwidth="{w}" offheight="{h}" fovy="{fovy:.6g}"/>
    <quality shadowsize="{int(shadow_size)}" offsamples="0"/>
    <headlight ambient="{_v(*(scene.ambient * c for c in (r, g, b)))}" diffuse="0.25 0.25 0.25"
               specular="0 0 0"/>
    <map znear="0.01" zfar="60" shadowclip="8"/>
  </visual>
  <asset>
    <material name="matte" specular="0" shininess="0" reflectance="0"/>
    {assets_xml}
  </asset>
  <worldbody>
    {chr(10).join('    ' + line for line in body).strip()}
  </worldbody>
  <actuator>
    <velocity name="left" joint="left_wheel" kv="{robot.kv}" ctrlrange="{_v(*_ctrl(robot))}"
              forcerange="{_v(-robot.max_torque_nm, robot.max_torque_nm)}"/>
    <velocity name="right" joint="right_wheel" kv="{robot.kv}" ctrlrange="{_v(*_ctrl(robot))}"
              forcerange="{_v(-robot.max_torque_nm, robot.max_torque_nm)}"/>
  </actuator>
</mujoco>
"""
    model.xml = xml
    return model


def fovy_deg(camera: CameraConfig) -> float:
    """MuJoCo's vertical field of view of a pinhole of ``focal_px``: 2·atan(h / 2f)."""
    return math.degrees(2.0 * math.atan((camera.height / 2.0) / camera.focal_px))


def _intrinsics(camera: CameraConfig) -> str:
    """The camera's pinhole as MJCF intrinsics: focal length and principal point in pixels
    (MuJoCo's ``principalpixel`` is the principal point's offset from the image centre, rows
    and columns counted toward the top left; the sensor size only sets the units)."""
    w, h, f = camera.width, camera.height, camera.focal_px
    dx, dy = (w - 1) / 2.0 - camera.cx, (h - 1) / 2.0 - camera.cy
    return (f'resolution="{w} {h}" focalpixel="{_v(f, f)}" principalpixel="{_v(dx, dy)}" '
            f'sensorsize="{_v(w * 1e-5, h * 1e-5)}"')


#: The level camera's axes (OpenCV: x right, y down, z forward) in the robot's body frame
#: (x forward, y left, z up), as columns.
_LEVEL_CAMERA_IN_BODY = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


def _eye_axes(pitch_deg: float, roll_deg: float) -> str:
    """MJCF ``xyaxes`` of the camera on a mount turned by ``pitch_deg`` (up) and ``roll_deg``
    (:func:`marknav.sim.builtin_camera.tilt_rotation`): MuJoCo's camera x is the image's right,
    its y the image's up (OpenCV's −y); it looks along its −z."""
    rot = tilt_rotation(pitch_deg=pitch_deg, roll_deg=roll_deg)
    right = _LEVEL_CAMERA_IN_BODY @ rot[0]
    up = -(_LEVEL_CAMERA_IN_BODY @ rot[1])
    return _v(*(float(v) + 0.0 for v in (*right, *up)))


def _ctrl(robot: CreateSpec) -> tuple[float, float]:
    w = robot.max_speed_mm_s / (robot.wheel_diameter_mm / 2.0)
    return (-w, w)


def _robot_xml(world: World, robot: CreateSpec, camera: CameraConfig) -> str:
    pose = world.robot.pose()
    r_wheel = robot.wheel_diameter_mm / 2.0
    # effective tyre radii (mismatch and slip): the ground moves by these, encoders count r_wheel
    c = world.conditions
    left_r = r_wheel * robot.left_scale * (1.0 - c.wheel_slip)
    right_r = r_wheel * robot.right_scale * (1.0 + c.wheel_mismatch) * (1.0 - c.wheel_slip)
    axle = r_wheel  # the body's origin: on the axle
    zc = robot.ground_clearance_mm + robot.body_height_mm / 2.0 - axle
    half_base = robot.wheel_base_mm / 2.0
    body_mass = robot.mass_kg - 2 * robot.wheel_mass_kg
    rr, hh = robot.radius_mm / 1000.0, robot.body_height_mm / 1000.0
    ixx = body_mass * (3 * rr * rr + hh * hh) / 12.0
    izz = body_mass * rr * rr / 2.0
    caster_x = robot.radius_mm - 40.0
    caster_z = robot.caster_radius_mm - axle
    cam_z = CAMERA_HEIGHT_MM - axle
    obstacle = f'contype="{_OBSTACLE_BITS}" conaffinity="{_OBSTACLE_BITS}"'
    floor = f'contype="{_FLOOR_BITS}" conaffinity="{_FLOOR_BITS}"'
    travel = robot.bumper_travel_mm
    wheels = []
    for side, y, rad in (("left", half_base, left_r), ("right", -half_base, right_r)):
        wheels.append(
            f'<body name="{side}_wheel" pos="0 {_m(y)} 0">'
            f'<joint name="{side}_wheel" type="hinge" axis="0 1 0" damping="0.0005" '
            f'armature="0.0001"/>'
            f'<geom name="{side}_tyre" type="cylinder" {floor} condim="3" priority="1" '
            f'solref="{TYRE_SOLREF_S} 1" '
            f'friction="1.0 0.01 0.001" size="{_m(rad)} {_m(TYRE_HALF_WIDTH_MM)}" '
            f'euler="{math.pi / 2:.6g} 0 0" mass="{robot.wheel_mass_kg}" '
            f'rgba="0.1 0.1 0.1 1"/></body>')
    return (
        f'<body name="create" pos="{_m(pose.x)} {_m(pose.y)} {_m(axle + 0.5)}" '
        f'euler="0 0 {pose.theta:.9g}">'
        f'<freejoint name="create"/>'
        f'<inertial pos="{_m(COM_AHEAD_MM)} 0 {_m(zc)}" mass="{body_mass:.6g}" '
        f'diaginertia="{_v(ixx, ixx, izz)}"/>'
        f'<geom name="chassis" type="cylinder" {obstacle} margin="{_m(travel)}" gap="{_m(travel)}" '
        f'size="{_m(robot.radius_mm)} {_m(robot.body_height_mm / 2)}" pos="0 0 {_m(zc)}" '
        f'rgba="0.85 0.85 0.85 1"/>'
        # priority: the caster's condim (1, frictionless) wins over the floor's
        f'<geom name="caster" type="sphere" {floor} condim="1" priority="1" '
        f'size="{_m(robot.caster_radius_mm)}" '
        f'pos="{_m(caster_x)} 0 {_m(caster_z)}" mass="0.02" rgba="0.2 0.2 0.2 1"/>'
        + "".join(wheels)
        + f'<camera name="eye" pos="{_m(camera.forward_offset_mm)} 0 {_m(cam_z)}" '
        f'xyaxes="{_eye_axes(c.camera_pitch_deg, c.camera_roll_deg)}" {_intrinsics(camera)}/>'
        f'</body>'
    )
