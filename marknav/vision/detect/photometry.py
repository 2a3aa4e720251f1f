"""Stage 1, photometry: the frame as if exposed for its marks and lit by white light.

**Design.** Hue and saturation are ratios of the channels, so a frame's brightness leaves them alone
— until the marks are so dark that 8-bit steps and sensor noise decide them, and until the value
floors that keep out shadows cut the marks too. A camera's auto-exposure meters the whole frame, so
a dim room or a frame with a lamp in it leaves the marks a few tens of grey levels. The stage
therefore applies a software gain that brings the frame's :data:`BRIGHT_PERCENTILE`-th brightest
value (max of B, G, R) to ``target_value`` (never below 1×, never above ``max_gain``): after it,
every value floor is relative to the frame's exposure. The light's colour is taken out by grey world
on the frame's grey part (its less saturated pixels, neither dark nor clipped: a board, a carpet or
the marks cannot pull it), each channel's correction bounded by :data:`MAX_CAST` and its
green–magenta part by ``tint_limit``: a tinted lamp's greys come back grey (their saturation, which
the floors read, falls back), while a room whose walls are really coloured is corrected only so far.
Both corrections are one per-channel gain (``Scene.gains``), applied through a table (``Scene.lut``)
to the half-size search image; the marks are measured in the frame's own pixels, where a blurred rim
still mixes paint and surroundings linearly (no channel clipped by the gain), and judged in
corrected units (:mod:`.shape`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np

from marknav.vision.detect.scene import SEARCH_SCALE, Mat, Scene

__all__ = ["MAX_CAST", "PhotometryConfig", "correction_gains", "correction_table", "photometry",
           "table_of"]

#: Rows and columns of the search image sampled for the frame's statistics (every n-th):
#: percentiles and medians of 1/16 of the pixels differ from the whole frame's by under a grey
#: level on the project's frames, at 1/16 of the cost.
_SAMPLE_STEP = 4
#: The frame's grey part: pixels whose saturation is at most 25 above the frame's 40th
#: percentile (within 60..160: a strong cast lifts grey to S ≈ 100, paint sits near 255),
#: neither dark (V ≤ 16: noise) nor clipped (V ≥ 250: the cast is lost there). Marks,
#: boards and carpets of strong colour are not grey, so they cannot pull the correction.
_GREY_RANK = 40.0
_GREY_S_ABOVE = 25.0
_GREY_S_MIN, _GREY_S_MAX = 60.0, 160.0
_DARK, _CLIPPED = 16, 250
#: Under this share of grey pixels there is no grey to balance against: no correction.
_MIN_GREY_SHARE = 0.05
#: Percentile (%) of the brightest channel that is the frame's bright end: 99 ignores a lamp
#: or a specular highlight covering under 1 % of the frame.
BRIGHT_PERCENTILE = 99.0
#: 8-bit levels, and the whole in percent.
_LEVELS = 256
_PERCENT = 100.0
#: Largest per-channel light-colour correction (×, and 1/× down): a lamp from 2700 K to
#: 6500 K moves the blue-to-red ratio by about 1.6× each way from daylight.
MAX_CAST = 1.6


@dataclass(frozen=True)
class PhotometryConfig:
    """Exposure and light-colour correction (see the module docstring)."""

    #: Grey level (0..255) the frame's bright end is brought to: 200 leaves headroom for
    #: highlights while a white sheet or a lamp-lit wall reads as white.
    target_value: float = 200.0
    #: Largest software gain (×): 8× is three stops, what a dim room under-exposes a camera
    #: metering a window or lamp by; more amplifies noise into colour.
    max_gain: float = 8.0
    #: Largest green–magenta part of the light-colour correction (natural log of the green
    #: gain over the mean of the blue and red ones' logs), or ``None`` for none: room lights
    #: differ along blue–amber, and a strong green or magenta excess in a room's greys is a
    #: painted wall or carpet, whose correction moves a yellow mark to orange. The robot's
    #: detector sets it (``camera.detect.tint_limit``); photographs from unknown cameras
    #: need plain grey world.
    tint_limit: float | None = None

    def __post_init__(self) -> None:
        if not 0 < self.target_value <= _LEVELS - 1:
            raise ValueError(f"target_value must be in (0, 255], got {self.target_value}")
        if not self.max_gain >= 1.0:
            raise ValueError(f"max_gain must be >= 1, got {self.max_gain}")
        if self.tint_limit is not None and not 0.0 <= self.tint_limit <= 1.0:
            raise ValueError(f"tint_limit must be in [0, 1] or None, got {self.tint_limit}")


def _percentile(channel: Mat, percent: float) -> float:
    """The ``percent``-th percentile of an 8-bit channel, from its histogram."""
    hist = cv2.calcHist([channel], [0], None, [256], [0, 256]).ravel()
    total = float(hist.sum())
    if total <= 0:
        return 0.0
    return float(np.searchsorted(np.cumsum(hist), percent / 100.0 * total))


def correction_table(small: Mat, config: PhotometryConfig) -> Mat:
    """The per-channel 256×1×3 table of the exposure gain and light-colour correction for a
    search image ``small`` (BGR)."""
    return table_of(correction_gains(small, config))


def table_of(gains: Mat) -> Mat:
    """The 256×1×3 table multiplying B, G, R by ``gains`` (rounded, clipped to 0..255)."""
    levels = np.arange(256, dtype=np.float32)[:, None] * gains[None, :].astype(np.float32)
    table: Mat = np.clip(levels + 0.5, 0, 255).astype(np.uint8).reshape(256, 1, 3)
    return table


def _grey_world(sample: Mat) -> Mat:
    """Per-channel gains (B, G, R) that make the sample's grey part grey (see the module
    docstring), within :data:`MAX_CAST`; 1 when under :data:`_MIN_GREY_SHARE` of it is grey."""
    hsv = cv2.cvtColor(sample, cv2.COLOR_BGR2HSV)
    sat, val = hsv[..., 1], hsv[..., 2]
    s_max = min(_GREY_S_MAX, max(_GREY_S_MIN, _percentile(sat, _GREY_RANK) + _GREY_S_ABOVE))
    grey = ((sat <= s_max) & (val > _DARK) & (val < _CLIPPED)).astype(np.uint8)
    if cv2.countNonZero(grey) < _MIN_GREY_SHARE * grey.size:
        return np.ones(3)
    means = np.array(cv2.mean(sample, grey)[:3]) + 1.0
    gains: Mat = np.clip(float(means.mean()) / means, 1.0 / MAX_CAST, MAX_CAST)
    return gains


def correction_gains(small: Mat, config: PhotometryConfig) -> Mat:
    """The per-channel gains (B, G, R) of the exposure and light-colour correction for a
    search image ``small`` (BGR)."""
    sample = np.ascontiguousarray(small[::_SAMPLE_STEP, ::_SAMPLE_STEP])
    channels = cv2.split(sample)
    cast = _grey_world(sample)
    if config.tint_limit is not None:
        logs = np.log(cast)
        tint = logs[1] - 0.5 * (logs[0] + logs[2])
        excess = tint - float(np.clip(tint, -config.tint_limit, config.tint_limit))
        # Take the excess out of green and put a third of it back on all three (grey stays).
        logs += excess / 3.0 - np.array([0.0, excess, 0.0])
        cast = np.exp(logs)
    balanced = [cv2.convertScaleAbs(c, alpha=float(k)) for c, k in zip(channels, cast, strict=True)]
    brightest = cv2.max(cv2.max(balanced[0], balanced[1]), balanced[2])
    bright = _percentile(brightest, BRIGHT_PERCENTILE)
    gain = float(np.clip(config.target_value / max(bright, 1.0), 1.0, config.max_gain))
    gains: Mat = gain * cast
    return gains


def photometry(scene: Scene, config: PhotometryConfig) -> Scene:
    """The scene with its search image, correction table and the search image's HSV."""
    h, w = scene.image.shape[:2]
    small = cv2.resize(scene.image, (max(1, w // SEARCH_SCALE), max(1, h // SEARCH_SCALE)),
                       interpolation=cv2.INTER_AREA)
    gains = correction_gains(small, config)
    lut = table_of(gains)
    corrected = cv2.LUT(small, lut)
    return replace(scene, gains=gains, lut=lut, small=corrected,
                   hsv=cv2.cvtColor(corrected, cv2.COLOR_BGR2HSV))
