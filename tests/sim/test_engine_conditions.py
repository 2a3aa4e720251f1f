"""Engine parity: each camera condition of a world acts in both engines' cameras, by the same
measure — the mount's pitch and roll and the marks' height move a mark where the tilted pinhole
puts it; the marks' printed saturation and hue reach the image; the exposure's drift scales the
brightness and its length smears a turn; the frame clock repeats frames and loses
``dropped_frames`` of them. (The room's conditions are each engine's own:
``tests/sim/world/test_course_engine.py``.)"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import cv2
import numpy as np
import pytest

from marknav.sim.mujoco import gl

gl.backend()  # the headless renderer, chosen before anything imports mujoco

from marknav.core.clock import ManualClock  # noqa: E402
from marknav.planning.kinematics import Pose  # noqa: E402
from marknav.sim.builtin_camera import (  # noqa: E402
    CameraConfig,
    SimCamera,
    mark_inks,
    tilt_homography,
)
from marknav.sim.camera_timing import exposure_gain, exposure_phase  # noqa: E402
from marknav.sim.world import Conditions, MarkSpec, World  # noqa: E402
from marknav.vision.palette import DEFAULT_PALETTE  # noqa: E402
from marknav.vision.sources import Image  # noqa: E402


def _mujoco_renders() -> bool:
    try:
        gl.import_mujoco()
    except Exception:
        return False
    return True


ENGINES = ("builtin", pytest.param("mujoco", marks=pytest.mark.skipif(
    not _mujoco_renders(), reason="MuJoCo or its off-screen renderer is not installed")))
CONFIG = CameraConfig(width=160, height=120, focal_px=147.5)
#: The robot at the origin looking north (+y); marks ahead of it.
POSE = Pose(0.0, 0.0, math.pi / 2)
AHEAD_MM = 1500.0
RADIUS_MM = 150.0


def world_of(marks: tuple[MarkSpec, ...], **conditions: Any) -> World:
    return World(marks=marks, conditions=Conditions(noise_sigma=0.0, **conditions))


@contextmanager
def camera(engine: str, world: World, clock: ManualClock, *, yaw_rate: float = 0.0,
           seed: int = 0) -> Iterator[Any]:
    """The engine's camera on a robot standing at :data:`POSE`, turning at ``yaw_rate``
    (rad/s: the built-in camera sees it in the past poses, MuJoCo in the body's velocity)."""
    if engine == "builtin":
        def pose_at(t: float) -> Pose:
            return Pose(POSE.x, POSE.y, POSE.theta + yaw_rate * (t - clock.now()))

        with SimCamera(world, DEFAULT_PALETTE, pose_fn=lambda: POSE, clock=clock,
                       config=CONFIG, pose_at=pose_at, seed=seed) as cam:
            yield cam
        return
    from marknav.sim.mujoco.body import MujocoBody
    from marknav.sim.mujoco.camera import MujocoCamera

    body = MujocoBody(world, DEFAULT_PALETTE, camera=CONFIG, shadows=False)
    body.set_pose(POSE)
    body.data.qvel[body._dfree + 5] = yaw_rate  # turning now (the pose itself is not stepped)
    with MujocoCamera(body, clock=clock, seed=seed) as cam:
        yield cam


def frame(engine: str, world: World, **kwargs: Any) -> Image:
    with camera(engine, world, ManualClock(), **kwargs) as cam:
        f = cam.read()
        assert f is not None
        return np.asarray(f.image)


def redness(image: Image) -> np.ndarray:
    """How much redder than green or blue each pixel is (0 where it is not)."""
    b, g, r = (image[:, :, k].astype(np.float64) for k in range(3))
    return np.clip(r - np.maximum(g, b), 0.0, None)


def centroid(image: Image) -> tuple[float, float]:
    w = redness(image)
    w[w < 60] = 0.0
    assert w.sum() > 0, "no red mark in the frame"
    vs, us = np.mgrid[:w.shape[0], :w.shape[1]]
    return float((us * w).sum() / w.sum()), float((vs * w).sum() / w.sum())


# --- the mount and the marks' height ----------------------------------------------------------


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize(("pitch", "roll", "lift"), [
    (8.0, 0.0, 0.0), (-6.0, 0.0, 0.0), (0.0, 12.0, 0.0), (5.0, -10.0, 0.0), (0.0, 0.0, 150.0),
])
def test_the_mount_and_the_marks_height_move_a_mark_where_the_tilted_pinhole_puts_it(
        engine: str, pitch: float, roll: float, lift: float) -> None:
    right = 250.0  # mm right of the axis: a roll moves it up or down
    mark = MarkSpec(colour="red", x_mm=right, y_mm=AHEAD_MM, radius_mm=RADIUS_MM)
    image = frame(engine, world_of((mark,), camera_pitch_deg=pitch, camera_roll_deg=roll,
                                   mark_height_offset_mm=lift))
    f, cx, cy = CONFIG.focal_px, CONFIG.cx, CONFIG.cy
    level = np.array([cx + f * right / AHEAD_MM, cy - f * lift / AHEAD_MM, 1.0])
    h = tilt_homography(CONFIG, pitch_deg=pitch, roll_deg=roll)
    want = level if h is None else h @ level
    u, v = centroid(image)
    assert u == pytest.approx(want[0] / want[2], abs=1.5)
    assert v == pytest.approx(want[1] / want[2], abs=1.5)
    if pitch and not roll:  # and the shift is the one f·tan(pitch) gives, not a tiny one
        assert abs(v - level[1]) > 0.8 * f * abs(math.tan(math.radians(pitch)))


# --- the marks' paint -------------------------------------------------------------------------


def _ink(image: Image, u: float) -> tuple[float, float]:
    """Mean hue (OpenCV units, red around 0 unwrapped) and saturation (0..1) of the mark's
    middle at column ``u``."""
    r = CONFIG.focal_px * RADIUS_MM / AHEAD_MM
    hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV).astype(np.float64)
    vs, us = np.mgrid[:image.shape[0], :image.shape[1]]
    inside = np.hypot(us - u, vs - CONFIG.cy) < 0.5 * r
    hue = hsv[:, :, 0][inside]
    hue = np.where(hue > 90, hue - 180, hue)
    return float(hue.mean()), float(hsv[:, :, 1][inside].mean() / 255.0)


@pytest.mark.parametrize("engine", ENGINES)
def test_the_marks_printed_saturation_and_hue_reach_the_image(engine: str) -> None:
    xs = (-450.0, 0.0, 450.0)
    marks = tuple(MarkSpec(colour="red", x_mm=x, y_mm=AHEAD_MM, radius_mm=RADIUS_MM) for x in xs)
    printed = world_of(marks, mark_saturation=0.6, mark_saturation_spread=0.25,
                       mark_hue_spread=8.0)
    inks = mark_inks(printed)
    assert max(s for s, _ in inks) - min(s for s, _ in inks) > 0.1  # they do differ
    full, pale = frame(engine, world_of(marks)), frame(engine, printed)
    f, cx = CONFIG.focal_px, CONFIG.cx
    for x, (sat, dh) in zip(xs, inks, strict=True):
        u = cx + f * x / AHEAD_MM
        hue0, sat0 = _ink(full, u)
        hue1, sat1 = _ink(pale, u)
        assert sat1 / sat0 == pytest.approx(sat, abs=0.08)
        assert hue1 - hue0 == pytest.approx(dh, abs=1.5)


# --- the exposure ------------------------------------------------------------------------------


@pytest.mark.parametrize("engine", ENGINES)
def test_the_exposure_drift_scales_the_brightness_by_its_gain(engine: str) -> None:
    mark = MarkSpec(colour="red", x_mm=0.0, y_mm=AHEAD_MM, radius_mm=RADIUS_MM)
    world = world_of((mark,), exposure_drift=0.3, exposure_period_s=1.0)
    clock = ManualClock()
    times = np.arange(0.0, 2.0, 0.1)
    means = []
    with camera(engine, world, clock, seed=5) as cam:
        for t in times:
            clock.advance(t - clock.now())
            f = cam.read()
            assert f is not None
            means.append(float(np.median(f.image)))
    gains = [exposure_gain(world.conditions, float(t), exposure_phase(5)) for t in times]
    assert max(gains) / min(gains) > 1.6
    ratios = np.array(means) / np.array(gains)
    assert ratios.std() / ratios.mean() < 0.04  # brightness ∝ the gain
    assert np.corrcoef(means, gains)[0, 1] > 0.98


def _spread_px2(image: Image) -> float:
    """The horizontal variance (px²) of the mark's redness above the room's, summed over the
    rows the mark spans (the mark covers a few per cent of the frame: the 90th percentile of
    the redness is the room's)."""
    red = redness(image)
    r = CONFIG.focal_px * RADIUS_MM / AHEAD_MM
    band = red[math.floor(CONFIG.cy - r - 2):math.ceil(CONFIG.cy + r + 3)]
    profile = np.clip(band - np.percentile(red, 90), 0.0, None).sum(axis=0)
    u = np.arange(profile.size)
    mean = (u * profile).sum() / profile.sum()
    return float(((u - mean) ** 2 * profile).sum() / profile.sum())


@pytest.mark.parametrize("engine", ENGINES)
def test_a_turn_during_the_exposure_smears_the_image_by_the_angle_turned(engine: str) -> None:
    mark = MarkSpec(colour="red", x_mm=0.0, y_mm=AHEAD_MM, radius_mm=RADIUS_MM)
    yaw_rate, exposure_ms = 1.5, 80.0
    still = frame(engine, world_of((mark,), exposure_ms=exposure_ms))
    standing = frame(engine, world_of((mark,)), yaw_rate=yaw_rate)
    turning = frame(engine, world_of((mark,), exposure_ms=exposure_ms), yaw_rate=yaw_rate)
    assert _spread_px2(still) == pytest.approx(_spread_px2(standing), rel=0.02)
    n = round(yaw_rate * exposure_ms / 1000.0 * CONFIG.focal_px)  # the box filter's length, px
    added = _spread_px2(turning) - _spread_px2(standing)
    assert added == pytest.approx((n * n - 1) / 12.0, rel=0.25)  # a box of n px adds (n²−1)/12


# --- the frame clock ---------------------------------------------------------------------------


@pytest.mark.parametrize("engine", ENGINES)
def test_a_camera_slower_than_the_loop_repeats_its_frames(engine: str) -> None:
    world = world_of((), frame_rate_hz=10.0)
    clock = ManualClock()
    indices = []
    with camera(engine, world, clock) as cam:
        for _ in range(50):  # 1 s of reads at 50 Hz
            f = cam.read()
            assert f is not None
            indices.append(f.index)
            clock.advance(0.02)
    assert len(set(indices)) == 10
    assert indices[:5] == [indices[0]] * 5 and indices[5] == indices[0] + 1


@pytest.mark.parametrize("engine", ENGINES)
def test_lost_frames_are_lost_in_both_engines(engine: str) -> None:
    world = world_of((), dropped_frames=0.5)
    clock = ManualClock()
    reads = 200
    indices = []
    with camera(engine, world, clock, seed=3) as cam:
        for _ in range(reads):
            f = cam.read()
            assert f is not None
            indices.append(f.index)
            clock.advance(0.02)
        dropped = cam.frames_dropped
    assert 0.35 * reads < dropped < 0.65 * reads
    assert abs(len(set(indices)) - (reads - dropped)) <= 1


@pytest.mark.parametrize("engine", ENGINES)
def test_latency_in_frames_counts_the_frames_the_camera_took_not_the_reads(engine: str) -> None:
    """With its own clock at 10 Hz read at 50 Hz, a camera two frames late delivers the frame
    taken two frames (0.2 s) before the newest: the reads in between add no frames."""
    clock = ManualClock()
    late, now = [], []
    with camera(engine, world_of((), frame_rate_hz=10.0, latency_frames=2), clock) as late_cam, \
            camera(engine, world_of((), frame_rate_hz=10.0), clock) as cam:
        for _ in range(50):
            a, b = late_cam.read(), cam.read()
            assert a is not None and b is not None
            late.append(a.index)
            now.append(b.index)
            clock.advance(0.02)
    assert late[:15] == [0] * 15  # the first frame until two more were taken
    assert all(x == max(0, y - 2) for x, y in zip(late, now, strict=True))


def test_a_smear_is_at_most_the_frame_wide() -> None:
    """However fast the turn (a body knocked into a spin), one exposure averages the row."""
    from marknav.sim.camera_timing import expose

    rng = np.random.default_rng(1)
    image = rng.integers(0, 256, (12, 40, 3), dtype=np.uint8)
    widest = expose(image, motion_px=40.0)
    for px in (41.0, 1e6, math.inf, -math.inf):
        assert np.array_equal(expose(image, motion_px=px), widest)
    assert np.array_equal(expose(image, motion_px=math.nan), image)
