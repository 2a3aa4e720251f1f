"""Harder rooms for the simulated camera: what real rooms put around the marks.

The renderer's background panorama (:mod:`marknav.sim.builtin_camera`) is a plain, low-saturation
room.
The world's :class:`~marknav.sim.world.Conditions` can ask for more (all drawn deterministically
from the background's seed):

- ``floor``: ``wood`` (planks with grain, hue 10-22) or ``carpet`` (fine grain, any hue) at
  ``floor_saturation`` (up to 160 in randomised worlds; a mark's detector mask starts at 100);
- ``wall``: ``photo`` — the far wall is a real photograph (shipped in ``marknav/sim/photos/``, see
  its README), tiled round the room;
- ``wall_hue``: one colour dominates the scene: the wall is tinted with this hue at saturation
  60-120 (a green room, an orange one);
- the room's own colours stay off the palette's hues (within ``PALETTE_MARGIN``): a tint inside
  a mark colour's range moves just past its end, and a photograph's pixels of a mark colour
  (a blue sky behind a blue mark) are desaturated to ``PHOTO_PALETTE_SAT``. A mark of the
  room's own colour is a patch of one colour region, which no colour detector (nor a course
  designer choosing mark colours) can tell apart; near colours stay (distractors, the tint
  beside a range), so hue discrimination is still tested;
- ``distractors``: round objects of near-mark colours on the horizon, off the course (orange
  beside red, teal beside green, violet beside blue: hues 8-10 beyond a palette range), 0.5-3°
  across;
- ``occluders``: thin poles in front of everything (table legs, cables, door frames), 2-8 px wide
  at the default camera (scaled with the focal length), at fixed azimuths. They are drawn at
  infinity (no parallax against the marks) and after the blur: an image condition, not geometry.

:func:`random_room` draws them for ``marknav evaluate``'s randomised worlds.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from marknav.sim.randomisation import bounds, counts

__all__ = [
    "NEAR_HUE_OFFSET",
    "PHOTOS",
    "Pole",
    "draw_poles",
    "off_palette_hue",
    "paint_distractors",
    "paint_room",
    "poles",
    "random_room",
]

FloatImage = npt.NDArray[np.float32]
Image = npt.NDArray[np.uint8]

#: The photographs the ``photo`` wall is made of.
PHOTOS = Path(__file__).resolve().parent / "photos"
# The drawn ranges are entries of the one table, marknav.sim.randomisation (``room.*``).
#: A near-mark colour lies this many hue units beyond the end of a palette range.
NEAR_HUE_OFFSET = bounds("room.near_hue_offset")
#: Widths of the poles at f = 590 px.
POLE_WIDTH_PX = bounds("room.pole_width")
#: Ranges :func:`random_room` draws from.
FLOOR_SATURATION_RANGE = bounds("room.floor_saturation")
WALL_TINT_SATURATION = bounds("room.wall_tint_saturation")
#: Hue units around each palette range that walls and photographs keep clear of.
PALETTE_MARGIN = 4.0
#: Saturation a photograph's palette-coloured pixels are brought down to (below the
#: detector's mask floor of 100, with room for the colour casts' gains).
PHOTO_PALETTE_SAT = 50.0


@functools.lru_cache(maxsize=1)
def _photos() -> tuple[Image, ...]:
    out = []
    for path in sorted(PHOTOS.glob("*.jpg")):
        image = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if image is not None:
            out.append(np.asarray(image, np.uint8))
    return tuple(out)


def _hsv_image(hue: npt.NDArray[np.float32], sat: npt.NDArray[np.float32],
               val: npt.NDArray[np.float32]) -> FloatImage:
    hsv = np.dstack([hue * 2.0, np.clip(sat / 255.0, 0, 1), np.clip(val / 255.0, 0, 1)])
    return np.asarray(cv2.cvtColor(hsv.astype(np.float32), cv2.COLOR_HSV2BGR) * 255.0,
                      np.float32)


def _floor(rng: np.random.Generator, h: int, w: int, kind: str, saturation: float) -> FloatImage:
    if kind == "wood":
        hue = float(rng.uniform(10.0, 22.0))
        grain = cv2.resize(rng.normal(0.0, 1.0, (max(2, h // 2), max(8, w // 64)))
                           .astype(np.float32), (w, h), interpolation=cv2.INTER_CUBIC)
        planks = np.zeros((h, w), np.float32)
        rows = np.arange(h)
        # Planks get narrower towards the horizon (perspective): equal steps in 1/row.
        depth = 1.0 / np.maximum(rows + 1.0, 1.0)
        plank = np.floor(depth * 4000.0 / max(h, 1)).astype(np.int64)
        levels = rng.uniform(-0.15, 0.15, int(plank.max()) + 2).astype(np.float32)
        planks[:] = levels[plank][:, None]
        val = 150.0 * (1.0 + 0.12 * grain + planks)
        sat = saturation * (1.0 + 0.08 * grain)
    else:
        hue = float(rng.uniform(0.0, 180.0))
        fine = cv2.GaussianBlur(rng.normal(0.0, 1.0, (h, w)).astype(np.float32), (0, 0), 0.8)
        val = 125.0 * (1.0 + 0.15 * fine)
        sat = saturation * (1.0 + 0.1 * fine)
    return _hsv_image(np.full((h, w), hue, np.float32), sat.astype(np.float32),
                      val.astype(np.float32))


def _photo_wall(rng: np.random.Generator, rows: int, cols: int) -> FloatImage | None:
    photos = _photos()
    if not photos or rows < 2:
        return None
    tiles: list[Image] = []
    width = 0
    while width < cols:
        photo = photos[int(rng.integers(len(photos)))]
        ph, pw = photo.shape[:2]
        s = rows / ph
        tile = cv2.resize(photo, (max(1, round(pw * s)), rows), interpolation=cv2.INTER_AREA)
        if rng.random() < 0.5:
            tile = tile[:, ::-1]
        tiles.append(np.asarray(tile, np.uint8))
        width += tile.shape[1]
    return np.asarray(np.hstack(tiles)[:, :cols], np.float32)


def room_photo(index: int, palette_ranges: Sequence[tuple[int, int]]) -> Image:
    """Photograph ``index`` (modulo their number) of the room photographs shipped in
    ``photos/``, its palette-coloured pixels desaturated as the built-in renderer's walls are
    (a texture for another engine)."""
    photos = _photos()
    if not photos:
        raise FileNotFoundError(f"no room photographs in {PHOTOS}")
    image = photos[index % len(photos)].astype(np.float32)
    _desaturate_palette(image, palette_ranges)
    return np.asarray(np.clip(image, 0, 255), dtype=np.uint8)


def _in_ranges(hue: float, ranges: Sequence[tuple[int, int]], margin: float) -> bool:
    for lo, hi in ranges:
        span = (hi - lo) % 180
        if (hue - (lo - margin)) % 180.0 <= span + 2.0 * margin:
            return True
    return False


def off_palette_hue(hue: float, ranges: Sequence[tuple[int, int]],
                    margin: float = PALETTE_MARGIN) -> float:
    """``hue``, or the nearest hue (0.5 steps) outside every palette range grown by
    ``margin``."""
    for step in range(361):
        for h in ((hue + 0.5 * step) % 180.0, (hue - 0.5 * step) % 180.0):
            if not _in_ranges(h, ranges, margin):
                return h
    return hue  # the palette covers every hue


def _desaturate_palette(wall: FloatImage, ranges: Sequence[tuple[int, int]]) -> None:
    """Bring the wall's pixels of palette hues down to ``PHOTO_PALETTE_SAT``, in place."""
    hsv = cv2.cvtColor(np.clip(wall, 0, 255).astype(np.uint8), cv2.COLOR_BGR2HSV)
    hue = hsv[:, :, 0].astype(np.float32)
    inside = np.zeros(hue.shape, bool)
    for lo, hi in ranges:
        span = (hi - lo) % 180
        inside |= (hue - (lo - PALETTE_MARGIN)) % 180.0 <= span + 2.0 * PALETTE_MARGIN
    inside &= hsv[:, :, 1] > PHOTO_PALETTE_SAT
    if not inside.any():
        return
    hsv[:, :, 1][inside] = int(PHOTO_PALETTE_SAT)
    wall[inside] = cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)[inside]


def paint_room(pan: FloatImage, base_row: int, seed: int, conditions: Any,
               palette_ranges: Sequence[tuple[int, int]] = ()) -> None:
    """Paint the floor, the wall and the wall's tint that ``conditions`` ask for into the
    panorama (float BGR, before the light's gains), in place; the wall's photograph and tint
    keep off ``palette_ranges`` (hue ranges, OpenCV units, inclusive, may wrap)."""
    rng = np.random.default_rng([seed, 0x200A])
    h, wp = pan.shape[:2]
    if conditions.wall == "photo":
        wall = _photo_wall(rng, base_row, wp)
        if wall is not None:
            _desaturate_palette(wall, palette_ranges)
            pan[:base_row] = wall
    if conditions.wall_hue is not None:
        sat = float(rng.uniform(*WALL_TINT_SATURATION))
        grey = pan[:base_row].mean(axis=2)
        hue = off_palette_hue(float(conditions.wall_hue), palette_ranges)
        tint = _hsv_image(np.full(grey.shape, hue, np.float32),
                          np.full(grey.shape, sat, np.float32), np.clip(grey * 1.1, 0, 255))
        pan[:base_row] = tint
    if conditions.floor != "plain" and base_row < h:
        pan[base_row:] = _floor(rng, h - base_row, wp, conditions.floor,
                                float(conditions.floor_saturation))


def near_hues(palette_ranges: Sequence[tuple[int, int]]) -> list[float]:
    """Hues just outside each palette range (both sides), not inside any range."""
    def inside(h: float) -> bool:
        for lo, hi in palette_ranges:
            if (lo <= hi and lo - 3 <= h <= hi + 3) or \
                    (lo > hi and (h >= lo - 3 or h <= hi + 3)):
                return True
        return False
    out = []
    for lo, hi in palette_ranges:
        for h in ((hi + NEAR_HUE_OFFSET[1]) % 180.0, (lo - NEAR_HUE_OFFSET[1]) % 180.0):
            if not inside(h):
                out.append(h)
    return out


def paint_distractors(pan: Image, seed: int, count: int, hues: Sequence[float],
                      focal_px: float, cy: float, gains: npt.NDArray[np.float64]) -> None:
    """Round objects of near-mark colours on the horizon, at random azimuths (8-bit panorama,
    anti-aliased), in place."""
    if count <= 0 or not hues:
        return
    rng = np.random.default_rng([seed, 0xD157])
    wp = pan.shape[1]
    shift = 4
    for _ in range(count):
        col = float(rng.uniform(0, wp))
        radius = focal_px * math.tan(math.radians(float(rng.uniform(0.25, 1.5))))
        row = cy + focal_px * math.tan(math.radians(float(rng.uniform(-1.0, 1.0))))
        hue = float(hues[int(rng.integers(len(hues)))])
        bgr = _hsv_image(np.full((1, 1), hue, np.float32), np.full((1, 1), 230.0, np.float32),
                         np.full((1, 1), float(rng.uniform(140, 220)), np.float32))[0, 0]
        colour = tuple(float(v) for v in np.minimum(bgr * gains, 255.0))
        for dx in (-wp, 0, wp):
            cv2.circle(pan, (round((col + dx) * (1 << shift)), round(row * (1 << shift))),
                       round(radius * (1 << shift)), colour, cv2.FILLED, cv2.LINE_AA, shift)


@dataclass(frozen=True)
class Pole:
    """A thin vertical occluder: panorama column (at f px per radian), width px, BGR."""

    column: float
    width: float
    bgr: tuple[float, float, float]


def poles(seed: int, count: int, wp: int, focal_px: float) -> tuple[Pole, ...]:
    """The world's poles (deterministic for its background seed)."""
    rng = np.random.default_rng([seed, 0x90E5])
    out = []
    for _ in range(count):
        width = float(rng.uniform(*POLE_WIDTH_PX)) * focal_px / 590.0
        grey = float(rng.uniform(30.0, 200.0))
        tint = rng.uniform(0.85, 1.15, 3) * grey
        out.append(Pole(float(rng.uniform(0, wp)), max(1.0, width),
                        (float(tint[0]), float(tint[1]), float(tint[2]))))
    return tuple(out)


def draw_poles(img: Image, items: Sequence[Pole], c0: int, wp: int) -> None:
    """Draw the poles over a frame whose column 0 is panorama column ``c0``, in place."""
    h, w = img.shape[:2]
    shift = 8
    one = 1 << shift
    for pole in items:
        u = (pole.column - c0) % wp
        if u > w + pole.width:
            u -= wp
        if u + pole.width < 0 or u - pole.width > w:
            continue
        half = pole.width / 2.0
        pts = np.array([[u - half, -1.0], [u + half, -1.0], [u + half, h + 1.0],
                        [u - half, h + 1.0]])
        cv2.fillPoly(img, [np.round(pts * one).astype(np.int32)], pole.bgr, cv2.LINE_AA,
                     shift)


def random_room(seed: int) -> dict[str, Any]:
    """The room conditions of a randomised world (a :class:`Conditions` update), drawn from
    the world's seed on their own stream (the course and the other conditions are unchanged)."""
    rng = np.random.default_rng([int(seed), 0x2A2D])
    occluders, distractors = counts("room.occluders"), counts("room.distractors")
    floor = ("plain", "wood", "carpet")[int(rng.integers(3))]
    return {
        "floor": floor,
        "floor_saturation": round(float(rng.uniform(*FLOOR_SATURATION_RANGE)), 1),
        "wall": "photo" if rng.random() < 0.4 else "plain",
        "wall_hue": round(float(rng.uniform(0, 180)), 1) if rng.random() < 0.2 else None,
        "occluders": int(rng.integers(occluders[0], occluders[1] + 1)),
        "distractors": int(rng.integers(distractors[0], distractors[1] + 1)),
    }
