"""Composited frames: marks painted into real photographs, with what rooms do to them.

Each frame is a 640×480 (or any size) view cut from a photograph, with marks painted like the
simulator paints them (fully saturated at the middle of their colour's hue range) but through the
conditions a room adds, each with a known truth (centre, semi-axes, range):

- **perspective**: a mark turned by a yaw is an ellipse (minor/major = cos yaw, the exact image of a
  small disc); its centre lies near the horizon row (marks at camera height, paper §3.1), within a
  pitch/roll tolerance;
- **shading**: a linear light gradient across the mark (0.65-1.1 of its colour), then the frame's
  blur and sensor noise;
- **thin occluders**: poles, wires and seams 2-8 px wide across the mark (through or near its
  centre), grey, dark or the photograph's own colours;
- **partial overlap**: another object (a grey or photo-coloured board) hiding part of the mark;
- **saturated floors**: a wood or carpet texture of saturation up to 160 behind the mark's lower
  part (the floor line between the mark's centre and its bottom);
- **near-colour boards**: a board of a neighbouring hue (orange beside red, teal beside green,
  violet beside blue) touching the mark behind half of it.

Painting is anti-aliased as in :mod:`marknav.sim.synthetic.scene` (4× supersampling, box
reduction), so
the painted centre and axes are the truth to a small fraction of a pixel. The range follows from
the pinhole model: ``range = f·R / a`` for a mark of radius ``R`` mm at focal length ``f`` px.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt

from marknav.sim.randomisation import bounds
from marknav.sim.synthetic.scene import (
    SUPERSAMPLE,
    Image,
    TruthMark,
    _bgr_of,
    _paint_ellipse,
    _poly,
    _rect,
    _uniform,
)
from marknav.vision.palette import ColourRange, Palette

__all__ = [
    "COMPOSITE_PALETTE",
    "CONDITIONS",
    "CompositeFrame",
    "CompositeSpec",
    "composite_frame",
    "composite_frames",
    "load_photos",
    "near_hue",
    "wood_texture",
]

FloatImage = npt.NDArray[np.float32]

#: Red, green and blue as :data:`~marknav.vision.palette.DEFAULT_PALETTE` has them: their
#: neighbours (orange, teal, violet) are then near colours, not palette colours.
COMPOSITE_PALETTE: Palette = (
    ColourRange("red", 170, 8),
    ColourRange("green", 40, 85),
    ColourRange("blue", 95, 130),
)
#: A mark is placed only where at most this share of the photograph around it (to 1.6 radii)
#: has the mark's own colour: a green disc on green foliage is not a mark any colour detector
#: can see. Near colours and saturated floors are what the conditions add on purpose.
MAX_OWN_COLOUR_SHARE = 0.03
#: The kinds of difficulty a composite frame can carry (one or more per frame).
CONDITIONS = ("plain", "occluder", "overlap", "floor", "board")


@dataclass(frozen=True)
class CompositeSpec:
    """What to composite. Ranges are (low, high), drawn uniformly; the defaults are the
    ``composite.*`` entries of :mod:`marknav.sim.randomisation`."""

    width: int = 640
    height: int = 480
    focal_px: float = 590.0
    mark_radius_mm: float = 100.0
    n_marks: int = 2
    radius: tuple[float, float] = bounds("composite.mark_radius")
    yaw_deg: tuple[float, float] = bounds("composite.mark_yaw")
    #: Mark centres lie within this many px of the horizon row (pitch, roll, uneven floors).
    horizon_tolerance_px: float = 12.0
    occluder_px: tuple[float, float] = bounds("composite.occluder_width")
    floor_saturation: tuple[float, float] = bounds("composite.floor_saturation")
    #: Share of the outline an overlapping object hides.
    overlap: tuple[float, float] = bounds("composite.overlap")
    blur_sigma: tuple[float, float] = bounds("composite.blur_sigma")
    noise_sigma: tuple[float, float] = bounds("composite.noise_sigma")
    gain: tuple[float, float] = bounds("composite.gain")
    mark_value: tuple[float, float] = bounds("composite.mark_value")


@dataclass(frozen=True)
class CompositeFrame:
    image: Image
    marks: tuple[TruthMark, ...]
    #: The pinhole range of each mark (mm), in ``marks`` order.
    ranges_mm: tuple[float, ...]
    conditions: tuple[str, ...]
    photo: str


def load_photos(folder: str | Path) -> list[tuple[str, Image]]:
    """The ``*.jpg``/``*.png`` photographs of ``folder``, sorted by name (BGR ``uint8``)."""
    out: list[tuple[str, Image]] = []
    for path in sorted(Path(folder).iterdir()):
        if path.suffix.lower() not in (".jpg", ".jpeg", ".png"):
            continue
        image = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if image is not None:
            out.append((path.name, np.asarray(image, np.uint8)))
    return out


def near_hue(colour: ColourRange) -> float:
    """A hue next to ``colour``'s range, outside it (OpenCV units): orange beside red, teal
    beside green, violet beside blue; the side away from the other palette colours is not
    chosen here, the nearer neighbour of the range's upper end is."""
    return float((colour.hue_hi + 6) % 180)


def wood_texture(rng: np.random.Generator, h: int, w: int, saturation: float,
                 kind: str = "wood") -> FloatImage:
    """A floor of ``kind`` ``wood`` (planks with grain, hue 10-22) or ``carpet`` (fine
    isotropic grain, any hue) at about ``saturation`` (0..255), BGR float32."""
    if kind == "wood":
        hue = float(rng.uniform(10.0, 22.0))
        grain = cv2.resize(rng.normal(0.0, 1.0, (max(2, h // 3), 8)).astype(np.float32), (w, h),
                           interpolation=cv2.INTER_CUBIC)
        planks = np.zeros((h, w), np.float32)
        plank_h = max(6, h // 6)
        for y in range(0, h, plank_h):
            planks[y:y + plank_h] = float(rng.uniform(-0.15, 0.15))
            planks[y:y + 1] = -0.35  # the joint
        value = 150.0 * (1.0 + 0.12 * grain + planks)
        sat = saturation * (1.0 + 0.08 * grain)
    else:
        hue = float(rng.uniform(0.0, 180.0))
        fine = cv2.GaussianBlur(rng.normal(0.0, 1.0, (h, w)).astype(np.float32), (0, 0), 0.8)
        value = 130.0 * (1.0 + 0.15 * fine)
        sat = saturation * (1.0 + 0.1 * fine)
    hsv = np.dstack([np.full((h, w), hue * 2.0, np.float32),
                     np.clip(sat / 255.0, 0, 1).astype(np.float32),
                     np.clip(value / 255.0, 0, 1).astype(np.float32)])
    return np.asarray(cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR) * 255.0, np.float32)


def _view(rng: np.random.Generator, photo: Image, w: int, h: int) -> FloatImage:
    """A w×h view of ``photo``: scaled to cover it, a random crop, maybe mirrored."""
    ph, pw = photo.shape[:2]
    s = max(w / pw, h / ph) * float(rng.uniform(1.0, 1.3))
    big = cv2.resize(photo, (max(w, round(pw * s)), max(h, round(ph * s))),
                     interpolation=cv2.INTER_AREA if s < 1 else cv2.INTER_LINEAR)
    y0 = int(rng.integers(0, big.shape[0] - h + 1))
    x0 = int(rng.integers(0, big.shape[1] - w + 1))
    view = big[y0:y0 + h, x0:x0 + w]
    if rng.random() < 0.5:
        view = view[:, ::-1]
    return np.asarray(view, np.float32)


def _own_colour_share(base: FloatImage, colour: ColourRange, x: float, y: float,
                      a: float) -> float:
    """Share of the photograph's pixels within 1.6 a of (x, y) that have the mark's own
    palette colour (its hue range, saturation and value floors)."""
    h, w = base.shape[:2]
    r = 1.6 * a
    x0, x1 = max(0, int(x - r)), min(w, int(x + r) + 1)
    y0, y1 = max(0, int(y - r)), min(h, int(y + r) + 1)
    patch = np.clip(base[y0:y1, x0:x1], 0, 255).astype(np.uint8)
    hsv = cv2.cvtColor(patch, cv2.COLOR_BGR2HSV)
    hue = hsv[:, :, 0].astype(np.float64)
    inside = (hue >= colour.hue_lo) & (hue <= colour.hue_hi) if not colour.wraps else \
        (hue >= colour.hue_lo) | (hue <= colour.hue_hi)
    own = inside & (hsv[:, :, 1] >= colour.sat_min) & (hsv[:, :, 2] >= colour.val_min)
    return float(np.count_nonzero(own)) / max(own.size, 1)


def composite_frame(rng: np.random.Generator, photos: Sequence[tuple[str, Image]],
                    conditions: Sequence[str], spec: CompositeSpec = CompositeSpec(),
                    palette: Palette = COMPOSITE_PALETTE) -> CompositeFrame:
    """One composited frame carrying ``conditions`` (names from :data:`CONDITIONS`)."""
    unknown = set(conditions) - set(CONDITIONS)
    if unknown:
        raise ValueError(f"unknown composite conditions: {sorted(unknown)}")
    w, h, s = spec.width, spec.height, SUPERSAMPLE
    name, photo = photos[int(rng.integers(len(photos)))]
    base = _view(rng, photo, w, h)
    canvas = np.asarray(cv2.resize(base, (w * s, h * s), interpolation=cv2.INTER_LINEAR),
                        np.float32)
    horizon = (h - 1) / 2.0
    marks: list[TruthMark] = []
    placed: list[tuple[float, float, float]] = []
    for _ in range(spec.n_marks):
        colour = palette[int(rng.integers(len(palette)))]
        for _ in range(200):
            a = _uniform(rng, spec.radius)
            b = a * math.cos(math.radians(_uniform(rng, spec.yaw_deg)))
            x = float(rng.uniform(a + 4, w - a - 5))
            y = horizon + float(rng.uniform(-spec.horizon_tolerance_px, spec.horizon_tolerance_px))
            if a + 4 < y < h - a - 5 and all(abs(x - px) > 2.2 * (a + pa) + 12
                                             for px, _, pa in placed) and \
                    _own_colour_share(base, colour, x, y, a) <= MAX_OWN_COLOUR_SHARE:
                break
        else:
            continue
        marks.append(TruthMark(colour.name, x, y, a, b, 0.0))
        placed.append((x, y, a))

    # Behind the marks: floors and near-colour boards.
    if "floor" in conditions:
        sat = _uniform(rng, spec.floor_saturation)
        kind = "wood" if rng.random() < 0.6 else "carpet"
        floor = wood_texture(rng, h * s, w * s, sat, kind)
        line = min(m.y + float(rng.uniform(0.1, 0.7)) * m.b for m in marks) if marks else horizon
        row = max(0, round((line + 0.5) * s - 0.5))
        canvas[row:] = floor[row:]
    if "board" in conditions:
        for m in marks:
            spec_colour = next(c for c in palette if c.name == m.colour)
            tone = _bgr_of(near_hue(spec_colour), float(rng.uniform(0.7, 1.0)),
                           _uniform(rng, spec.mark_value))
            side = 1.0 if rng.random() < 0.5 else -1.0
            # A board from the mark's centre line outwards, reaching past its outline.
            bw, bh = 2.6 * m.a, float(rng.uniform(2.2, 3.5)) * m.a
            _poly(canvas, _rect(m.x + side * bw / 2.0, m.y + float(rng.uniform(-0.4, 0.4)) * m.a,
                                bw, bh, 0.0), tone)

    for m in marks:
        spec_colour = next(c for c in palette if c.name == m.colour)
        val = _uniform(rng, spec.mark_value)
        _paint_shaded(canvas, m, _bgr_of(spec_colour.centre_hue, 1.0, val), rng)

    # In front of the marks: thin occluders and overlapping objects.
    if "occluder" in conditions:
        for m in marks:
            width = _uniform(rng, spec.occluder_px)
            ang = float(rng.uniform(-0.5, 0.5)) + (math.pi / 2 if rng.random() < 0.75 else 0.0)
            off = float(rng.uniform(-0.3, 0.3)) * m.b
            cx = m.x + off * math.cos(ang + math.pi / 2)
            cy = m.y + off * math.sin(ang + math.pi / 2)
            grey = float(rng.uniform(20.0, 200.0))
            tint = rng.uniform(0.85, 1.15, 3) * grey
            _poly(canvas, _rect(cx, cy, 3.0 * m.a + 40.0, width, ang),
                  tuple(float(v) for v in tint))
    if "overlap" in conditions:
        for m in marks:
            hidden = _uniform(rng, spec.overlap)
            phi = float(rng.uniform(0, 2 * math.pi))
            d = m.b * math.cos(math.pi * hidden)
            half = math.sqrt(max(m.a * m.a - d * d, 0.0))
            depth = m.a - d + 0.3 * m.a
            nx, ny = math.cos(phi), math.sin(phi)
            cx, cy = m.x + nx * (d + depth / 2), m.y + ny * (d + depth / 2)
            grey = float(rng.uniform(60.0, 200.0))
            _poly(canvas, _rect(cx, cy, depth, 2 * (half + 0.3 * m.a), phi),
                  tuple(float(v) for v in rng.uniform(0.8, 1.2, 3) * grey))

    img = np.asarray(cv2.resize(canvas, (w, h), interpolation=cv2.INTER_AREA), np.float32)
    img *= np.float32(_uniform(rng, spec.gain))
    sigma = _uniform(rng, spec.blur_sigma)
    if sigma > 0.05:
        img = np.asarray(cv2.GaussianBlur(img, (0, 0), sigma), np.float32)
    noise = _uniform(rng, spec.noise_sigma)
    if noise > 0:
        img += rng.normal(0.0, noise, img.shape).astype(np.float32)
    out = np.clip(np.rint(img), 0, 255).astype(np.uint8)
    ranges = tuple(spec.focal_px * spec.mark_radius_mm / m.a for m in marks)
    return CompositeFrame(out, tuple(marks), ranges, tuple(conditions), name)


def _paint_shaded(canvas: FloatImage, m: TruthMark, colour: tuple[float, float, float],
                  rng: np.random.Generator) -> None:
    """Paint a mark (exact coverage) with a linear light gradient across it."""
    s = SUPERSAMPLE
    hh, ww = canvas.shape[:2]
    x0, x1 = max(0, int((m.x - m.a) * s) - 4), min(ww, int((m.x + m.a) * s) + 8)
    y0, y1 = max(0, int((m.y - m.a) * s) - 4), min(hh, int((m.y + m.a) * s) + 8)
    if x1 <= x0 or y1 <= y0:
        return
    layer = np.zeros((y1 - y0, x1 - x0, 1), np.float32)
    local = TruthMark(m.colour, m.x - x0 / s, m.y - y0 / s, m.a, m.b, m.angle_deg)
    _paint_ellipse(layer, local, (1.0,))
    cover = layer
    ang = float(rng.uniform(0, 2 * math.pi))
    lo, hi = float(rng.uniform(0.65, 0.85)), float(rng.uniform(0.95, 1.1))
    yy, xx = np.mgrid[y0:y1, x0:x1].astype(np.float32)
    t = ((xx / s - m.x) * math.cos(ang) + (yy / s - m.y) * math.sin(ang)) / max(m.a, 1.0)
    light = (lo + (hi - lo) * np.clip((t + 1.0) / 2.0, 0, 1))[:, :, None]
    paint = np.minimum(np.asarray(colour, np.float32)[None, None, :] * light, 255.0)
    region = canvas[y0:y1, x0:x1]
    region[:] = np.where(cover > 0, paint, region)


def composite_frames(photos: Sequence[tuple[str, Image]], *, per_condition: int = 8,
                     seed: int = 10, spec: CompositeSpec = CompositeSpec(),
                     palette: Palette = COMPOSITE_PALETTE) -> list[CompositeFrame]:
    """A fixed set: ``per_condition`` frames of each single condition, and as many carrying
    occluder + floor + board together. Same photos and seed → same frames."""
    rng = np.random.default_rng([seed, 0xC0A1])
    sets: list[tuple[str, ...]] = [(c,) for c in CONDITIONS]
    sets.append(("occluder", "floor", "board"))
    frames: list[CompositeFrame] = []
    for conditions in sets:
        for _ in range(per_condition):
            frames.append(composite_frame(rng, photos, conditions, spec, palette))
    return frames
