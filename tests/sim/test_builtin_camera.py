"""The simulated camera: projection, anti-aliased marks, conditions, frame source, speed."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from marknav.core.clock import ManualClock
from marknav.planning.kinematics import Pose
from marknav.runs.benchmarks.render import bench_render, example_poses, example_renderer
from marknav.sim.builtin_camera import (
    CameraConfig,
    Renderer,
    SimCamera,
    mark_bgr,
    project_marks,
    render,
)
from marknav.sim.projection import ProjectedMark
from marknav.sim.world import Background, Conditions, MarkSpec, World, load_world
from marknav.vision.detect import Detector
from marknav.vision.palette import ColourRange
from marknav.vision.sources import FrameSource

F, R = 590.0, 100.0
CAM = CameraConfig()
NORTH = math.pi / 2
START = Pose(0.0, 0.0, NORTH)
RED = ColourRange("red", 170, 10)
BLUE = ColourRange("blue", 95, 130)
PALETTE = (RED, BLUE, ColourRange("green", 40, 85))
EXAMPLE = Path(__file__).resolve().parents[2] / "missions" / "worlds" / "slalom-world.yaml"
QUIET = Conditions(noise_sigma=0.0)


def one_mark(x: float, y: float, *, yaw: float = 0.0, colour: str = "red",
             conditions: Conditions = QUIET, clutter: int = 0) -> World:
    return World(marks=(MarkSpec(colour=colour, x_mm=x, y_mm=y, yaw_deg=yaw, radius_mm=R),),
                 conditions=conditions, background=Background(seed=1, clutter=clutter))


def coverage(world: World, pose: Pose = START) -> npt.NDArray[np.float64]:
    """Per-pixel share of each pixel covered by the (single-colour) marks, from a noise-free
    render and the same background without marks: the anti-aliased fill blends linearly."""
    with_marks = Renderer(world, PALETTE).render(pose).astype(float)
    empty = Renderer(world.model_copy(update={"marks": ()}), PALETTE).render(pose).astype(float)
    colour = np.array(mark_bgr({c.name: c for c in PALETTE}[world.marks[0].colour]))
    diff = colour[None, None, :] - empty
    channel = np.argmax(np.abs(diff), axis=2)  # the channel where the mark differs most
    rows, cols = np.indices(channel.shape)
    d = diff[rows, cols, channel]
    alpha = (with_marks[rows, cols, channel] - empty[rows, cols, channel]) / d
    return np.clip(alpha, 0.0, 1.0)


def area_radius_and_centroid(alpha: npt.NDArray[np.float64]) -> tuple[float, float, float]:
    area = float(alpha.sum())
    v, u = np.indices(alpha.shape)
    return (math.sqrt(area / math.pi), float((alpha * u).sum() / area),
            float((alpha * v).sum() / area))


# --- geometry ---------------------------------------------------------------------------------


@pytest.mark.parametrize("d", [300.0, 500.0, 1000.0, 2000.0, 3000.0])
def test_mark_straight_ahead_has_radius_f_r_over_d(d: float) -> None:
    r, u, v = area_radius_and_centroid(coverage(one_mark(0.0, d)))
    assert r == pytest.approx(F * R / d, abs=0.15)
    assert (u, v) == pytest.approx((CAM.cx, CAM.cy), abs=0.05)


@pytest.mark.parametrize("d", [400.0, 800.0, 1500.0, 2000.0, 3000.0])
def test_detector_measures_the_rendered_radius(d: float) -> None:
    image = Renderer(one_mark(0.0, d, conditions=Conditions(), clutter=8), PALETTE).render(
        START, np.random.default_rng(0))
    (mark,) = [m for m in Detector(PALETTE).detect(image) if m.colour == "red"]
    assert mark.radius == pytest.approx(F * R / d, abs=0.5)
    assert (mark.x, mark.y) == pytest.approx((CAM.cx, CAM.cy), abs=0.3)


def test_off_axis_disc_parallel_to_the_image_is_a_circle_at_the_pinhole_position() -> None:
    x, y = -400.0, 1600.0
    r, u, v = area_radius_and_centroid(coverage(one_mark(x, y)))
    assert r == pytest.approx(F * R / y, abs=0.15)
    assert u == pytest.approx(CAM.cx + F * x / y, abs=0.05)
    assert v == pytest.approx(CAM.cy, abs=0.05)


@pytest.mark.parametrize(("d", "yaw"), [(600.0, 30.0), (1000.0, 60.0), (2000.0, -45.0)])
def test_yawed_disc_half_widths_follow_eq_3(d: float, yaw: float) -> None:
    alpha = coverage(one_mark(0.0, d, yaw=yaw))
    # The horizontal diameter lies between rows 239 and 240 (cy = 239.5).
    row = 0.5 * (alpha[239] + alpha[240])
    left = float(row[: int(CAM.cx + 0.5)].sum())
    right = float(row[int(CAM.cx + 0.5):].sum())
    a = math.radians(yaw)
    # Eq. 3: r = f·R·cos α / (d + R·sin α). Positive yaw turns the disc's right edge away.
    far = F * R * math.cos(a) / (d + R * math.sin(abs(a)))
    near = F * R * math.cos(a) / (d - R * math.sin(abs(a)))
    expected = (near, far) if yaw > 0 else (far, near)
    assert (left, right) == pytest.approx(expected, rel=0.01)


@pytest.mark.parametrize(("d", "yaw"), [(600.0, 30.0), (1000.0, 60.0), (2000.0, -45.0)])
def test_detected_ellipse_axis_ratio(d: float, yaw: float) -> None:
    image = Renderer(one_mark(0.0, d, yaw=yaw, colour="blue"), PALETTE).render(START)
    (mark,) = Detector(PALETTE).detect(image)
    a = math.radians(yaw)
    far = F * R * math.cos(a) / (d + R * math.sin(abs(a)))
    near = F * R * math.cos(a) / (d - R * math.sin(abs(a)))
    assert mark.shape == "ellipse"
    assert mark.axes[1] / mark.axes[0] == pytest.approx((far + near) / 2 / (F * R / d), rel=0.02)
    assert mark.radius == pytest.approx(F * R / d, rel=0.02)  # the vertical axis stays f·R/d


def test_a_disc_seen_from_behind_looks_the_same() -> None:
    front = coverage(one_mark(0.0, 1200.0, yaw=30.0))
    back = coverage(one_mark(0.0, 1200.0, yaw=210.0))  # the same disc, its other face on view
    assert np.abs(front - back).max() < 0.02
    assert front.sum() == pytest.approx(back.sum(), rel=1e-3)


def test_nearer_marks_hide_farther_ones_whatever_the_list_order() -> None:
    near = MarkSpec(colour="red", x_mm=0.0, y_mm=1000.0, radius_mm=R)
    far = MarkSpec(colour="blue", x_mm=60.0, y_mm=2500.0, radius_mm=R)
    images = [
        Renderer(World(marks=marks, conditions=QUIET, background=Background(clutter=0)),
                 PALETTE).render(START)
        for marks in ((near, far), (far, near))
    ]
    assert np.array_equal(images[0], images[1])
    img = images[0]
    u_far = round(CAM.cx + F * 60.0 / 2500.0)
    assert tuple(img[240, u_far]) == tuple(round(c) for c in mark_bgr(RED))  # covered
    found = Detector(PALETTE).detect(img)
    assert [m.colour for m in found] == ["red"]  # the blue one is wholly hidden


def test_marks_are_cut_by_the_image_edge_and_behind_the_camera_is_empty() -> None:
    # Centre projected onto the image's left edge (u = −0.5): half the disc is in the image.
    d = 1500.0
    x = (-0.5 - CAM.cx) * d / F
    alpha = coverage(one_mark(x, d))
    assert alpha.sum() == pytest.approx(math.pi * (F * R / d) ** 2 / 2, rel=0.01)
    assert alpha[:, 0].max() > 0.99
    behind = one_mark(0.0, -1000.0)
    assert project_marks(behind, START) == []
    assert coverage(behind).max() == 0.0


def test_a_mark_beside_the_camera_is_clipped_at_the_near_plane() -> None:
    # A disc in the plane x = 30 mm, from y = −60 to 140 mm: partly behind the camera.
    world = one_mark(30.0, 40.0, yaw=90.0)
    (pm,) = project_marks(world, START)
    assert np.all(np.isfinite(pm.polygon))
    assert pm.bbox[0] > CAM.cx  # all of it right of the centre
    alpha = coverage(world)
    assert alpha[:, : int(CAM.cx)].max() == 0.0
    assert alpha[:, -1].mean() > 0.9  # reaches the right edge, top to bottom


def test_forward_offset_moves_the_camera() -> None:
    cam = CameraConfig(forward_offset_mm=200.0)
    (pm,) = project_marks(one_mark(0.0, 1200.0), START, cam)
    assert pm.depth_mm == pytest.approx(1000.0)
    assert CameraConfig.from_fov(640, 480, 2 * math.degrees(math.atan(320 / 590))).focal_px == \
        pytest.approx(590.0)


def test_background_turns_with_the_heading() -> None:
    renderer = Renderer(one_mark(0.0, 1500.0, clutter=12), PALETTE)
    wp = round(2 * math.pi * F)
    a = renderer.background(START)
    b = renderer.background(Pose(0.0, 0.0, NORTH + 10 * 2 * math.pi / wp))
    # Turning left by 10 columns' worth moves the scene 10 columns to the right.
    assert np.array_equal(b[:, 10:], a[:, :-10])
    full_turn = renderer.background(Pose(0.0, 0.0, NORTH + 2 * math.pi))
    assert np.array_equal(full_turn, a)


def test_background_is_low_saturation_and_clutter_is_coloured() -> None:
    import cv2

    plain = Renderer(one_mark(0.0, 1500.0, clutter=0), PALETTE).background(START)
    hsv = cv2.cvtColor(np.ascontiguousarray(plain), cv2.COLOR_BGR2HSV)
    assert np.percentile(hsv[:, :, 1], 99) < 60
    cluttered = Renderer(one_mark(0.0, 1500.0, clutter=40), PALETTE)
    sat = [cv2.cvtColor(np.ascontiguousarray(cluttered.background(Pose(0, 0, t))),
                        cv2.COLOR_BGR2HSV)[:, :, 1] for t in np.linspace(0, 2 * math.pi, 7)]
    assert max(float((s > 120).mean()) for s in sat) > 0.01


def test_render_is_deterministic_for_an_rng_seed() -> None:
    world = load_world(EXAMPLE)
    a = render(world, START, CAM, PALETTE, np.random.default_rng(5))
    b = render(world, START, CAM, PALETTE, np.random.default_rng(5))
    c = render(world, START, CAM, PALETTE, np.random.default_rng(6))
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)
    noise = a.astype(int) - render(world, START, CAM, PALETTE, None).astype(int)
    assert 1.5 < float(noise.std()) < 2.5  # σ = 2 grey levels in the example world


def test_unknown_colour_is_refused() -> None:
    with pytest.raises(ValueError, match="'purple' is not in the palette"):
        Renderer(one_mark(0.0, 1000.0, colour="purple"), PALETTE)


# --- conditions -------------------------------------------------------------------------------

CONDITIONS = {
    "dim": Conditions(lighting_gain=0.5),
    "bright": Conditions(lighting_gain=1.5),
    "warm": Conditions(cast="warm"),
    "cool": Conditions(cast="cool"),
    "noisy": Conditions(noise_sigma=6.0),
    "blurred": Conditions(blur_sigma_px=1.2),
    "everything": Conditions(lighting_gain=0.6, cast="cool", noise_sigma=5.0, blur_sigma_px=1.0),
}


def _hidden(pm: ProjectedMark, projected: list[ProjectedMark]) -> bool:
    """Whether a nearer mark's face covers part of ``pm``'s (their image discs overlap)."""
    return any(q.depth_mm < pm.depth_mm and
               math.hypot(q.u - pm.u, q.v - pm.v) < F * R / q.depth_mm + F * R / pm.depth_mm
               for q in projected)


def _check_found(name: str, *, hidden: bool) -> int:
    """Assert the rendered marks (the partly hidden ones when ``hidden``, else the wholly seen
    ones) are found under condition ``name`` at their centre, colour and radius; their count."""
    world = load_world(EXAMPLE).with_mark_radius(R).with_conditions(CONDITIONS[name])
    renderer = Renderer(world, PALETTE)
    pose = Pose(0.0, 300.0, NORTH)
    image = renderer.render(pose, np.random.default_rng(1))
    found = Detector(PALETTE).detect(image)
    projected = list(renderer.project(pose))
    checked = 0
    for pm in projected:
        if _hidden(pm, projected) != hidden:
            continue
        mark = world.marks[pm.index]
        expected_r = F * R / pm.depth_mm
        match = [m for m in found if math.hypot(m.x - pm.u, m.y - pm.v) < 2.0]
        assert match, f"{mark.colour} mark at {mark.xy} not found under {name}"
        assert match[0].colour == mark.colour
        assert match[0].radius == pytest.approx(expected_r, rel=0.04)
        checked += 1
    return checked


@pytest.mark.parametrize("name", sorted(CONDITIONS))
def test_detector_finds_rendered_marks_under_each_condition(name: str) -> None:
    assert _check_found(name, hidden=False) >= 3


#: The pipeline detector measures a mark by what of it shows: one whose face is partly behind a
#: nearer mark's (the far blue one here, about half hidden) is not yet fitted from its arc.
@pytest.mark.xfail(strict=True, reason="pipeline detector: partly hidden marks are not fitted "
                   "from their visible arc")
@pytest.mark.parametrize("name", sorted(CONDITIONS))
def test_detector_finds_partly_hidden_rendered_marks_under_each_condition(name: str) -> None:
    assert _check_found(name, hidden=True) >= 1


def test_sim_camera_is_a_frame_source_with_latency() -> None:
    world = one_mark(0.0, 1500.0, conditions=Conditions(latency_frames=2))
    clock = ManualClock()
    poses = iter([Pose(0.0, 100.0 * k, NORTH) for k in range(10)])
    current: list[Pose] = []

    def pose_fn() -> Pose:
        current.append(next(poses))
        return current[-1]

    cam = SimCamera(world, PALETTE, pose_fn=pose_fn, clock=clock, seed=3)
    assert isinstance(cam, FrameSource)
    assert cam.name == "sim" and cam.latency_frames == 2
    detector = Detector(PALETTE)
    delivered = []
    for _ in range(6):
        frame = cam.read()
        assert frame is not None
        delivered.append((frame.index, frame.t))
        (mark,) = detector.detect(frame.image)
        taken_at = current[frame.index]  # the pose when this frame was rendered
        assert mark.radius == pytest.approx(F * R / (1500.0 - taken_at.y), abs=0.5)
        clock.advance(0.05)
    # The first frame until two more have been taken, then always two reads behind.
    assert [i for i, _ in delivered] == [0, 0, 0, 1, 2, 3]
    assert [t for _, t in delivered] == pytest.approx([0.0, 0.0, 0.0, 0.05, 0.10, 0.15])
    cam.close()
    cam.close()
    assert cam.read() is None


def test_sim_camera_without_latency_and_as_context_manager() -> None:
    clock = ManualClock(12.5)
    with SimCamera(one_mark(0.0, 1500.0), PALETTE, pose_fn=lambda: START, clock=clock,
                   latency_frames=0, name="front") as cam:
        a = cam.read()
        b = cam.read()
        assert a is not None and b is not None
        assert (a.index, b.index, a.t, cam.name) == (0, 1, 12.5, "front")
        assert cam.config == CAM
    assert cam.read() is None


# --- the benchmark's workload (its speed is `marknav bench render`, not a test) -----------------


def test_frames_are_a_pure_function_of_pose_and_noise_draw() -> None:
    # The example world with noise and blur, marks approaching (the render benchmark's frames).
    renderer = example_renderer()
    poses = example_poses(30)
    first = [renderer.render(p, np.random.default_rng(7)) for p in poses]
    again = [renderer.render(p, np.random.default_rng(7)) for p in poses]
    assert all(np.array_equal(a, b) for a, b in zip(first, again, strict=True))
    assert all(f.shape == (480, 640, 3) and f.dtype == np.uint8 for f in first)
    # another draw changes the noise only: about σ = 3 per pixel, the same picture otherwise
    other = renderer.render(poses[0], np.random.default_rng(8)).astype(float)
    diff = other - first[0].astype(float)
    assert 2.0 < float(np.std(diff)) < 6.0 and abs(float(np.mean(diff))) < 0.5
    clean = renderer.render(poses[0])
    assert np.array_equal(clean, renderer.render(poses[0]))  # no rng: noise-free, repeatable
    # moving forward changes the view: the marks grow
    assert int(np.count_nonzero(np.any(first[0] != first[-1], axis=2))) > 1000


def test_render_bench_reports_its_figure() -> None:
    out = bench_render(frames=3, batches=1)
    assert (out["width"], out["height"], out["frames"], out["batches"]) == (640, 480, 3, 1)
    assert out["frame_ms_p50"] > 0 and out["target_ms"] == 2.0
    assert out["within_target"] == (out["frame_ms_p50"] < 2.0)
    with pytest.raises(ValueError, match="at least 1"):
        bench_render(frames=0)
