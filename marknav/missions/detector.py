"""The detector a mission's camera calls for: minimum mark size and horizon prior from the
camera model (``camera.detect`` in the mission file).

- **Minimum radius** (:meth:`DetectorConfig.for_camera`): a mark at ``max_range_mm`` is
  0.9·f·R/d px across its semi-major axis, not below ``ROBOT_FLOOR_PX``; smaller blobs are not
  marks that matter (they are clutter or marks too far to steer by).
- **Horizon prior** (paper §3.1: marks stand at camera height): mark centres lie on the
  principal point's row (the image centre's without intrinsics). ``horizon_tolerance_deg``
  covers the camera's pitch (f·tan t rows) and roll (up to width/2·tan t rows at the image
  edges), plus ``HORIZON_SLACK_PX`` for the centre's measurement.
- **White balance held to the room's light** (``tint_limit``): the grey-world correction's
  green–magenta part is limited; a room's lights differ along blue–amber, and a strong green or
  magenta cast in its greys is a painted wall or carpet (:attr:`DetectorConfig.tint_limit`).
- **Faint blobs are not marks** (``min_chroma_contrast``, :mod:`.detect.faint`): a mark's
  colour must stand out from a ring just outside it.

Frames of another size than the mission's camera (a camera that delivers another mode) get
their own detector, the focal length and principal point scaled to them.
"""

from __future__ import annotations

import math
from dataclasses import replace

from marknav.missions.schema import ROBOT_TINT_LIMIT, Mission
from marknav.vision.detect import Detector, DetectorConfig, Mark
from marknav.vision.detect.geometry import U8Array
from marknav.vision.palette import Palette

__all__ = ["HORIZON_SLACK_PX", "ROBOT_FLOOR_PX", "ROBOT_TINT_LIMIT", "CameraDetector",
           "camera_detector_config"]

#: Rows added to the horizon tolerance for the error of a measured centre.
HORIZON_SLACK_PX = 4.0
#: The smallest minimum radius the robot uses (px): the detector finds marks down to 2.5 px,
#: but below 5 px their range is off by 10-16 % (docs/explanation/detector.md, *Small cameras*)
#: and a 160×120 camera's slalom goes wrong steering by them (wrong side, seed 5 of the
#: camera-run test).
ROBOT_FLOOR_PX = 5.0


def camera_detector_config(*, width: int, height: int, focal_px: float, mark_radius_mm: float,
                           max_range_mm: float | None, horizon_tolerance_deg: float | None,
                           horizon_row: float | None = None,
                           tint_limit: float | None = None,
                           min_chroma_contrast: float = DetectorConfig.min_chroma_contrast,
                           max_readings: int = DetectorConfig.max_readings,
                           ) -> DetectorConfig:
    """The detector config for a ``width`` × ``height`` camera of focal length ``focal_px``
    (``horizon_row``: the principal point's row; default the image centre's; ``tint_limit``,
    ``min_chroma_contrast``, ``max_readings``: :class:`DetectorConfig`'s)."""
    row, tolerance = None, DetectorConfig.horizon_tolerance_px
    if horizon_tolerance_deg is not None:
        t = math.tan(math.radians(horizon_tolerance_deg))
        row = (height - 1) / 2.0 if horizon_row is None else horizon_row
        tolerance = (focal_px + width / 2.0) * t + HORIZON_SLACK_PX
    if max_range_mm is None:
        return DetectorConfig(horizon_row=row, horizon_tolerance_px=tolerance,
                              tint_limit=tint_limit, min_chroma_contrast=min_chroma_contrast,
                              max_readings=max_readings)
    return replace(DetectorConfig.for_camera(
        focal_px=focal_px, mark_radius_mm=mark_radius_mm, max_range_mm=max_range_mm,
        floor_px=ROBOT_FLOOR_PX, horizon_row=row, horizon_tolerance_px=tolerance),
        tint_limit=tint_limit, min_chroma_contrast=min_chroma_contrast,
        max_readings=max_readings)


class CameraDetector:
    """A :class:`Detector` configured from a mission's camera, one per frame size."""

    def __init__(self, palette: Palette, *, width: int, height: int, focal_px: float,
                 mark_radius_mm: float, max_range_mm: float | None,
                 horizon_tolerance_deg: float | None, horizon_row: float | None = None,
                 tint_limit: float | None = None,
                 min_chroma_contrast: float = DetectorConfig.min_chroma_contrast,
                 max_readings: int = DetectorConfig.max_readings) -> None:
        self.palette = palette
        self._tint_limit = tint_limit
        self._min_chroma_contrast = min_chroma_contrast
        self._max_readings = max_readings
        self._camera = (width, height, focal_px, horizon_row)
        self._mark_radius_mm = mark_radius_mm
        self._max_range_mm = max_range_mm
        self._tolerance_deg = horizon_tolerance_deg
        self._detectors: dict[tuple[int, int], Detector] = {}
        # The camera's own size now, at set-up (tables, compiled loops), not in the first frame.
        self.detector_for(width, height)

    @classmethod
    def for_mission(cls, mission: Mission, horizon_row: float | None = None) -> CameraDetector:
        """The mission's detector (``horizon_row``: the principal point's row, if known)."""
        cam = mission.camera
        return cls(mission.palette(), width=cam.width, height=cam.height,
                   focal_px=cam.focal_px, mark_radius_mm=mission.marks.radius_mm,
                   max_range_mm=cam.detect.max_range_mm,
                   horizon_tolerance_deg=cam.detect.horizon_tolerance_deg,
                   horizon_row=horizon_row, tint_limit=cam.detect.tint_limit,
                   min_chroma_contrast=cam.detect.min_chroma_contrast,
                   max_readings=cam.detect.max_readings)

    def config_for(self, width: int, height: int) -> DetectorConfig:
        """The config frames of ``width`` × ``height`` are searched with."""
        return self.detector_for(width, height).config

    def detector_for(self, width: int, height: int) -> Detector:
        detector = self._detectors.get((width, height))
        if detector is None:
            w0, h0, focal, row = self._camera
            k = width / w0
            config = camera_detector_config(
                width=width, height=height, focal_px=focal * k,
                mark_radius_mm=self._mark_radius_mm, max_range_mm=self._max_range_mm,
                horizon_tolerance_deg=self._tolerance_deg, tint_limit=self._tint_limit,
                min_chroma_contrast=self._min_chroma_contrast, max_readings=self._max_readings,
                horizon_row=None if row is None else (row + 0.5) * height / h0 - 0.5)
            detector = self._detectors[(width, height)] = Detector(self.palette, config)
        return detector

    def detect(self, image: U8Array) -> list[Mark]:
        """The marks in one BGR frame (see :meth:`Detector.detect`)."""
        height, width = image.shape[:2]
        return self.detector_for(width, height).detect(image)
