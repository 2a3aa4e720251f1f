"""The simulated lens (marknav.sim.lens): distortion, principal point, the renderer's warp, and
range accuracy after undistorting detections."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydantic import ValidationError

from marknav.planning.kinematics import Pose
from marknav.sim.builtin_camera import CameraConfig, Renderer
from marknav.sim.lens import K1_RANGE, Lens, random_lens
from marknav.sim.lens_accuracy import _distort, lens_range_errors
from marknav.sim.world import Background, Conditions, MarkSpec, World, generate_world
from marknav.vision.detect import Detector
from marknav.vision.palette import DEFAULT_PALETTE
from marknav.vision.undistort import undistort_mark

UP = Pose(0.0, 0.0, math.pi / 2)


def test_a_lens_that_folds_the_image_is_refused() -> None:
    with pytest.raises(ValidationError, match="fold the image back"):
        Lens(k1=-0.4, k2=0.0)
    Lens(k1=-0.4, k2=0.08)


def test_random_lenses_are_webcam_like() -> None:
    rng = np.random.default_rng(1)
    lenses = [random_lens(rng) for _ in range(200)]
    k1 = [lens.k1 for lens in lenses]
    assert K1_RANGE[0] <= min(k1) < -0.35 and -0.05 < max(k1) <= K1_RANGE[1]
    assert all(abs(lens.p1) <= 0.002 and abs(lens.principal_offset[0]) <= 0.04
               for lens in lenses)


def test_randomised_worlds_draw_a_lens_default_worlds_none() -> None:
    route = ["red", "green"]
    plain = generate_world(route, seed=3, clearance_mm=300)
    assert plain.conditions.lens.ideal
    rnd = generate_world(route, seed=3, clearance_mm=300, conditions="randomised")
    assert rnd.conditions.lens.distorted


def _render(lens: Lens, x_mm: float) -> tuple[Renderer, np.ndarray]:
    world = World(marks=(MarkSpec(colour="red", x_mm=x_mm, y_mm=1500.0, radius_mm=100.0),),
                  conditions=Conditions(lens=lens, noise_sigma=0.0),
                  background=Background(seed=0))
    r = Renderer(world, DEFAULT_PALETTE, CameraConfig())
    return r, r.render(UP)


def test_a_pinhole_lens_changes_nothing() -> None:
    r, img = _render(Lens(), -400.0)
    assert r.intrinsics.dist == () and (r.config.cx, r.config.cy) == (319.5, 239.5)
    assert img.shape == (480, 640, 3)


@pytest.mark.parametrize("x_mm", [-700.0, 0.0, 450.0])
def test_the_warp_images_a_mark_where_opencvs_lens_model_says(x_mm: float) -> None:
    lens = Lens(k1=-0.3, k2=0.08, p1=0.001, p2=-0.0015, principal_offset=(0.03, -0.02))
    r, img = _render(lens, x_mm)
    intr = r.intrinsics
    assert intr.cx == pytest.approx(319.5 + 0.03 * 640) and intr.dist == lens.dist
    assert img.shape == (480, 640, 3)
    (pm,) = r.project(UP)
    rim = _distort(pm.polygon, intr)
    (mark,) = [m for m in Detector(DEFAULT_PALETTE).detect(img) if m.colour == "red"]
    # The detected blob is where the lens model puts the rim (its box centre and half-width).
    assert mark.x == pytest.approx(0.5 * (rim[:, 0].min() + rim[:, 0].max()), abs=0.6)
    assert mark.y == pytest.approx(0.5 * (rim[:, 1].min() + rim[:, 1].max()), abs=0.6)
    half = 0.5 * max(np.ptp(rim[:, 0]), np.ptp(rim[:, 1]))
    assert mark.radius == pytest.approx(half, abs=0.6)


def test_range_error_after_undistortion_is_small_everywhere() -> None:
    """Barrel lenses (k1 −0.4 and −0.2, with k2, p1, p2 and an off-centre principal point),
    marks from 0.5 to 3 m across the whole width: raw detections read several per cent far
    off-axis, undistorted ones within 1.5 % (95th percentile)."""
    lenses = [Lens(k1=-0.4, k2=0.13, p1=0.0015, p2=-0.001, principal_offset=(0.03, 0.02)),
              Lens(k1=-0.2, k2=0.04, p1=-0.001, p2=0.0012, principal_offset=(-0.025, -0.03))]
    samples = lens_range_errors(lenses, distances_mm=(500.0, 1500.0, 3000.0), columns=5,
                                frames=1)
    assert len(samples) >= 25
    raw = np.abs([s.raw for s in samples])
    und = np.abs([s.undistorted for s in samples])
    assert raw.max() > 0.05  # the problem is real
    assert float(np.percentile(und, 95)) <= 0.015
    assert und.max() < 0.025


def test_small_far_marks_in_a_randomised_world_read_their_size_after_undistortion() -> None:
    """Issue 13: off-axis marks of 21–32 px (1.6–2.8 m) in a randomised world (webcam lens,
    blur, noise, lighting, clutter) often come out of the detector as circles with equal axes,
    rounder than the lens made them. Undistorted, such a circle's radial axis was stretched
    past its true size (p95 7.6 %, up to +12 %) and taken for the radius; read along the
    lens's stretch it matches the pinhole image's upright half-height (p95 ≤ 1.5 %)."""
    route = ["red", "green", "blue", "yellow"]
    world = generate_world(route, seed=6, clearance_mm=300, conditions="randomised")
    renderer = Renderer(world, DEFAULT_PALETTE, CameraConfig())
    detector = Detector(DEFAULT_PALETTE)
    rng = np.random.default_rng(1)
    errors = []
    for j, mark in enumerate(world.marks):
        phi = math.atan2(-mark.y_mm, -mark.x_mm)  # stand between the mark and the start
        for d in (1600.0, 2000.0, 2400.0, 2800.0):
            for ang in (-22.0, -16.0, 16.0, 22.0):
                pose = Pose(mark.x_mm + d * math.cos(phi), mark.y_mm + d * math.sin(phi),
                            phi + math.pi + math.radians(ang))
                seen = [p for p in renderer.project(pose) if p.index == j]
                if not seen or seen[0].polygon[:, 0].min() < 3 or \
                        seen[0].polygon[:, 0].max() > 636:
                    continue
                found = [undistort_mark(m, renderer.intrinsics)
                         for m in detector.detect(renderer.render(pose, rng))
                         if m.colour == mark.colour]
                near = [m for m in found if abs(m.x - seen[0].u) < 4]
                if near:
                    errors.append(near[0].radius / (0.5 * np.ptp(seen[0].polygon[:, 1])) - 1)
    assert len(errors) >= 40
    assert float(np.percentile(np.abs(errors), 95)) <= 0.015
