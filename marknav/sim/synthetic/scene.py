"""Synthetic scenes: the frames the detector's tests and the vision benchmark run on.

Scenes are rendered anti-aliased: the marks are painted at 4× resolution by testing each
high-resolution pixel centre against the ellipse equation, clutter and occluders are filled
polygons at 4×, and the image is reduced with ``INTER_AREA`` (box average), so a mark's edge
pixels carry its exact coverage and sub-pixel truth is meaningful. Light is applied afterwards:
a gain, a per-channel colour cast, a Gaussian blur (optics), Gaussian noise (sensor), clipping.

Marks are painted like the simulator does (design brief, *Mission file*): fully saturated at the
middle of their colour's hue range (:attr:`ColourRange.centre_hue`), on a textured grey background
with non-circular clutter (rectangles, stripes, triangles) of similar colours.

"""

from __future__ import annotations

import colorsys
import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from marknav.sim.randomisation import bounds
from marknav.vision.palette import DEFAULT_PALETTE, ColourRange, Palette

__all__ = [
    "BENCH_SPEC",
    "Scene",
    "SceneSpec",
    "TruthMark",
    "bench_frames",
    "render_scene",
]

SUPERSAMPLE = 4
Image = npt.NDArray[np.uint8]


@dataclass(frozen=True)
class TruthMark:
    """A painted mark: centre (px, pixel centres at integers), semi-axes a >= b, angle of a."""

    colour: str
    x: float
    y: float
    a: float
    b: float
    angle_deg: float
    #: Share of the outline hidden by an occluder (0 when none).
    occluded: float = 0.0
    #: Whether part of the mark lies outside the image.
    cut: bool = False

    @property
    def radius(self) -> float:
        return self.a


@dataclass(frozen=True)
class Scene:
    image: Image
    marks: tuple[TruthMark, ...]


@dataclass(frozen=True)
class SceneSpec:
    """What to paint. Ranges are (low, high), drawn uniformly; the defaults' drawn ranges are the
    ``synthetic.*`` entries of :mod:`marknav.sim.randomisation`."""

    width: int = 640
    height: int = 480
    n_marks: int = 3
    radius: tuple[float, float] = bounds("synthetic.mark_radius")
    #: Share of marks drawn as ellipses, and their minor/major ratio range.
    ellipse_share: float = 0.0
    axis_ratio: tuple[float, float] = bounds("synthetic.axis_ratio")
    n_clutter: int = 6
    #: Share of marks partly hidden by a grey occluder, and the hidden share of the outline.
    occluded_share: float = 0.0
    occlusion: tuple[float, float] = bounds("synthetic.occlusion")
    #: Share of marks placed across the image edge.
    cut_share: float = 0.0
    #: Pairs of touching marks of different colours (counted in ``n_marks``).
    touching_pairs: int = 0
    gain: tuple[float, float] = (1.0, 1.0)
    #: Largest per-channel cast factor deviation (warm: R up, B down; cool: the reverse).
    cast: float = 0.0
    blur_sigma: tuple[float, float] = (0.0, 0.0)
    noise_sigma: tuple[float, float] = bounds("synthetic.noise_sigma")
    #: Value (0..255) of the painted marks before the gain.
    mark_value: tuple[float, float] = bounds("synthetic.mark_value")
    background: tuple[float, float] = bounds("synthetic.background")


def _bgr_of(hue_cv: float, sat: float, val: float) -> tuple[float, float, float]:
    """BGR (0..255 floats) of an OpenCV hue (0..180), saturation and value in 0..1 / 0..255."""
    r, g, b = colorsys.hsv_to_rgb((hue_cv * 2.0 % 360.0) / 360.0, sat, val / 255.0)
    return b * 255.0, g * 255.0, r * 255.0


def _texture(rng: np.random.Generator, h: int, w: int, level: float) -> npt.NDArray[np.float32]:
    """A grey, slightly tinted floor: smooth blotches plus fine grain."""
    coarse = np.asarray(cv2.resize(
        rng.normal(0.0, 1.0, (max(2, h // 40), max(2, w // 40), 3)).astype(np.float32), (w, h),
        interpolation=cv2.INTER_CUBIC), np.float32)
    luminance = coarse.mean(axis=2, keepdims=True)
    tint = coarse - luminance
    fine = cv2.GaussianBlur(rng.normal(0.0, 1.0, (h, w)).astype(np.float32), (0, 0), 1.0)
    img = level * (1.0 + 0.12 * luminance + 0.03 * tint) + 6.0 * fine[:, :, None]
    return np.clip(img, 0, 255).astype(np.float32)


def _paint_ellipse(canvas: npt.NDArray[np.float32], m: TruthMark, colour: Sequence[float]) -> None:
    """Paint a mark at SUPERSAMPLE× resolution by the pixel-centre test (exact coverage)."""
    s = SUPERSAMPLE
    cx, cy = (m.x + 0.5) * s - 0.5, (m.y + 0.5) * s - 0.5
    a, b = m.a * s, m.b * s
    hh, ww = canvas.shape[:2]
    x0, x1 = max(0, int(cx - a) - 2), min(ww, int(cx + a) + 3)
    y0, y1 = max(0, int(cy - a) - 2), min(hh, int(cy + a) + 3)
    if x1 <= x0 or y1 <= y0:
        return
    yy, xx = np.mgrid[y0:y1, x0:x1].astype(np.float32)
    t = math.radians(m.angle_deg)
    c, sn = math.cos(t), math.sin(t)
    dx, dy = xx - cx, yy - cy
    u = (dx * c + dy * sn) / a
    v = (-dx * sn + dy * c) / b
    inside = (u * u + v * v) <= 1.0
    canvas[y0:y1, x0:x1][inside] = np.asarray(colour, np.float32)


def _poly(canvas: npt.NDArray[np.float32], pts: npt.NDArray[np.float64],
          colour: Sequence[float]) -> None:
    s = SUPERSAMPLE
    hi = np.rint(((pts + 0.5) * s - 0.5) * 16).astype(np.int32).reshape(-1, 1, 2)
    cv2.fillPoly(canvas, [hi], tuple(float(v) for v in colour), cv2.LINE_8, 4)


def _rect(cx: float, cy: float, w: float, h: float, angle: float) -> npt.NDArray[np.float64]:
    c, s = math.cos(angle), math.sin(angle)
    corners = np.array([[-w / 2, -h / 2], [w / 2, -h / 2], [w / 2, h / 2], [-w / 2, h / 2]])
    rot = np.array([[c, -s], [s, c]])
    out: npt.NDArray[np.float64] = corners @ rot.T + np.array([cx, cy])
    return out


def _uniform(rng: np.random.Generator, r: tuple[float, float]) -> float:
    return float(rng.uniform(r[0], r[1])) if r[1] > r[0] else float(r[0])


def render_scene(rng: np.random.Generator, spec: SceneSpec = SceneSpec(),
                 palette: Palette = DEFAULT_PALETTE) -> Scene:
    """One synthetic frame with its truth. Marks do not overlap each other (touching pairs
    aside) nor the clutter; occluders hide only their own mark."""
    w, h, s = spec.width, spec.height, SUPERSAMPLE
    level = _uniform(rng, spec.background)
    back = _texture(rng, h, w, level)
    canvas = np.asarray(cv2.resize(back, (w * s, h * s), interpolation=cv2.INTER_LINEAR),
                        np.float32)
    marks: list[TruthMark] = []
    occupied: list[tuple[float, float, float]] = []

    def free(x: float, y: float, r: float, gap: float = 6.0) -> bool:
        return all(math.hypot(x - ox, y - oy) > r + orad + gap for ox, oy, orad in occupied)

    def new_mark(colour: ColourRange, *, cut: bool, r_max: float | None = None) -> TruthMark:
        hi = spec.radius[1] if r_max is None else min(r_max, spec.radius[1])
        a = _uniform(rng, (spec.radius[0], max(spec.radius[0], hi)))
        b = a
        angle = 0.0
        if rng.random() < spec.ellipse_share:
            b = a * _uniform(rng, spec.axis_ratio)
            angle = float(rng.uniform(0, 180))
        if cut:
            side = int(rng.integers(4))  # left, right, top, bottom
            depth = float(rng.uniform(0.35, 0.75)) * b  # centre this far inside the edge
            if side < 2:
                along = float(rng.uniform(a + 2, h - a - 2))
                x, y = (depth, along) if side == 0 else (w - 1 - depth, along)
            else:
                along = float(rng.uniform(a + 2, w - a - 2))
                x, y = (along, depth) if side == 2 else (along, h - 1 - depth)
        else:
            x = float(rng.uniform(a + 3, w - a - 4))
            y = float(rng.uniform(a + 3, h - a - 4))
        return TruthMark(colour.name, x, y, a, b, angle, 0.0, cut)

    n_single = spec.n_marks - 2 * spec.touching_pairs
    for i in range(max(0, n_single)):
        colour = palette[int(rng.integers(len(palette)))]
        cut = rng.random() < spec.cut_share
        for _ in range(200):
            m = new_mark(colour, cut=cut)
            if free(m.x, m.y, m.a, 10.0):
                break
        else:
            continue
        occluded = 0.0
        if not cut and rng.random() < spec.occluded_share:
            occluded = _uniform(rng, spec.occlusion)
        marks.append(TruthMark(m.colour, m.x, m.y, m.a, m.b, m.angle_deg, occluded, m.cut))
        occupied.append((m.x, m.y, m.a * (1.9 if occluded else 1.0)))
        del i
    for _ in range(spec.touching_pairs):
        k1, k2 = rng.choice(len(palette), 2, replace=False)
        for _ in range(200):
            r1 = _uniform(rng, spec.radius)
            r2 = _uniform(rng, spec.radius)
            x1 = float(rng.uniform(r1 + 3, w - r1 - 4))
            y1 = float(rng.uniform(r1 + 3, h - r1 - 4))
            ang = float(rng.uniform(0, 2 * math.pi))
            dist = (r1 + r2) * float(rng.uniform(0.95, 1.0))
            x2, y2 = x1 + dist * math.cos(ang), y1 + dist * math.sin(ang)
            if not (r2 + 3 < x2 < w - r2 - 4 and r2 + 3 < y2 < h - r2 - 4):
                continue
            if free(x1, y1, r1, 10.0) and free(x2, y2, r2, 10.0):
                break
        else:
            continue
        marks.append(TruthMark(palette[int(k1)].name, x1, y1, r1, r1, 0.0))
        marks.append(TruthMark(palette[int(k2)].name, x2, y2, r2, r2, 0.0))
        occupied.extend([(x1, y1, r1), (x2, y2, r2)])

    # Clutter first (under the marks), never touching a mark.
    hues = [c.centre_hue for c in palette]
    for _ in range(spec.n_clutter):
        kind = int(rng.integers(3))
        hue = float(hues[int(rng.integers(len(hues)))] + rng.uniform(-3, 3)) % 180.0
        sat = float(rng.uniform(0.15, 1.0)) if rng.random() < 0.3 else 1.0
        tone = _bgr_of(hue, sat, _uniform(rng, spec.mark_value))
        for _ in range(100):
            cx, cy = float(rng.uniform(0, w)), float(rng.uniform(0, h))
            ang = float(rng.uniform(0, math.pi))
            if kind == 0:  # rectangle, clearly not round
                rw = float(rng.uniform(24, 120))
                rh = rw * float(rng.uniform(0.2, 0.65))
                pts = _rect(cx, cy, rw, rh, ang)
            elif kind == 1:  # stripe
                pts = _rect(cx, cy, float(rng.uniform(60, 300)), float(rng.uniform(4, 14)), ang)
            else:  # triangle
                size = float(rng.uniform(20, 90))
                tri = [ang + k * 2 * math.pi / 3 + float(rng.uniform(-0.3, 0.3)) for k in range(3)]
                pts = np.array([[cx + size * math.cos(t), cy + size * math.sin(t)] for t in tri])
            span = float(np.max(np.hypot(pts[:, 0] - cx, pts[:, 1] - cy)))
            if free(cx, cy, span, 8.0):
                _poly(canvas, pts, tone)
                break

    for m in marks:
        spec_colour = next(c for c in palette if c.name == m.colour)
        _paint_ellipse(canvas, m, _bgr_of(spec_colour.centre_hue, 1.0,
                                          _uniform(rng, spec.mark_value)))
    for m in marks:
        if m.occluded <= 0:
            continue
        # A grey board whose straight edge is a chord hiding ``occluded`` of the outline; it
        # reaches no further than 1.84 a from the centre (marks keep 1.9 a free).
        phi = float(rng.uniform(0, 2 * math.pi))
        d = m.b * math.cos(math.pi * m.occluded)
        half_chord = math.sqrt(max(m.a * m.a - d * d, 0.0))
        depth = m.a - d + 0.3 * m.a
        nx, ny = math.cos(phi), math.sin(phi)
        cx, cy = m.x + nx * (d + depth / 2), m.y + ny * (d + depth / 2)
        pts = _rect(cx, cy, depth, 2 * (half_chord + 0.3 * m.a), phi)
        grey = level * float(rng.uniform(0.6, 1.4))
        _poly(canvas, pts, (grey, grey, grey))

    img = np.asarray(cv2.resize(canvas, (w, h), interpolation=cv2.INTER_AREA), np.float32)
    gain = _uniform(rng, spec.gain)
    if spec.cast > 0:
        k = float(rng.uniform(0.5, 1.0)) * spec.cast * (1 if rng.random() < 0.5 else -1)
        cast = np.array([1.0 - k, 1.0, 1.0 + k], np.float32)  # B, G, R: warm when k > 0
    else:
        cast = np.ones(3, np.float32)
    img = img * (np.float32(gain) * cast)
    sigma = _uniform(rng, spec.blur_sigma)
    if sigma > 0.05:
        img = np.asarray(cv2.GaussianBlur(img, (0, 0), sigma), np.float32)
    noise = _uniform(rng, spec.noise_sigma)
    if noise > 0:
        img = img + rng.normal(0.0, noise, img.shape).astype(np.float32)
    out = np.clip(np.rint(img), 0, 255).astype(np.uint8)
    return Scene(out, tuple(marks))


# ---------------------------------------------------------------------- fixed frames

BENCH_SPEC = SceneSpec(
    width=640, height=480, n_marks=3, radius=bounds("bench.mark_radius"), ellipse_share=0.25,
    n_clutter=6, gain=bounds("bench.gain"), cast=0.15, blur_sigma=bounds("bench.blur_sigma"),
    noise_sigma=bounds("bench.noise_sigma"),
)


def bench_frames(n: int = 60, seed: int = 2024) -> list[Scene]:
    """The benchmark's fixed frames: 640×480, 3 marks + 6 clutter shapes each."""
    rng = np.random.default_rng(seed)
    return [render_scene(rng, BENCH_SPEC) for _ in range(n)]
