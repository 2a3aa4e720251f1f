"""The renderer's faster paths give the same numbers and pixels as the plain ones.

Projection works on every rim at once and the near-plane clip on every edge at once; a noisy
frame without lens and poles is built in two passes (background + positive noise, marks' box
likewise, then − negative noise) instead of copy, add, subtract. Each is compared exactly with
the straightforward computation it replaced.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
import pytest

from marknav.planning.kinematics import Pose
from marknav.runs.benchmarks.render import example_poses, example_renderer
from marknav.sim.builtin_camera import CameraConfig, Renderer
from marknav.sim.projection import MarkGeometry, clip_near, inset, rim_projection
from marknav.sim.world import Background, Conditions, MarkSpec, World
from marknav.vision.palette import ColourRange

FloatArray = npt.NDArray[np.float64]
PALETTE = (ColourRange("red", 170, 10), ColourRange("blue", 95, 130),
           ColourRange("green", 40, 85))


def reference_clip(pts: FloatArray, near: float) -> FloatArray:
    """Sutherland–Hodgman, one edge at a time."""
    out: list[FloatArray] = []
    n = len(pts)
    for i in range(n):
        a, b = pts[i], pts[(i + 1) % n]
        a_in, b_in = a[2] >= near, b[2] >= near
        if a_in:
            out.append(a)
        if a_in != b_in:
            t = (near - a[2]) / (b[2] - a[2])
            out.append(a + t * (b - a))
    return np.array(out) if out else np.empty((0, 3))


def reference_polygons(geometry: MarkGeometry, pose: Pose,
                       config: CameraConfig) -> list[tuple[int, FloatArray]]:
    """Each mark in front projected on its own, as the renderer did before."""
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    ox = pose.x + config.forward_offset_mm * c
    oy = pose.y + config.forward_offset_mm * s
    zc = (geometry.centres[:, 0] - ox) * c + (geometry.centres[:, 1] - oy) * s
    out = []
    for j in np.nonzero(zc + geometry.radii > config.near_mm)[0]:
        dx = geometry.rims[j, :, 0] - ox
        dy = geometry.rims[j, :, 1] - oy
        z = dx * c + dy * s
        x = dx * s - dy * c
        y = -geometry.rims[j, :, 2]
        if z.min() <= config.near_mm:
            pts = reference_clip(np.stack([x, y, z], axis=1), config.near_mm)
            if len(pts) < 3:
                continue
            x, y, z = pts[:, 0], pts[:, 1], pts[:, 2]
        f = config.focal_px
        out.append((int(j), np.stack([config.cx + f * x / z, config.cy + f * y / z], axis=1)))
    return out


def test_near_plane_clip_is_the_edge_by_edge_clip() -> None:
    rng = np.random.default_rng(3)
    for _ in range(500):
        n = int(rng.integers(3, 100))
        pts = rng.normal(0.0, 100.0, (n, 3))
        pts[:, 2] += rng.uniform(-150, 150)
        if rng.random() < 0.1:
            pts[int(rng.integers(n)), 2] = 10.0  # a vertex exactly on the plane
        fast, slow = clip_near(pts, 10.0), reference_clip(pts, 10.0)
        assert fast.shape == slow.shape and np.array_equal(fast, slow)


def test_projection_of_all_rims_at_once_is_bitwise_the_same() -> None:
    rng = np.random.default_rng(5)
    marks = tuple(MarkSpec(colour="red", x_mm=float(rng.uniform(-1500, 1500)),
                           y_mm=float(rng.uniform(-500, 3000)),
                           yaw_deg=float(rng.uniform(-80, 80)), radius_mm=100.0)
                  for _ in range(12))
    world = World(marks=marks, conditions=Conditions(noise_sigma=0.0))
    geometry = MarkGeometry(world)
    config = CameraConfig(forward_offset_mm=50.0)
    seen = clipped = 0
    for _ in range(300):
        pose = Pose(float(rng.uniform(-800, 800)), float(rng.uniform(-300, 1500)),
                    float(rng.uniform(-math.pi, math.pi)))
        fast = geometry.project(pose, config)
        expected = {j: poly for j, poly in reference_polygons(geometry, pose, config)}
        for pm in fast:
            assert np.array_equal(pm.polygon, expected[pm.index])
            clipped += len(pm.polygon) != 96
        # the marks left out are exactly the reference polygons outside the image
        for j, poly in expected.items():
            if j not in {pm.index for pm in fast}:
                lo, hi = poly.min(axis=0), poly.max(axis=0)
                assert (hi[0] < -0.5 or hi[1] < -0.5 or lo[0] > config.width - 0.5
                        or lo[1] > config.height - 0.5)
        seen += len(fast)
    assert seen > 100 and clipped > 2  # the test saw marks, and marks cut by the near plane


@pytest.mark.parametrize("blur", [0.0, 0.5, 1.2])
def test_two_pass_noisy_frames_equal_copy_add_subtract(blur: float) -> None:
    if blur == 0.5:
        renderer = example_renderer()  # the example world: noise, blur, clutter
    else:
        world = example_renderer().world
        renderer = Renderer(world.model_copy(update={"conditions": world.conditions.model_copy(
            update={"blur_sigma_px": blur})}), PALETTE)
    assert renderer._noise is not None and renderer._warp is None and not renderer._poles
    pos, neg = renderer._noise
    h, w = renderer.config.height, renderer.config.width
    with_marks = 0
    for k, pose in enumerate(example_poses(25)):
        frame = renderer.render(pose, np.random.default_rng(k))
        draw = np.random.default_rng(k)
        oy, ox = int(draw.integers(0, h + 1)), int(draw.integers(0, w + 1))
        clean = renderer.render(pose)  # no rng: the plain path, without noise
        expected = np.clip(clean.astype(int) + pos[oy:oy + h, ox:ox + w]
                           - neg[oy:oy + h, ox:ox + w], 0, 255)
        # (the saturating add then subtract equals one clip: a pixel's noise has one sign)
        assert np.array_equal(frame, expected)
        with_marks += bool(renderer.project(pose))
    assert with_marks > 10


def test_noisy_frames_with_poles_still_take_the_plain_path() -> None:
    world = World(marks=(MarkSpec(colour="blue", x_mm=0.0, y_mm=900.0, radius_mm=100.0),),
                  conditions=Conditions(noise_sigma=3.0, blur_sigma_px=0.5, occluders=4),
                  background=Background(seed=2, clutter=3))
    renderer = Renderer(world, PALETTE)
    assert renderer._poles
    pose = Pose(0.0, 0.0, math.pi / 2)
    pos, neg = renderer._noise or (None, None)
    assert pos is not None and neg is not None
    draw = np.random.default_rng(1)
    oy, ox = int(draw.integers(0, 481)), int(draw.integers(0, 641))
    expected = np.clip(renderer.render(pose).astype(int) + pos[oy:oy + 480, ox:ox + 640]
                       - neg[oy:oy + 480, ox:ox + 640], 0, 255)
    assert np.array_equal(renderer.render(pose, np.random.default_rng(1)), expected)


def reference_inset(poly: FloatArray, by: float) -> FloatArray:
    """The NumPy inset the renderer used before its compiled pass."""
    n = len(poly)
    nxt, prv = poly[np.roll(np.arange(n), -1)], poly[np.roll(np.arange(n), 1)]
    x, y = poly[:, 0], poly[:, 1]
    area2 = float(np.dot(x, nxt[:, 1]) - np.dot(nxt[:, 0], y))
    if area2 == 0.0:
        return poly
    edges = nxt - poly
    perimeter = float(np.sum(np.sqrt(np.einsum("ij,ij->i", edges, edges))))
    by = min(by, 0.25 * abs(area2) / perimeter)
    t = nxt - prv
    norm = np.sqrt(np.einsum("ij,ij->i", t, t))
    norm[norm == 0] = 1.0
    k = math.copysign(by, area2) / norm
    out = poly.copy()
    out[:, 0] -= t[:, 1] * k
    out[:, 1] += t[:, 0] * k
    return out


def test_the_compiled_inset_is_the_numpy_inset() -> None:
    """The same vertices to the last bits that the fill's fixed point (1/256 px) could see:
    the sums run in another order, nothing else differs."""
    rng = np.random.default_rng(11)
    geometry = MarkGeometry(World(marks=tuple(
        MarkSpec(colour="red", x_mm=-1500.0 + 260.0 * i, y_mm=float(rng.uniform(200, 3000)),
                 yaw_deg=float(rng.uniform(-89, 89)), radius_mm=100.0) for i in range(12))))
    config = CameraConfig(forward_offset_mm=50.0)
    polygons = []
    for _ in range(200):
        pose = Pose(float(rng.uniform(-800, 800)), float(rng.uniform(-300, 1500)),
                    float(rng.uniform(-math.pi, math.pi)))
        polygons += [pm.polygon for pm in geometry.project(pose, config)]
    phi = np.linspace(0.0, 2.0 * math.pi, 96, endpoint=False)
    for _ in range(100):  # marks seen almost edge-on: the inset is limited by their width
        a, b, t = rng.uniform(5, 60), rng.uniform(0.2, 2.0), rng.uniform(0, math.pi)
        u, v = a * np.cos(phi), b * np.sin(phi)
        polygons.append(np.stack([rng.uniform(0, 640) + u * math.cos(t) - v * math.sin(t),
                                  rng.uniform(0, 480) + u * math.sin(t) + v * math.cos(t)],
                                 axis=1))
    same = 0
    for poly in polygons:
        got, want = inset(poly, 0.6), reference_inset(poly, 0.6)
        assert got.shape == want.shape
        assert np.allclose(got, want, rtol=0.0, atol=1e-9)
        assert np.array_equal(np.round(got * 256), np.round(want * 256))
        same += bool(np.array_equal(got, want))
    assert len(polygons) > 300 and same > 0.75 * len(polygons)  # the thin ones: last bits
    flat = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])  # no area: unchanged
    assert np.array_equal(inset(flat, 0.6), flat)


def test_rendering_compiles_nothing_after_the_renderer_is_built() -> None:
    """The projection's compiled loops are loaded when a renderer is built, before a run's
    clock starts: no frame stops to compile."""
    renderer = example_renderer()
    loops = (rim_projection, inset)
    before = [len(loop.signatures) for loop in loops]
    assert all(before)
    for k, pose in enumerate(example_poses(25)):
        renderer.render(pose, np.random.default_rng(k))
        renderer.render(pose)
    assert [len(loop.signatures) for loop in loops] == before
