"""Each stage's output as a picture, drawn from the code (the docs' detector page shows them).

:func:`stage_pictures` runs the pipeline on a small drawn scene — a dim room lit by a warm lamp,
a red mark standing on a red carpet, a pale green mark, a blue mark behind a thin pole, a
yellow bar and a blurred orange blob — and returns one PNG per stage: the search image after
photometry, the colour masks, the blobs (those with a mark's shape outlined), and the marks.
"""

from __future__ import annotations

import cv2
import numpy as np

from marknav.vision.detect.pipeline import DetectorConfig, run_stages
from marknav.vision.detect.scene import SEARCH_SCALE, Mat, Scene, U8Array
from marknav.vision.palette import DEFAULT_PALETTE, ColourRange

__all__ = ["demo_scene", "stage_pictures"]

#: The drawn scene's size (px): the robot camera's.
_W, _H = 640, 480
#: The lamp's colour (B, G, R gains) and the room's exposure (a share of full scale).
_WARM = np.array([0.75, 1.0, 1.25])
_DIM = 0.3
#: Where the blurred blob shows (sum of its B, G, R levels).
_BLOB_EDGE = 30.0


def _paint(colour: ColourRange, saturation: float = 1.0) -> tuple[float, float, float]:
    hsv = np.array([[[2.0 * colour.centre_hue, saturation, 1.0]]], np.float32)
    b, g, r = (cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)[0, 0] * 230.0).tolist()
    return b, g, r


def demo_scene() -> U8Array:
    """The drawn scene (see the module docstring), as the camera would deliver it."""
    by = {c.name: c for c in DEFAULT_PALETTE}
    img = np.full((_H, _W, 3), (170.0, 175.0, 180.0), np.float32)  # a grey wall
    img[300:] = (60.0, 70.0, 150.0)                                  # a red carpet
    cv2.circle(img, (120, 262), 40, _paint(by["red"]), -1, cv2.LINE_AA)  # on the carpet
    cv2.circle(img, (300, 240), 34, _paint(by["green"], 0.5), -1, cv2.LINE_AA)  # pale paint
    cv2.circle(img, (470, 240), 36, _paint(by["blue"]), -1, cv2.LINE_AA)
    cv2.rectangle(img, (466, 120), (473, 299), (90.0, 90.0, 90.0), -1)  # a pole before it
    cv2.rectangle(img, (560, 200), (620, 222), _paint(by["yellow"]), -1)  # a bar
    sharp = np.zeros_like(img)
    cv2.circle(sharp, (390, 110), 22, _paint(by["orange"]), -1)
    blob: Mat = cv2.GaussianBlur(sharp, (0, 0), 9.0)  # out of focus, faint
    shown: Mat = np.where(blob.sum(axis=2, keepdims=True) > _BLOB_EDGE,
                          0.6 * img + 0.4 * blob, img)
    lit = shown * _WARM * _DIM
    rng = np.random.default_rng(0)
    noisy = lit + rng.normal(0.0, 1.5, lit.shape)
    out: U8Array = np.clip(noisy, 0, 255).astype(np.uint8)
    return out


def _png(image: Mat) -> bytes:
    ok, data = cv2.imencode(".png", image)
    if not ok:
        raise RuntimeError("PNG encoding failed")
    return bytes(data.tobytes())


def _masks_picture(scene: Scene) -> U8Array:
    assert scene.small is not None
    out: U8Array = np.zeros_like(scene.small)
    for colour, mask in zip(scene.palette, scene.masks, strict=True):
        hsv = np.array([[[colour.centre_hue, 255, 255]]], np.uint8)
        out[mask > 0] = cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)[0, 0]
    return out


def _blobs_picture(scene: Scene) -> U8Array:
    assert scene.small is not None
    out: U8Array = (scene.small // 3).astype(np.uint8)
    for blob in scene.blobs:
        shaped = blob.ellipse is not None
        cv2.drawContours(out, [blob.contour], -1, (255, 255, 255) if shaped else (0, 0, 200),
                         1)
    return out


def _marks_picture(image: U8Array, scene: Scene) -> U8Array:
    out: U8Array = image.copy()
    for m in scene.marks:
        cv2.ellipse(out, ((m.x, m.y), (2 * m.axes[0], 2 * m.axes[1]), m.angle_deg),
                    (255, 255, 255), 2)
        cv2.putText(out, m.colour, (int(m.x - m.axes[0]), int(m.y - m.axes[1] - 6)),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.6, (255, 255, 255), 1, cv2.LINE_AA)
    return out


def stage_pictures() -> dict[str, bytes]:
    """PNG per stage: ``frame``, ``photometry``, ``classify``, ``segment``, ``marks``."""
    image = demo_scene()
    config = DetectorConfig()
    palette = DEFAULT_PALETTE
    seen = run_stages(image, palette, config, until="photometry")
    masks = run_stages(image, palette, config, until="classify")
    blobs = run_stages(image, palette, config, until="segment")
    marks = run_stages(image, palette, config)
    half = (image.shape[1] // SEARCH_SCALE, image.shape[0] // SEARCH_SCALE)
    assert seen.small is not None
    return {
        "frame": _png(cv2.resize(image, half, interpolation=cv2.INTER_AREA)),
        "photometry": _png(seen.small),
        "classify": _png(_masks_picture(masks)),
        "segment": _png(_blobs_picture(blobs)),
        "marks": _png(cv2.resize(_marks_picture(image, marks), half,
                                 interpolation=cv2.INTER_AREA)),
    }
