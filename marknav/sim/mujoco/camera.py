"""MuJoCo's renderer as the robot's camera: a :class:`marknav.vision.sources.FrameSource`.

Each :meth:`MujocoCamera.read` renders the model's ``eye`` camera (fixed to the robot's body at
the camera height, turned by the mount's pitch and roll: the mission's focal length and principal
point as an exact pinhole) at the current physics state and clock time, in BGR. The world's image
conditions that belong to a camera rather than to the room are then applied as the built-in
camera applies them: the lens's distortion (the pinhole image is rendered on a larger canvas and
remapped, :class:`marknav.sim.lens.LensWarp`), a Gaussian blur of σ ``blur_sigma_px``, the
exposure (:mod:`marknav.sim.camera_timing`: the smear of the body's turn rate over
``exposure_ms``, the gain of ``exposure_drift``) and additive Gaussian noise of σ
``noise_sigma`` (from a tile drawn once, at a random offset per frame).

Time: with ``frame_rate_hz`` the camera takes frames on its own clock and loses
``dropped_frames`` of them (:class:`~marknav.sim.camera_timing.FrameClock`, the built-in camera's
clock): a read with no new frame taken since the previous one delivers the previous frame again
(same index). MuJoCo renders the present state only, so a frame taken between two reads is
rendered at the read that finds it, and stamped with that time. ``latency_frames`` delays
delivery by whole frames, and the world's ``camera_latency_s + processing_s`` in continuous
time: each frame taken goes into a short queue and a read delivers the newest one captured at
least that long ago, stamped with its capture time (the built-in camera renders the past pose
directly). Light level and colour come from the room's lamps (the model), not from a gain.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any

import cv2
import numpy as np

from marknav.core.clock import Clock
from marknav.sim.builtin_camera import CameraConfig
from marknav.sim.camera_timing import FrameClock, expose, exposure_gain, exposure_phase, smear_px
from marknav.sim.mujoco.body import MujocoBody
from marknav.sim.mujoco.gl import make_renderer
from marknav.vision.estimate import PowerLaw
from marknav.vision.sources import Frame, Image
from marknav.vision.undistort import Intrinsics

__all__ = ["MujocoCamera"]


class MujocoCamera:
    """The robot's camera in a :class:`MujocoBody`'s model (see the module docstring).
    ``close`` is idempotent; a closed camera reads ``None``."""

    def __init__(self, body: MujocoBody, *, clock: Clock, seed: int = 0,
                 latency_frames: int | None = None, name: str = "mujoco") -> None:
        cond = body.world.conditions
        latency = cond.latency_frames if latency_frames is None else latency_frames
        if latency < 0:
            raise ValueError(f"latency_frames must be ≥ 0, got {latency}")
        self.name = name
        self.config: CameraConfig = body.camera
        config = self.config
        canvas = body.canvas
        self._warp = body.warp
        self.latency_frames = latency
        self._body = body
        self._clock = clock
        self._renderer: Any = make_renderer(body.model, canvas.height, canvas.width)
        self._rng = np.random.default_rng([int(seed), 0x3C0C])
        self._blur = float(cond.blur_sigma_px)
        self._noise: tuple[Image, Image] | None = None
        if cond.noise_sigma > 0:
            tile = self._rng.normal(0.0, cond.noise_sigma,
                                    (2 * config.height, 2 * config.width, 3))
            self._noise = (np.clip(np.rint(tile), 0, 255).astype(np.uint8),
                           np.clip(np.rint(-tile), 0, 255).astype(np.uint8))
        self._buffer: deque[Frame] = deque(maxlen=latency + 1)
        delay = cond.camera_latency_s + cond.processing_s
        if not (math.isfinite(delay) and delay >= 0.0):
            raise ValueError(f"camera latency must be ≥ 0 s, got {delay}")
        #: Capture to processing (s), as :attr:`marknav.sim.builtin_camera.SimCamera.delay_s`.
        self.delay_s = float(delay)
        self._late: deque[Frame] = deque()  # rendered, not yet old enough to deliver
        self._index = 0
        self._closed = False
        self._conditions = cond
        self._frames = FrameClock(cond, t0=clock.now(), seed=seed)
        self._phase = exposure_phase(seed)

    @property
    def intrinsics(self) -> Intrinsics:
        """The exact pinhole the frames are rendered with."""
        c = self.config
        dist = self._body.world.conditions.lens.dist if self._warp is not None else ()
        return Intrinsics(fx=c.focal_px, fy=c.focal_px, cx=c.cx, cy=c.cy,
                          dist=dist if any(dist) else ())

    def range_law(self, mark_radius_mm: float) -> PowerLaw:
        """The pinhole's range law d = f·R / r (paper eq. 18) as a power law."""
        return PowerLaw(a=self.config.focal_px * mark_radius_mm, b=-1.0)

    @property
    def frames_dropped(self) -> int:
        """Frames lost so far (``dropped_frames``)."""
        return self._frames.frames_dropped

    def render(self, *, noise: bool = True, t: float | None = None) -> Image:
        """One BGR frame of the current state (blur, the exposure of a frame captured at ``t``
        (s; default: now), and noise unless ``noise`` is off)."""
        r = self._renderer
        r.update_scene(self._body.data, camera="eye")
        image = np.ascontiguousarray(cv2.cvtColor(r.render(), cv2.COLOR_RGB2BGR))
        if self._warp is not None:
            image = self._warp.apply(image)
        if self._blur > 0:
            k = 2 * math.ceil(3.0 * self._blur) + 1
            image = np.asarray(cv2.GaussianBlur(image, (k, k), self._blur), dtype=np.uint8)
        c = self._conditions
        when = self._clock.now() if t is None else t
        image = expose(image, motion_px=smear_px(self._body.yaw_rate, c, self.config.focal_px),
                       gain=exposure_gain(c, when, self._phase))
        if noise and self._noise is not None:
            h, w = self.config.height, self.config.width
            oy, ox = int(self._rng.integers(0, h + 1)), int(self._rng.integers(0, w + 1))
            pos, neg = self._noise
            cv2.add(image, pos[oy:oy + h, ox:ox + w], dst=image)
            cv2.subtract(image, neg[oy:oy + h, ox:ox + w], dst=image)
        return image

    def read(self) -> Frame | None:
        if self._closed:
            return None
        now = self._clock.now()
        if self._frames.capture(now, have_frame=bool(self._late)) is not None:
            self._late.append(Frame(image=self.render(t=now), t=now, index=self._index))
            self._index += 1
        # the newest frame at least delay_s old (the oldest one while none is yet)
        while len(self._late) > 1 and self._late[1].t <= now - self.delay_s + 1e-9:
            self._late.popleft()
        head = self._late[0]
        if not self._buffer or self._buffer[-1].index != head.index:
            self._buffer.append(head)
        return self._buffer[0]

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        self._buffer.clear()
        self._late.clear()
        # An OpenGL context left to the garbage collector at exit complains (ctypes errors).
        self._renderer.close()

    def __enter__(self) -> MujocoCamera:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
