"""Simulated camera: a pinhole camera at mark height that renders the world (paper §3.1).

The camera sits at the robot's centre (plus ``forward_offset_mm`` along the heading), at the
height of the marks' centres, looking along the heading — the paper's set-up, in which a mark
straight ahead at distance d has radius r = f·R/d (eq. 2) and a disc turned by α becomes an
ellipse whose horizontal half-width is f·R·cos α / (d ± R·sin α) (eq. 3).

Rendering (:class:`Renderer`, :func:`render`):

- **Marks** are projected exactly: their rim (``RIM_POINTS`` points, radius scaled so the polygon
  has the disc's area) goes through the pinhole model, clipped at the near plane, and the polygon
  is filled — so perspective, obliquity (eq. 3) and discs seen from behind (the same colour on
  both faces) come out right. Marks are painted far to near (occlusion), cut by the image edge,
  fully saturated at ``ColourRange.centre_hue`` of their colour, with **no** rim. Edges are
  anti-aliased with ``cv2.LINE_AA`` at 1/256 px precision; OpenCV's anti-aliased fill paints
  ≈ 0.6 px beyond the true edge, so polygons are first moved in by ``AA_EDGE_BIAS_PX`` (measured:
  the filled area then matches the disc's to ≈ 0.05 px of radius).
- **Background**: a cylindrical panorama at infinity (one column per 1/f rad of azimuth), made
  once per world: a low-saturation textured wall and floor, panels, a skirting board, and the
  world's clutter (:func:`marknav.sim.world.clutter_items`: coloured posters and stripes, not
  circular). A frame's background is a slice of it chosen by the heading (the pinhole's tangent
  warp of the background is ignored; only the marks are projected exactly). Walls and boxes of the
  world take part in collisions only; they are not drawn.
- **Conditions**: lighting gain × colour cast are applied once to the panorama and the mark
  colours; per frame, a Gaussian blur (σ ``blur_sigma_px``) and additive Gaussian noise (σ
  ``noise_sigma``, from a pre-generated tile at a random offset drawn from ``rng``).

:class:`SimCamera` is a :class:`marknav.vision.sources.FrameSource`: each ``read`` renders the
world as it was at the frame's capture time, ``clock.now()`` minus the world's
``camera_latency_s + processing_s`` (continuous time: the pose comes from ``pose_at(t)``, the
simulator's true path interpolated), and stamps the frame with that capture time;
``latency_frames`` further delays delivery through a ring buffer. The principal point is the
image centre ((width − 1)/2, (height − 1)/2), pixel centres at integer coordinates, as
OpenCV's moments and ``fitEllipse`` count them.
"""

from __future__ import annotations

import functools
import math
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from marknav.core.clock import Clock
from marknav.planning.kinematics import Pose
from marknav.sim.camera_model import SIM_FOCAL_PX, SIM_HEIGHT, SIM_WIDTH, sim_range_law
from marknav.sim.camera_timing import FrameClock, expose, exposure_gain, exposure_phase
from marknav.sim.lens import LensWarp, lens_warp
from marknav.sim.projection import RIM_POINTS, MarkGeometry, ProjectedMark, inset
from marknav.sim.projection import warm_up as _warm_projection
from marknav.sim.scenery import draw_poles, near_hues, paint_distractors, paint_room, poles
from marknav.sim.world.clutter import ClutterItem, clutter_items
from marknav.sim.world.schema import Background, Conditions, World
from marknav.vision.estimate import PowerLaw
from marknav.vision.palette import ColourRange
from marknav.vision.sources import Frame, Image
from marknav.vision.undistort import Intrinsics

__all__ = [
    "AA_EDGE_BIAS_PX",
    "RIM_POINTS",
    "CameraConfig",
    "ProjectedMark",
    "Renderer",
    "SimCamera",
    "mark_bgr",
    "mark_inks",
    "project_marks",
    "render",
    "tilt_rotation",
]

FloatArray = npt.NDArray[np.float64]

#: How far OpenCV's anti-aliased fill reaches beyond a polygon's edge (measured, OpenCV 4.x/5.0).
AA_EDGE_BIAS_PX = 0.6
_SHIFT = 8  # fixed-point bits for cv2.fillPoly
#: Elevation of the far wall's base below the horizon (camera above the floor), degrees.
_WALL_BASE_DEG = 1.5


@dataclass(frozen=True)
class CameraConfig:
    """A pinhole camera. ``principal`` defaults to the image centre; ``forward_offset_mm`` moves
    the camera ahead of the robot's centre along the heading; ``near_mm`` is the near plane."""

    width: int = SIM_WIDTH
    height: int = SIM_HEIGHT
    focal_px: float = SIM_FOCAL_PX
    principal: tuple[float, float] | None = None
    forward_offset_mm: float = 0.0
    near_mm: float = 10.0

    def __post_init__(self) -> None:
        if self.width < 16 or self.height < 16:
            raise ValueError(f"camera: image too small ({self.width}×{self.height})")
        if not self.focal_px > 0:
            raise ValueError(f"camera: focal length must be positive, got {self.focal_px}")
        if not self.near_mm > 0:
            raise ValueError(f"camera: near plane must be positive, got {self.near_mm}")

    @classmethod
    def from_fov(cls, width: int, height: int, hfov_deg: float, **kwargs: Any) -> CameraConfig:
        """A camera given its horizontal field of view instead of its focal length."""
        if not 0 < hfov_deg < 180:
            raise ValueError(f"camera: field of view must be in (0, 180) degrees, got {hfov_deg}")
        focal = (width / 2.0) / math.tan(math.radians(hfov_deg) / 2.0)
        return cls(width=width, height=height, focal_px=focal, **kwargs)

    @property
    def cx(self) -> float:
        return self.principal[0] if self.principal is not None else (self.width - 1) / 2.0

    @property
    def cy(self) -> float:
        return self.principal[1] if self.principal is not None else (self.height - 1) / 2.0

    @property
    def hfov_rad(self) -> float:
        """Horizontal field of view (rad)."""
        return 2.0 * math.atan((self.width / 2.0) / self.focal_px)


def mark_bgr(colour: ColourRange, *, saturation: float = 1.0,
             hue_offset: float = 0.0) -> tuple[float, float, float]:
    """The BGR colour (0..255) a mark of ``colour`` is painted: hue at the middle of the range
    (plus ``hue_offset``, OpenCV units), full value, ``saturation`` (1: full) — printed marks
    are less than fully saturated (world conditions ``mark_saturation``, ``..._spread``)."""
    hue = (colour.centre_hue + hue_offset) % 180.0
    hsv = np.array([[[hue * 2.0, min(1.0, max(0.0, saturation)), 1.0]]], dtype=np.float32)
    bgr = cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)[0, 0] * 255.0
    return (float(bgr[0]), float(bgr[1]), float(bgr[2]))


# --- geometry ---------------------------------------------------------------------------------


def project_marks(world: World, pose: Pose, config: CameraConfig = CameraConfig()) -> list[
        ProjectedMark]:
    """The marks the camera at ``pose`` sees (any part in the image), far to near."""
    return MarkGeometry(world).project(pose, config)


def tilt_rotation(*, pitch_deg: float, roll_deg: float) -> FloatArray:
    """The rotation R of a camera turned by ``pitch_deg`` (up) and then ``roll_deg`` (about its
    optical axis) from level, in camera coordinates (x right, y down, z forward): a ray of the
    level camera has coordinates R·d in the turned one (its rows are the turned camera's axes in
    the level camera's coordinates)."""
    p, r = math.radians(pitch_deg), math.radians(roll_deg)
    pitch = np.array([[1.0, 0.0, 0.0],
                      [0.0, math.cos(p), math.sin(p)],
                      [0.0, -math.sin(p), math.cos(p)]])
    roll = np.array([[math.cos(r), -math.sin(r), 0.0],
                     [math.sin(r), math.cos(r), 0.0],
                     [0.0, 0.0, 1.0]])
    return np.asarray(roll @ pitch, dtype=np.float64)


def tilt_homography(config: CameraConfig, *, pitch_deg: float,
                    roll_deg: float) -> FloatArray | None:
    """The image map of a camera turned by ``pitch_deg`` (up) and then ``roll_deg`` (about its
    optical axis) from level (:func:`tilt_rotation`): H = K·R·K⁻¹ (a rotation about the centre
    of projection maps the whole image by a homography; Hartley & Zisserman, 2nd ed., §8.4.2).
    A level point ahead goes to the row cy + f·tan(pitch). ``None`` for a level camera."""
    if pitch_deg == 0.0 and roll_deg == 0.0:
        return None
    k = np.array([[config.focal_px, 0.0, config.cx], [0.0, config.focal_px, config.cy],
                  [0.0, 0.0, 1.0]])
    h = k @ tilt_rotation(pitch_deg=pitch_deg, roll_deg=roll_deg) @ np.linalg.inv(k)
    return np.asarray(h / h[2, 2], dtype=np.float64)


# --- background -------------------------------------------------------------------------------


def _smooth_noise(rng: np.random.Generator, rows: int, cols: int, cell: int) -> FloatArray:
    """Zero-mean, unit-ish smooth noise that wraps around horizontally."""
    lr = max(2, rows // cell + 2)
    lc = max(4, cols // cell)
    low = rng.standard_normal((lr, lc)).astype(np.float32)
    padded = np.hstack([low, low[:, :3]])
    width = round((lc + 3) * cols / lc)
    big = cv2.resize(padded, (width, rows), interpolation=cv2.INTER_CUBIC)
    return np.asarray(big[:, :cols], dtype=np.float64)


def _hsv_bgr(h: float, s: float, v: float) -> FloatArray:
    hsv = np.array([[[h * 2.0, s / 255.0, v / 255.0]]], dtype=np.float32)
    return np.asarray(cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)[0, 0], dtype=np.float64) * 255.0


def _draw_clutter(
    pan: Image, item: ClutterItem, config: CameraConfig, wp: int, gains: FloatArray
) -> None:
    f, cy = config.focal_px, config.cy
    col = (-item.azimuth_deg / 360.0 * wp) % wp
    half_w = item.width_deg / 360.0 * wp / 2.0
    top = cy - f * math.tan(math.radians(item.elevation_deg + item.height_deg / 2.0))
    bottom = cy - f * math.tan(math.radians(item.elevation_deg - item.height_deg / 2.0))
    bgr = np.minimum(_hsv_bgr(item.hue, item.sat, item.val) * gains, 255.0)
    colour = (float(bgr[0]), float(bgr[1]), float(bgr[2]))
    rects: list[tuple[float, float, float, float]] = []
    if item.kind == "rect":
        rects.append((col - half_w, top, col + half_w, bottom))
    else:
        n = 2 * item.bars - 1
        if half_w * 2 >= bottom - top:  # vertical bars across a wide patch
            step = 2 * half_w / n
            rects += [(col - half_w + 2 * k * step, top, col - half_w + (2 * k + 1) * step, bottom)
                      for k in range(item.bars)]
        else:
            step = (bottom - top) / n
            rects += [(col - half_w, top + 2 * k * step, col + half_w, top + (2 * k + 1) * step)
                      for k in range(item.bars)]
    for u0, v0, u1, v1 in rects:
        for shift in (-wp, 0, wp):
            pts = np.array([[u0 + shift, v0], [u1 + shift, v0], [u1 + shift, v1],
                            [u0 + shift, v1]])
            cv2.fillPoly(pan, [np.round(pts * (1 << _SHIFT)).astype(np.int32)], colour,
                         cv2.LINE_AA, _SHIFT)


@functools.lru_cache(maxsize=4)
def _panorama(
    background: Background, gains_bgr: tuple[float, float, float], config: CameraConfig,
    room: Conditions | None = None, near: tuple[float, ...] = (),
    palette_ranges: tuple[tuple[int, int], ...] = (),
) -> Image:
    """The background for every heading: H × Wp × 3 (Wp = 2πf columns), gains applied.
    Cached: worlds that differ only in their marks share it (treat it as read-only)."""
    rng = np.random.default_rng([background.seed, 0xBAC6])
    h = config.height
    wp = round(2.0 * math.pi * config.focal_px)
    cy = config.cy
    base_row = round(cy + config.focal_px * math.tan(math.radians(_WALL_BASE_DEG)))
    base_row = min(max(base_row, 1), h - 1)

    pan = np.empty((h, wp, 3), dtype=np.float32)
    wall_hue, wall_sat, wall_val = rng.uniform(0, 180), rng.uniform(8, 30), rng.uniform(140, 180)
    floor_hue, floor_sat, floor_val = rng.uniform(0, 180), rng.uniform(10, 35), rng.uniform(85, 120)
    pan[:base_row] = _hsv_bgr(wall_hue, wall_sat, wall_val)
    pan[base_row:] = _hsv_bgr(floor_hue, floor_sat, floor_val)
    # Panels and pillars: grey rectangles standing on the wall's base.
    for _ in range(int(rng.integers(5, 12))):
        c0 = float(rng.uniform(0, wp))
        width = float(rng.uniform(30, 220))
        top = float(rng.uniform(0, base_row - 20))
        grey = _hsv_bgr(float(rng.uniform(0, 180)), float(rng.uniform(0, 25)),
                        float(rng.uniform(110, 200)))
        for shift in (-wp, 0, wp):
            pts = np.array([[c0 + shift, top], [c0 + width + shift, top],
                            [c0 + width + shift, base_row], [c0 + shift, base_row]])
            cv2.fillPoly(pan, [np.round(pts * (1 << _SHIFT)).astype(np.int32)],
                         tuple(float(v) for v in grey), cv2.LINE_8, _SHIFT)
    # Texture: smooth shading plus grain, stronger on the floor.
    shade = _smooth_noise(rng, h, wp, 24).astype(np.float32)
    grain = rng.standard_normal((h, wp), dtype=np.float32)
    amp = np.where(np.arange(h)[:, None] < base_row, 9.0, 14.0).astype(np.float32)
    pan += (amp * shade + 3.0 * grain)[:, :, None]
    if room is not None:
        paint_room(pan, base_row, background.seed, room, palette_ranges)
    # Skirting board.
    pan[max(0, base_row - 5):base_row] *= 0.45
    gains = np.array(gains_bgr)
    pan *= gains.astype(np.float32)
    out = np.empty((h, wp, 3), dtype=np.uint8)
    np.copyto(out, np.clip(np.rint(pan), 0, 255), casting="unsafe")
    for item in clutter_items(background):  # on the 8-bit image: OpenCV anti-aliases only 8-bit
        _draw_clutter(out, item, config, wp, gains)
    if room is not None:
        paint_distractors(out, background.seed, room.distractors, near, config.focal_px, cy,
                          gains)
    return out


def _room(conditions: Conditions) -> Conditions | None:
    """The conditions when they ask for a harder room (the panorama's cache key), else None."""
    plain = conditions.floor == "plain" and conditions.wall == "plain" and \
        conditions.wall_hue is None and conditions.distractors == 0
    return None if plain else conditions


@functools.lru_cache(maxsize=4)
def _noise_tiles(seed: int, sigma: float, config: CameraConfig) -> tuple[Image, Image]:
    """Gaussian noise of σ ``sigma`` on a tile twice the image in each direction, split into its
    positive and negative parts (added and subtracted with 8-bit saturation per frame)."""
    rng = np.random.default_rng([seed, 0x401CE])
    tile = np.round(rng.normal(0.0, sigma, (2 * config.height, 2 * config.width, 3)))
    return (np.clip(tile, 0, 255).astype(np.uint8), np.clip(-tile, 0, 255).astype(np.uint8))


# --- renderer ---------------------------------------------------------------------------------


class Renderer:
    """Renders one world through one camera. Build once (it pre-renders the background panorama
    and the noise tile, ≈ 0.1 s), then call :meth:`render` per frame (≈ 1 ms at 640×480)."""

    def __init__(
        self, world: World, palette: Sequence[ColourRange], config: CameraConfig = CameraConfig()
    ) -> None:
        self.world = world
        # A lens (world.conditions.lens): the ideal image is drawn on a larger canvas and warped.
        lens = world.conditions.lens
        self._warp: LensWarp | None = None
        canvas = config
        if not lens.ideal:
            self._warp = lens_warp(config.width, config.height, config.focal_px, lens,
                                   (config.cx, config.cy))
            intr = self._warp.intrinsics
            config = replace(config, principal=(intr.cx, intr.cy))
            cw, ch = self._warp.canvas_size
            canvas = replace(config, width=cw, height=ch, principal=self._warp.canvas_principal)
        self.config = config
        self._canvas = canvas
        by_name = {c.name: c for c in palette}
        gains = np.array(world.conditions.channel_gains_bgr())
        self._colours: list[tuple[float, float, float]] = []
        inks = mark_inks(world)
        for i, m in enumerate(world.marks):
            if m.colour not in by_name:
                raise ValueError(
                    f"marks[{i}]: colour {m.colour!r} is not in the palette "
                    f"({', '.join(sorted(by_name))}); check the world with check_against_palette"
                )
            sat, dh = inks[i]
            bgr = np.minimum(np.array(mark_bgr(by_name[m.colour], saturation=sat,
                                               hue_offset=dh)) * gains, 255.0)
            self._colours.append((float(bgr[0]), float(bgr[1]), float(bgr[2])))
        self._geometry = MarkGeometry(world)
        _warm_projection()  # its compiled loops, loaded now rather than in the first frame
        cond = world.conditions
        ranges = tuple((c.hue_lo, c.hue_hi) for c in palette)
        pan = _panorama(world.background, cond.channel_gains_bgr(), canvas, _room(cond),
                        tuple(near_hues(list(ranges))), ranges)
        self._wp = pan.shape[1]
        self._poles = poles(world.background.seed, cond.occluders, self._wp, config.focal_px)
        self._blur = world.conditions.blur_sigma_px
        # Blur kernel radius; the panorama is padded by it on both sides so that any window
        # the blur needs exists around the image.
        self._k = math.ceil(3.0 * self._blur) if self._blur > 0 else 0
        self._margin = self._k + 2
        pad, w = self._margin, canvas.width
        columns = np.arange(-pad, self._wp + w + pad) % self._wp  # wraps even if w > Wp
        self._pan: Image = np.ascontiguousarray(pan[:, columns])
        # With blur, the background is blurred once here and only the marks' surroundings are
        # blurred per frame (from the sharp panorama, so the result is the same as blurring
        # the whole frame, but cheaper).
        self._pan_blurred = self._pan
        if self._blur > 0:
            self._pan_blurred = np.asarray(
                cv2.GaussianBlur(self._pan, self._ksize, self._blur), dtype=np.uint8)
        sigma = world.conditions.noise_sigma
        self._noise = _noise_tiles(world.background.seed, sigma, config) if sigma > 0 else None
        self._tilt = tilt_homography(config, pitch_deg=cond.camera_pitch_deg,
                                     roll_deg=cond.camera_roll_deg)

    @property
    def _ksize(self) -> tuple[int, int]:
        return (2 * self._k + 1, 2 * self._k + 1)

    def project(self, pose: Pose) -> list[ProjectedMark]:
        """The marks in view from ``pose``, far to near."""
        return self._geometry.project(pose, self.config)

    @property
    def intrinsics(self) -> Intrinsics:
        """The camera matrix and lens distortion the frames are rendered with."""
        cfg = self.config
        dist = self.world.conditions.lens.dist if self._warp is not None else ()
        return Intrinsics(fx=cfg.focal_px, fy=cfg.focal_px, cx=cfg.cx, cy=cfg.cy,
                          dist=dist if any(dist) else ())

    def _column(self, pose: Pose) -> int:
        """Column of the padded panorama where the canvas's column 0 starts."""
        c0 = round(-pose.theta * self._wp / (2.0 * math.pi) - self._canvas.cx) % self._wp
        return int(c0) + self._margin

    def background(self, pose: Pose) -> Image:
        """The background seen from ``pose`` (without lens distortion: a view into the
        panorama, the canvas's size; do not modify)."""
        c0 = self._column(pose)
        return self._pan_blurred[:, c0:c0 + self._canvas.width]

    def _draw(self, img: Image, marks: list[ProjectedMark], du: float, dv: float) -> None:
        for pm in marks:
            poly = inset(np.ascontiguousarray(pm.polygon), AA_EDGE_BIAS_PX)
            if du or dv:
                poly = poly - (du, dv)
            pts = np.round(poly * (1 << _SHIFT)).astype(np.int32)
            cv2.fillPoly(img, [pts], self._colours[pm.index], cv2.LINE_AA, _SHIFT)

    def _blurred_marks(
        self, c0: int, marks: list[ProjectedMark]
    ) -> tuple[int, int, int, int, Image]:
        """With blur: the box (u0, v0, u1, v1) of the canvas the blurred marks can reach and its
        pixels (marks drawn on the sharp panorama, then blurred)."""
        h, w = self._canvas.height, self._canvas.width
        # The pixels the blurred marks can reach: their box plus the kernel (and 1 px of
        # anti-aliasing); the blur there needs the sharp scene one kernel further out.
        boxes = [pm.bbox for pm in marks]
        reach = self._k + 2
        u0 = max(0, math.floor(min(b[0] for b in boxes)) - reach)
        v0 = max(0, math.floor(min(b[1] for b in boxes)) - reach)
        u1 = min(w - 1, math.ceil(max(b[2] for b in boxes)) + reach)
        v1 = min(h - 1, math.ceil(max(b[3] for b in boxes)) + reach)
        k = self._k
        su0, su1 = u0 - k, u1 + k
        sv0, sv1 = max(0, v0 - k), min(h - 1, v1 + k)
        roi = self._pan[sv0:sv1 + 1, c0 + su0:c0 + su1 + 1].copy()
        self._draw(roi, marks, float(su0), float(sv0))
        cv2.GaussianBlur(roi, self._ksize, self._blur, dst=roi)
        return u0, v0, u1, v1, roi[v0 - sv0:v1 - sv0 + 1, k:k + u1 - u0 + 1]

    def render(self, pose: Pose, rng: np.random.Generator | None = None, *,
               motion_px: float = 0.0, gain: float = 1.0) -> Image:
        """One BGR frame from ``pose``. ``rng`` picks the noise; ``None`` renders noise-free.

        ``motion_px``: the image moved this many pixels sideways during the exposure (the robot
        turning), smeared by a box filter of that length; ``gain``: the exposure's brightness
        factor. Both apply to the scene, before the sensor's noise."""
        if abs(motion_px) >= 1.0 or gain != 1.0:
            img = expose(self.render(pose, None), motion_px=motion_px, gain=gain)
            return self._add_noise(img, rng)
        if (self._noise is not None and rng is not None and self._warp is None
                and not self._poles and self._tilt is None):
            return self._render_noisy(pose, rng, self._noise)
        cfg = self._canvas
        h, w = cfg.height, cfg.width
        img = np.empty((h, w, 3), dtype=np.uint8)
        c0 = self._column(pose)
        np.copyto(img, self._pan_blurred[:, c0:c0 + w])
        marks = self._geometry.project(pose, cfg)
        if marks and self._k == 0:
            self._draw(img, marks, 0.0, 0.0)
        elif marks:
            u0, v0, u1, v1, crop = self._blurred_marks(c0, marks)
            img[v0:v1 + 1, u0:u1 + 1] = crop
        if self._poles:
            draw_poles(img, self._poles, c0 - self._margin, self._wp)
        if self._warp is not None:
            img = self._warp.apply(img)
            h, w = self.config.height, self.config.width
        if self._tilt is not None:
            img = np.asarray(cv2.warpPerspective(img, self._tilt, (w, h), flags=cv2.INTER_LINEAR,
                                                 borderMode=cv2.BORDER_REPLICATE),
                             dtype=np.uint8)
        return self._add_noise(img, rng)

    def _add_noise(self, img: Image, rng: np.random.Generator | None) -> Image:
        if self._noise is not None and rng is not None:
            h, w = img.shape[:2]
            pos, neg = self._noise
            oy = int(rng.integers(0, h + 1))
            ox = int(rng.integers(0, w + 1))
            cv2.add(img, pos[oy:oy + h, ox:ox + w], dst=img)
            cv2.subtract(img, neg[oy:oy + h, ox:ox + w], dst=img)
        return img

    def _render_noisy(self, pose: Pose, rng: np.random.Generator,
                      noise: tuple[Image, Image]) -> Image:
        """:meth:`render` without lens and poles, with noise, in two passes over the frame
        instead of three: the background is copied by adding the noise's positive part to it
        (the marks' box likewise), then the negative part is subtracted — per pixel the same
        saturating operations in the same order, so the same frame."""
        h, w = self._canvas.height, self._canvas.width
        pos, neg = noise
        oy = int(rng.integers(0, h + 1))
        ox = int(rng.integers(0, w + 1))
        plus = pos[oy:oy + h, ox:ox + w]
        img = np.empty((h, w, 3), dtype=np.uint8)
        c0 = self._column(pose)
        marks = self._geometry.project(pose, self._canvas)
        if marks and self._k == 0:
            np.copyto(img, self._pan_blurred[:, c0:c0 + w])
            self._draw(img, marks, 0.0, 0.0)
            cv2.add(img, plus, dst=img)
        else:
            cv2.add(self._pan_blurred[:, c0:c0 + w], plus, dst=img)
            if marks:
                u0, v0, u1, v1, crop = self._blurred_marks(c0, marks)
                img[v0:v1 + 1, u0:u1 + 1] = cv2.add(crop, plus[v0:v1 + 1, u0:u1 + 1])
        cv2.subtract(img, neg[oy:oy + h, ox:ox + w], dst=img)
        return img


def mark_inks(world: World) -> list[tuple[float, float]]:
    """Each mark's (saturation, hue offset) as printed: ``mark_saturation`` ± up to
    ``mark_saturation_spread`` and a hue ± up to ``mark_hue_spread`` OpenCV units, drawn per mark
    from the world's background seed (the same marks look the same in every run)."""
    c = world.conditions
    rng = np.random.default_rng([world.background.seed, 0x1C0])
    out = []
    for _ in world.marks:
        ds = float(rng.uniform(-1.0, 1.0)) * c.mark_saturation_spread
        dh = float(rng.uniform(-1.0, 1.0)) * c.mark_hue_spread
        out.append((min(1.0, max(0.05, c.mark_saturation + ds)), dh))
    return out


@functools.lru_cache(maxsize=8)
def _cached_renderer(
    world: World, palette: tuple[ColourRange, ...], config: CameraConfig
) -> Renderer:
    return Renderer(world, palette, config)


def render(
    world: World,
    pose: Pose,
    camera_config: CameraConfig,
    palette: Sequence[ColourRange],
    rng: np.random.Generator | None,
) -> Image:
    """One frame of ``world`` seen from ``pose`` (a pure function of its arguments and the rng's
    state). The per-world background is cached, so repeated calls cost one frame each."""
    return _cached_renderer(world, tuple(palette), camera_config).render(pose, rng)


class SimCamera:
    """The simulator's camera as a :class:`~marknav.vision.sources.FrameSource`.

    Without a frame rate (``conditions.frame_rate_hz`` 0) each :meth:`read` takes a frame of the
    world at each read. With one, the camera takes frames at its own
    times ``t0 + k / frame_rate_hz`` (t0: when it was made), whatever the control rate: a read
    delivers the newest frame taken since the previous read, or the previous frame again (same
    index: nothing new) when none was. ``pose_at(t)`` (the true pose at a past time, from the
    simulator) places each frame at its capture time; without it the current pose is used.
    A frame taken is lost with probability ``dropped_frames``. During ``exposure_ms`` the robot's
    turn smears the image (``pose_at`` needed); the brightness swings by ``exposure_drift``.
    With ``latency_frames`` = L it delivers the frame taken L frames earlier (the first frame
    until L frames have been taken). ``seed`` fixes the noise and the drops. ``close`` is
    idempotent; a closed camera reads ``None``.

    Frames reach the reader ``delay_s`` after their capture (default: the world's
    ``camera_latency_s + processing_s``, continuous time): a read at ``now`` sees only the frames
    taken by ``now − delay_s``, each stamped with its capture time and rendered from
    ``pose_at(capture time)``, as a camera whose driver reports it would.
    """

    def __init__(
        self,
        world: World,
        palette: Sequence[ColourRange],
        *,
        pose_fn: Callable[[], Pose],
        clock: Clock,
        config: CameraConfig = CameraConfig(),
        seed: int = 0,
        latency_frames: int | None = None,
        name: str = "sim",
        pose_at: Callable[[float], Pose] | None = None,
        delay_s: float | None = None,
    ) -> None:
        latency = world.conditions.latency_frames if latency_frames is None else latency_frames
        if latency < 0:
            raise ValueError(f"latency_frames must be ≥ 0, got {latency}")
        cond = world.conditions
        delay = cond.camera_latency_s + cond.processing_s if delay_s is None else delay_s
        if not (math.isfinite(delay) and delay >= 0.0):
            raise ValueError(f"delay_s must be ≥ 0, got {delay}")
        self.name = name
        self.latency_frames = latency
        #: Capture to processing (s): what the tick processing a frame sees of its age.
        self.delay_s = float(delay)
        self.renderer = Renderer(world, palette, config)
        self._pose_fn = pose_fn
        self._pose_at = pose_at
        self._clock = clock
        self._rng = np.random.default_rng([int(seed), 0xCA3E7A])
        self._buffer: deque[Frame] = deque(maxlen=latency + 1)
        self._index = 0
        self._closed = False
        c = world.conditions
        self.conditions = c
        self._frames = FrameClock(c, t0=clock.now(), seed=seed)
        self._phase = exposure_phase(seed)

    @property
    def config(self) -> CameraConfig:
        return self.renderer.config

    @property
    def intrinsics(self) -> Intrinsics:
        """The simulated camera's exact intrinsics (as if calibrated)."""
        return self.renderer.intrinsics

    def range_law(self, mark_radius_mm: float) -> PowerLaw:
        """The simulated camera's own range law (:func:`marknav.sim.camera_model.sim_range_law`)."""
        a, b = sim_range_law(self.config.focal_px, mark_radius_mm)
        return PowerLaw(a=a, b=b)

    def read(self) -> Frame | None:
        if self._closed:
            return None
        now = self._clock.now() - self.delay_s  # the newest capture time delivered now
        t = self._frames.capture(now, have_frame=bool(self._buffer))
        if t is not None:
            self._take(t, self._clock.now())
        return self._buffer[0]

    @property
    def frames_dropped(self) -> int:
        """Frames lost so far (``dropped_frames``)."""
        return self._frames.frames_dropped

    def _take(self, t: float, now: float) -> None:
        """Render the frame captured at ``t`` and put it in the delivery buffer."""
        c = self.conditions
        pose_at = self._pose_at
        pose = pose_at(t) if pose_at is not None and t < now else self._pose_fn()
        motion = 0.0
        if c.exposure_ms > 0 and pose_at is not None:
            before = pose_at(t - c.exposure_ms / 1000.0)
            turned = math.remainder(pose.theta - before.theta, 2 * math.pi)
            motion = turned * self.config.focal_px
        gain = exposure_gain(c, t, self._phase)
        image = self.renderer.render(pose, self._rng, motion_px=motion, gain=gain)
        self._buffer.append(Frame(image=image, t=t, index=self._index))
        self._index += 1

    def close(self) -> None:
        self._closed = True
        self._buffer.clear()

    def __enter__(self) -> SimCamera:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
