"""What a simulated camera does in time, the same in both engines: its own frame clock with lost
frames, and its exposure (the smear of a turn during it, the auto-exposure's brightness swing).

- :class:`FrameClock`: with ``frame_rate_hz`` > 0 the camera takes frames at its own times
  ``t0 + k / frame_rate_hz``, whatever the control rate; each frame taken is lost with probability
  ``dropped_frames`` (a USB camera under load skips frames). A read asks which capture time it
  delivers: the newest frame taken since the previous read that was not lost, or ``None`` — the
  previous frame again (nothing new). Without a frame rate every read takes a frame (which may
  be lost the same way).
- :func:`exposure_gain`: 1 + ``exposure_drift`` · sin(2π t / ``exposure_period_s`` + φ), the
  slow swing of an auto-exposure chasing the room's light (φ drawn once per camera).
- :func:`expose`: the scene smeared sideways by the pixels the image moved during the exposure
  (the robot turning: ω · ``exposure_ms`` · f), a box filter of that length, then the gain — both
  before the sensor's noise.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from marknav.sim.world.schema import Conditions
from marknav.vision.sources import Image

__all__ = [
    "MAX_CAPTURES_PER_READ", "FrameClock", "expose", "exposure_gain", "exposure_phase",
    "smear_px",
]

#: Capture times a read looks back over (a camera far faster than the control loop): each is
#: one draw of the drop stream, so the cost of a read is bounded however long since the last.
MAX_CAPTURES_PER_READ = 64
#: A smear shorter than this many pixels is below the blur a real lens adds anyway (px).
_MIN_SMEAR_PX = 1.0
#: Slack on the capture-time grid, in periods (a read exactly on a capture time takes it).
_GRID_SLACK = 1e-9


class FrameClock:
    """A camera's capture times and lost frames (see the module docstring). ``seed`` fixes the
    losses; ``t0`` (s) is when the camera was made (its first capture time)."""

    def __init__(self, conditions: Conditions, *, t0: float, seed: int) -> None:
        self.rate_hz = float(conditions.frame_rate_hz)
        self.drop_p = float(conditions.dropped_frames)
        self.t0 = float(t0)
        self._drops = np.random.default_rng([int(seed), 0xD809])
        self._last_capture = -1  # index of the last capture time looked at
        #: Frames lost so far.
        self.frames_dropped = 0

    def capture(self, now: float, *, have_frame: bool) -> float | None:
        """The capture time (s) of the frame a read at ``now`` delivers, or ``None`` for the
        previous frame again (only when there is one: ``have_frame``)."""
        if self.rate_hz > 0:
            period = 1.0 / self.rate_hz
            k = math.floor((now - self.t0) / period + _GRID_SLACK)
            first = max(self._last_capture + 1, k - MAX_CAPTURES_PER_READ + 1)
            self._last_capture = k
            # every frame taken since the last read may be lost; the newest one that was not
            # is delivered
            kept = [j for j in range(first, k + 1) if not self._dropped()]
            if not kept and have_frame:
                return None
            return self.t0 + (kept[-1] if kept else k) * period
        if self._dropped() and have_frame:
            return None
        return now

    def _dropped(self) -> bool:
        if self.drop_p > 0 and self._drops.random() < self.drop_p:
            self.frames_dropped += 1
            return True
        return False


def exposure_phase(seed: int) -> float:
    """The phase φ (rad) of a camera's exposure swing, drawn once from its seed."""
    return float(np.random.default_rng([int(seed), 0xE7]).uniform(0.0, 2 * math.pi))


def exposure_gain(conditions: Conditions, t: float, phase: float) -> float:
    """The brightness factor of a frame captured at ``t`` (s): 1 without ``exposure_drift``."""
    if conditions.exposure_drift <= 0:
        return 1.0
    return 1.0 + conditions.exposure_drift * math.sin(
        2 * math.pi * t / conditions.exposure_period_s + phase)


def smear_px(yaw_rate_rad_s: float, conditions: Conditions, focal_px: float) -> float:
    """How far (px) the image moves sideways during one exposure while the robot turns at
    ``yaw_rate_rad_s``: ω · exposure · f (small angles)."""
    return yaw_rate_rad_s * conditions.exposure_ms / 1000.0 * focal_px


def expose(image: Image, *, motion_px: float = 0.0, gain: float = 1.0) -> Image:
    """``image`` smeared by ``motion_px`` (a horizontal box filter of that length, at most the
    image's width: a turn through more than the field of view during one exposure leaves only
    the average) and scaled by ``gain`` (saturating at 255); the image itself when neither
    applies."""
    if abs(motion_px) >= _MIN_SMEAR_PX:
        length = max(2, round(min(abs(motion_px), image.shape[1])))
        image = np.asarray(cv2.blur(image, (length, 1)), dtype=np.uint8)
    if gain != 1.0:
        image = np.asarray(cv2.convertScaleAbs(image, alpha=gain), dtype=np.uint8)
    return image
