"""The MuJoCo engine: the simulated Create's Open Interface on a MuJoCo body, encoders, bumper,
camera geometry, and a short closed-loop run through ``marknav run --engine mujoco``."""

from __future__ import annotations

import json
import math
from pathlib import Path

import cv2
import numpy as np
import pytest

from marknav.sim.mujoco import gl

gl.backend()  # the headless renderer, chosen before anything imports mujoco
pytest.importorskip("mujoco")

from marknav.core.clock import ManualClock  # noqa: E402
from marknav.core.errors import InputError  # noqa: E402
from marknav.planning.kinematics import Pose  # noqa: E402
from marknav.robot import oi  # noqa: E402
from marknav.robot.odometry import MM_PER_COUNT  # noqa: E402
from marknav.robot.oi import Model, OIMode  # noqa: E402
from marknav.robot.packets import decode_packet, packet_size  # noqa: E402
from marknav.sim.builtin_camera import CameraConfig  # noqa: E402
from marknav.sim.mujoco.body import MujocoBody  # noqa: E402
from marknav.sim.simulated_create import SimulatedCreate  # noqa: E402
from marknav.sim.world import Conditions, MarkSpec, World, generate_world  # noqa: E402
from marknav.vision.palette import DEFAULT_PALETTE  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
QUIET = Conditions(noise_sigma=0.0)


def quiet_world(*marks: MarkSpec) -> World:
    return World(marks=marks, conditions=QUIET)


def oi_session(sim: SimulatedCreate, clock: ManualClock) -> dict[int, object]:
    """Start, Safe, Drive Direct 200/200 mm/s for 1 s, then Sensors group 100."""
    sim.write(oi.start() + oi.safe() + oi.drive_direct(left=200, right=200))
    for _ in range(100):
        clock.advance(0.01)
        sim.sync()
    sim.read()
    sim.write(oi.sensors(100, model=Model.CREATE2))
    data = sim.read()
    assert len(data) == packet_size(Model.CREATE2, 100) == 80
    return decode_packet(Model.CREATE2, 100, data)


def test_the_mujoco_create_answers_an_oi_client_as_the_builtin_one() -> None:
    answers = {}
    for engine in ("builtin", "mujoco"):
        clock = ManualClock()
        body = (MujocoBody(quiet_world(), DEFAULT_PALETTE, render=False)
                if engine == "mujoco" else None)
        sim = SimulatedCreate(clock=clock, body=body)
        answers[engine] = oi_session(sim, clock)
    built, mj = answers["builtin"], answers["mujoco"]
    assert mj[35] == built[35] == OIMode.SAFE
    assert (mj[41], mj[42]) == (built[41], built[42]) == (200, 200)  # requested right, left
    assert mj[7] == built[7]  # no bumps, no wheel drops
    # 1 s at 200 mm/s; the MuJoCo wheels first accelerate (≈ 2 m/s², 10 mm lost)
    assert built[19] == pytest.approx(200, abs=1)
    assert mj[19] == pytest.approx(built[19], abs=15)
    assert abs(mj[20]) <= 1  # straight: no angle


def test_encoders_count_the_wheel_joints_rotation() -> None:
    clock = ManualClock()
    body = MujocoBody(quiet_world(), DEFAULT_PALETTE, render=False)
    sim = SimulatedCreate(clock=clock, body=body)
    q0 = (body.data.qpos[body._ql], body.data.qpos[body._qr])
    sim.write(oi.start() + oi.safe() + oi.drive_direct(left=100, right=300))  # a left arc
    for _ in range(80):
        clock.advance(0.015)
        sim.sync()
    radius = 36.0
    for enc, q, q_start in zip(sim.encoder_counts, (body.data.qpos[body._ql],
                                                      body.data.qpos[body._qr]), q0, strict=True):
        expected = (q - q_start) * radius / MM_PER_COUNT
        assert enc == pytest.approx(expected, abs=1.0)
    left, right = sim.encoder_counts
    assert right > 2.5 * left > 0  # the right wheel turned about three times as far
    assert body.pose.theta > math.pi / 2 + 0.3  # and the robot turned left


def test_the_bumper_fires_on_contact_and_the_safety_layer_stops() -> None:
    from marknav.runs.loop.sim_environment import SimEnvironment

    mark = (0.0, 1000.0)
    world = quiet_world(MarkSpec(colour="red", x_mm=mark[0], y_mm=mark[1], radius_mm=100.0))
    env = SimEnvironment(world, DEFAULT_PALETTE, seed=3, engine="mujoco")
    try:
        for _ in range(120):  # 6 s of 200 mm/s commands: contact after ~0.73 m
            env.poll()
            env.robot.drive(left=200, right=200)
            env.advance(env.clock.now() + 0.05)
        assert env.robot.safety_state == "bumped"
        assert len(env.truth.collisions) == 1
        hit = env.truth.collisions[0]
        assert (hit["kind"], hit["index"], hit["bump"]) == ("mark", 0, "both")
        closest = min(math.dist(p, mark) for p in env.truth.xy)
        assert 165.0 + 100.0 - 5.0 < closest < 165.0 + 100.0 + 5.0  # stopped at the base
        assert env.create.wheel_speeds.left == env.create.wheel_speeds.right == 0
    finally:
        env.close()


def test_a_rendered_mark_is_where_the_pinhole_model_puts_it() -> None:
    from marknav.sim.mujoco.camera import MujocoCamera

    x, y, radius = 300.0, 2000.0, 100.0
    world = quiet_world(MarkSpec(colour="red", x_mm=x, y_mm=y, radius_mm=radius))
    body = MujocoBody(world, DEFAULT_PALETTE, camera=CameraConfig(principal=(300.0, 250.0)),
                      shadows=False)
    body.set_pose(Pose(0.0, 0.0, math.pi / 2))
    with MujocoCamera(body, clock=ManualClock()) as cam:
        image = cam.render()
        f, cx, cy = cam.config.focal_px, cam.intrinsics.cx, cam.intrinsics.cy
    hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)
    red = ((hsv[:, :, 0] < 8) | (hsv[:, :, 0] > 172)) & (hsv[:, :, 1] > 150)
    vs, us = np.nonzero(red)
    assert len(us) > 100
    forward, right = y - body.pose.y, x - body.pose.x
    assert us.mean() == pytest.approx(cx + f * right / forward, abs=1.5)
    assert vs.mean() == pytest.approx(cy, abs=1.5)
    assert math.sqrt(len(us) / math.pi) == pytest.approx(f * radius / forward, rel=0.05)


def test_a_lens_distorts_the_frame_as_its_intrinsics_say() -> None:
    from marknav.sim.lens import Lens
    from marknav.sim.mujoco.camera import MujocoCamera
    from marknav.vision.undistort import undistort_points

    x, y = 700.0, 2000.0  # toward the image's right edge, where a barrel lens pulls inward
    lens = Lens(k1=-0.25, k2=0.05, principal_offset=(0.01, -0.01))
    world = World(marks=(MarkSpec(colour="red", x_mm=x, y_mm=y, radius_mm=60.0),),
                  conditions=Conditions(noise_sigma=0.0, lens=lens))
    body = MujocoBody(world, DEFAULT_PALETTE, shadows=False)
    with MujocoCamera(body, clock=ManualClock()) as cam:
        image = cam.render()
        intr = cam.intrinsics
    assert intr.dist == lens.dist and (intr.cx, intr.cy) != (319.5, 239.5)
    hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)
    vs, us = np.nonzero(((hsv[:, :, 0] < 8) | (hsv[:, :, 0] > 172)) & (hsv[:, :, 1] > 150))
    pose = body.pose
    ideal_u = intr.cx + intr.fx * (x - pose.x) / (y - pose.y)
    assert us.mean() < ideal_u - 3.0  # the distortion shows
    (u, v), = undistort_points([(us.mean(), vs.mean())], intr)
    assert u == pytest.approx(ideal_u, abs=1.5)
    assert v == pytest.approx(intr.cy, abs=1.5)


def test_a_missing_osmesa_is_an_input_error_naming_the_package(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    monkeypatch.setattr(gl, "_library_present", lambda name: False)
    with pytest.raises(InputError, match="libosmesa6"):
        MujocoBody(quiet_world(), DEFAULT_PALETTE)


def test_mujoco_worlds_keep_the_course_and_add_the_room() -> None:
    route = ["red", "green", "red", "blue"]
    kw = {"seed": 11, "clearance_mm": 300.0, "conditions": "randomised"}
    built = generate_world(route, **kw)  # type: ignore[arg-type]
    mj = generate_world(route, engine="mujoco", **kw)  # type: ignore[arg-type]
    assert [m.xy for m in mj.marks] == [m.xy for m in built.marks]
    assert built.mujoco is None and mj.mujoco is not None
    assert 1 <= len(mj.mujoco.lights or ()) <= 3
    yaws = [abs(m.yaw_deg) for m in generate_world(["red"] * 12, engine="mujoco",
                                                   **kw).marks[1:]]  # type: ignore[arg-type]
    assert max(yaws) > 45.0  # beyond the built-in engine's 45°
    lane = max(abs(m.x_mm) for m in mj.marks) + 300.0 + 165.0
    for item in (*mj.mujoco.occluders, *mj.mujoco.distractors):
        assert abs(item.x_mm) > lane  # off the lane the robot drives


def test_marknav_run_engine_mujoco_closes_the_loop(tmp_path: Path) -> None:
    from marknav.cli.main import main

    report = tmp_path / "r.json"
    code = main(["run", str(ROOT / "missions" / "slalom.yaml"), "--engine", "mujoco",
                 "--max-time", "3", "--tree", "none", "--report", str(report)])
    assert code == 1  # the time limit ends the mission before the route
    r = json.loads(report.read_text())
    assert r["engine"] == "mujoco"
    assert r["collisions"] == 0
    assert 2.9 <= r["sim_time_s"] <= 3.1
    assert r["ticks"] >= 55
    assert r["truth_path"][-1][2] > 250.0  # the robot drove forward on MuJoCo's physics
    assert r["sim_final"]["wheels_mm_s"] == [0.0, 0.0]


def test_bench_mujoco_measures_both_sizes_with_and_without_shadows_against_the_floor() -> None:
    from marknav.runs.benchmarks.engines import SIZES, bench_mujoco

    result = bench_mujoco(frames=2, batches=1)
    assert result["floor"] == "builtin renderer"
    for width, height in SIZES:
        row = result[f"{width}x{height}"]
        assert row["builtin_ms_p50"] > 0
        for key in ("no_shadows", "shadows"):
            ms = row[f"mujoco_{key}_ms_p50"]
            assert ms > 0 and abs(row[f"mujoco_{key}_fps"] - 1000.0 / ms) < 0.1 * 1000.0 / ms
            # (the ratio is of the unrounded time: its last digit may differ by one)
            assert abs(row[f"mujoco_{key}_over_builtin"] - ms / row["builtin_ms_p50"]) < 0.06


def test_a_late_camera_delivers_the_frame_captured_that_long_ago() -> None:
    """camera_latency_s + processing_s in continuous time: after the first reads (the oldest
    frame while none is old enough), each frame read is the one rendered ≥ 0.17 s earlier,
    stamped with its capture time: the frame rendered then."""
    from marknav.sim.mujoco.camera import MujocoCamera

    world = World(marks=(MarkSpec(colour="red", x_mm=0.0, y_mm=2000.0, radius_mm=100.0),),
                  conditions=Conditions(noise_sigma=0.0, camera_latency_s=0.12,
                                        processing_s=0.05))
    body = MujocoBody(world, DEFAULT_PALETTE, camera=CameraConfig(width=160, height=120,
                                                                  focal_px=147.5),
                      shadows=False)
    clock = ManualClock()
    with MujocoCamera(body, clock=clock) as cam:
        assert cam.delay_s == pytest.approx(0.17)
        seen = []
        for k in range(12):
            body.set_pose(Pose(0.0, 50.0 * k, math.pi / 2))  # 50 mm closer each 50 ms
            frame = cam.read()
            assert frame is not None
            seen.append((clock.now(), frame.t, frame.index))
            clock.advance(0.05)
    assert seen[0][1:] == (0.0, 0) and seen[1][1:] == (0.0, 0)  # nothing old enough yet
    for now, t, index in seen[4:]:
        assert now - t == pytest.approx(0.2) and index == round(t / 0.05)
