"""The detector a mission's camera calls for: minimum mark size and horizon prior from the
camera model (``camera.detect`` in the mission file).

- **Minimum radius** (:meth:`~marknav.vision.detect.DetectorConfig.for_camera`): a mark at
  ``max_range_mm`` is 0.9·f·R/d px across its semi-major axis, not below ``ROBOT_FLOOR_PX``; smaller
  blobs are not marks that matter (they are clutter or marks too far to steer by).
- **Horizon prior** (paper §3.1: marks stand at camera height): mark centres lie on the
  principal point's row (the image centre's without intrinsics). With the camera's pose
  (``camera.pitch_deg``, ``roll_deg``, ``height_mm`` and ``marks.height_mm``) the band is placed
  from it (:func:`horizon_band`): a mark whose centre stands Δh above the camera, d ahead, lies
  at the row c_y + f·tan(pitch − atan(Δh/d)) — on the horizon row c_y + f·tan(pitch) far away,
  farthest from it at the nearest range a mark is used at (``navigation.clearance_mm``: passing
  it); roll moves the image edges by width/2·tan(roll) rows. ``horizon_tolerance_deg`` is the
  pose's uncertainty (f·tan t rows of pitch, width/2·tan t of roll), plus ``HORIZON_SLACK_PX``
  for the centre's measurement. Without a pitch (``camera.pitch_deg`` null) the pose is
  learnt from the marks seen (:class:`CameraDetector` with ``learn=True``,
  :mod:`marknav.vision.horizon_learning`): until a fit, the detector searches
  ±:data:`LEARN_SPAN_DEG` and the marks it finds feed the fit, but only those in the level
  band are used; then the band is the fitted pose's (never narrower than the level one's).
- **White balance held to the room's light** (``tint_limit``): the grey-world correction's
  green–magenta part is limited; a room's lights differ along blue–amber, and a strong green or
  magenta cast in its greys is a painted wall or carpet
  (:attr:`~marknav.vision.detect.photometry.PhotometryConfig.tint_limit`).
- **Faint blobs are not marks** (``min_chroma_contrast``,
  :attr:`~marknav.vision.detect.shape.ShapeConfig.min_contrast`): a mark's colour must stand
  out from its surroundings'.

Frames of another size than the mission's camera (a camera that delivers another mode) get
their own detector, the focal length and principal point scaled to them.

**One detector per mission**: :func:`mission_detector` is the only way the project builds a
mission's detector — perception (``marknav run``) and ``marknav detect --mission`` both call it,
so the command a user tunes with answers as the robot does.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from marknav.core.wording import count, signed
from marknav.missions.schema_camera import ROBOT_TINT_LIMIT
from marknav.missions.schema_mission import Mission
from marknav.vision.detect.model import Mark
from marknav.vision.detect.pipeline import Detector, DetectorConfig
from marknav.vision.detect.scene import U8Array
from marknav.vision.detect.shape import ShapeConfig
from marknav.vision.horizon_learning import HorizonFit, HorizonLearner
from marknav.vision.palette import Palette

__all__ = ["HORIZON_SLACK_PX", "ROBOT_FLOOR_PX", "ROBOT_TINT_LIMIT", "CameraDetector",
           "CameraPose", "camera_detector_config", "horizon_band",
           "mission_detector"]

#: While the camera's pose is being learnt, the detector searches this far off level (deg): a
#: camera mounted by hand is within a few degrees; 12° is 125 px at f = 590.
LEARN_SPAN_DEG = 12.0
#: A learnt pitch beyond this (deg) is too near the edge of what was searched to trust.
TOO_FAR_OFF_DEG = LEARN_SPAN_DEG - 2.0
#: Sightings between two fits of the learnt pose.
REFIT_EVERY = 10

#: Rows added to the horizon tolerance for the error of a measured centre.
HORIZON_SLACK_PX = 4.0
#: The smallest minimum radius the robot uses (px): the detector finds marks down to 2.5 px,
#: but below 5 px their range is off by 10-16 % (docs/explanation/detector.md, *Small cameras*)
#: and a 160×120 camera's slalom steering by them can pass a mark on the wrong side.
ROBOT_FLOOR_PX = 5.0


@dataclass(frozen=True)
class CameraPose:
    """The camera's pose for the horizon prior: ``pitch_deg`` (up), ``roll_deg``, and the
    marks' centres above the camera, ``rise_mm = (lo, hi)`` (mm), at ranges from ``near_mm``."""

    pitch_deg: float = 0.0
    roll_deg: float = 0.0
    rise_mm: tuple[float, float] = (0.0, 0.0)
    near_mm: float = 300.0

    @classmethod
    def of_mission(cls, mission: Mission) -> CameraPose:
        """The mission's camera pose (what it does not give: level, at the marks' height)."""
        cam, marks = mission.camera, mission.marks
        rise = (0.0, 0.0)
        if marks.height_mm is not None and cam.height_mm is not None:
            rise = (marks.height_mm[0] - cam.height_mm, marks.height_mm[1] - cam.height_mm)
        return cls(pitch_deg=cam.pitch_deg or 0.0, roll_deg=cam.roll_deg or 0.0, rise_mm=rise,
                   near_mm=mission.navigation.clearance_mm)


def horizon_band(pose: CameraPose, *, width: int, focal_px: float, centre_row: float,
                 tolerance_deg: float) -> tuple[float, float]:
    """Rows ``(lo, hi)`` where the centres of marks can lie (see the module docstring): from the
    elevations 0 (far) to atan(rise/near) (nearest) of the marks' height range, seen by a camera
    pitched ``pitch_deg``, widened by the roll's width/2·|tan roll| and by the pose's
    uncertainty ``tolerance_deg`` ((f + width/2)·tan t) plus :data:`HORIZON_SLACK_PX`. Pure
    function."""
    p = math.radians(pose.pitch_deg)
    lo_rise, hi_rise = pose.rise_mm
    e_hi = max(0.0, math.atan2(hi_rise, pose.near_mm))
    e_lo = min(0.0, math.atan2(lo_rise, pose.near_mm))
    top = centre_row + focal_px * math.tan(p - e_hi)
    bottom = centre_row + focal_px * math.tan(p - e_lo)
    widen = (width / 2.0 * abs(math.tan(math.radians(pose.roll_deg)))
             + (focal_px + width / 2.0) * math.tan(math.radians(tolerance_deg))
             + HORIZON_SLACK_PX)
    return top - widen, bottom + widen


def camera_detector_config(*, width: int, height: int, focal_px: float, mark_radius_mm: float,
                           max_range_mm: float | None, horizon_tolerance_deg: float | None,
                           horizon_row: float | None = None,
                           tint_limit: float | None = None,
                           min_chroma_contrast: float = ShapeConfig.min_contrast,
                           max_readings: int = ShapeConfig.max_blobs,
                           pose: CameraPose | None = None,
                           ) -> DetectorConfig:
    """The detector config for a ``width`` × ``height`` camera of focal length ``focal_px``
    (``horizon_row``: the principal point's row; default the image centre's; ``pose``: the
    camera's, default level at the marks' height; ``tint_limit``, ``min_chroma_contrast``,
    ``max_readings``: the photometry's ``tint_limit``, the shape's ``min_contrast`` and
    ``max_blobs``)."""
    row: float | None = None
    tolerance = 0.0
    if horizon_tolerance_deg is not None:
        centre = (height - 1) / 2.0 if horizon_row is None else horizon_row
        lo, hi = horizon_band(pose or CameraPose(), width=width, focal_px=focal_px,
                              centre_row=centre, tolerance_deg=horizon_tolerance_deg)
        row, tolerance = 0.5 * (lo + hi), 0.5 * (hi - lo)
    base = DetectorConfig() if max_range_mm is None else DetectorConfig.for_camera(
        focal_px=focal_px, mark_radius_mm=mark_radius_mm, max_range_mm=max_range_mm,
        floor_px=ROBOT_FLOOR_PX)
    suppress = {"horizon_row": row}
    if row is not None:
        suppress["horizon_tolerance_px"] = tolerance
    return base.with_(photometry={"tint_limit": tint_limit},
                      shape={"min_contrast": min_chroma_contrast, "max_blobs": max_readings},
                      suppress=suppress)


class CameraDetector:
    """A :class:`Detector` configured from a mission's camera, one per frame size.

    With ``learn=True`` (the mission gives no ``camera.pitch_deg``) it learns the camera's pose
    from the marks seen (see the module docstring): :meth:`accepts` says which of a frame's
    marks lie in the band in use, :meth:`learn` takes every mark found with its distance and
    returns a message when the learnt pose changes (logged by perception); :attr:`learnt` is
    the latest fit. :meth:`detect` returns the marks in the band in use, and holds the others
    back for learning (:attr:`held_back`)."""

    def __init__(self, palette: Palette, *, width: int, height: int, focal_px: float,
                 mark_radius_mm: float, max_range_mm: float | None,
                 horizon_tolerance_deg: float | None, horizon_row: float | None = None,
                 tint_limit: float | None = None,
                 min_chroma_contrast: float = ShapeConfig.min_contrast,
                 max_readings: int = ShapeConfig.max_blobs,
                 pose: CameraPose | None = None, learn: bool = False) -> None:
        self.palette = palette
        self.pose = pose
        self._tint_limit = tint_limit
        self._min_chroma_contrast = min_chroma_contrast
        self._max_readings = max_readings
        self._camera = (width, height, focal_px, horizon_row)
        self._mark_radius_mm = mark_radius_mm
        self._max_range_mm = max_range_mm
        self._tolerance_deg = horizon_tolerance_deg
        self._detectors: dict[tuple[int, int], Detector] = {}
        self.learner: HorizonLearner | None = None
        self.learnt: HorizonFit | None = None
        self._accept: tuple[float, float] | None = None  # rows in use (camera's own size)
        self._told: tuple[float, float, float] | None = None
        #: The last frame's marks outside the band in use (while learning).
        self.held_back: list[Mark] = []
        if learn and horizon_tolerance_deg is not None:
            cy = (height - 1) / 2.0 if horizon_row is None else horizon_row
            self.learner = HorizonLearner(focal_px=focal_px, cx=(width - 1) / 2.0, cy=cy)
            self._level_deg = horizon_tolerance_deg
            self._accept = horizon_band(pose or CameraPose(), width=width, focal_px=focal_px,
                                        centre_row=cy, tolerance_deg=horizon_tolerance_deg)
            self._tolerance_deg = max(horizon_tolerance_deg, LEARN_SPAN_DEG)  # search wide
        # The camera's own size now, at set-up (tables, compiled loops), not in the first frame.
        self.detector_for(width, height)

    def accepts(self, y_px: float, height: int) -> bool:
        """Whether a mark centred on row ``y_px`` of a frame ``height`` rows high lies in the
        band in use (always, unless the pose is being learnt)."""
        if self._accept is None:
            return True
        k = height / self._camera[1]
        lo, hi = self._accept
        return (lo + 0.5) * k - 0.5 <= y_px <= (hi + 0.5) * k - 0.5

    def learn(self, sightings: Sequence[tuple[float, float, float]], width: int,
              height: int) -> str | None:
        """Feed one frame's marks ``(x_px, y_px, forward_mm)``; refit every
        :data:`REFIT_EVERY` sightings. Returns a message when the learnt pose moved the band
        (or looks too far off to trust), else ``None``."""
        learner = self.learner
        if learner is None or not sightings:
            return None
        w0, h0, focal, _ = self._camera
        k = w0 / width
        before = learner.samples
        for x, y, forward in sightings:
            learner.add((x + 0.5) * k - 0.5, (y + 0.5) * h0 / height - 0.5, forward)
        if learner.samples // REFIT_EVERY == before // REFIT_EVERY:
            return None
        fit = learner.fit()
        if fit is None:
            return None
        self.learnt = fit
        pitch = fit.pitch_deg(cy=learner.cy, focal_px=focal)
        rise = fit.rise_mm(focal_px=focal) if fit.rise_fitted else 0.0
        roll = fit.roll_deg()
        near = self.pose.near_mm if self.pose is not None else CameraPose().near_mm
        pose = CameraPose(pitch_deg=pitch, roll_deg=roll, rise_mm=(rise, rise), near_mm=near)
        # The band: the fitted pose's, its residual's 3σ as pose uncertainty, never narrower
        # than the level band's.
        spread = math.degrees(math.atan2(3.0 * fit.rms_px, focal))
        self.pose, self._tolerance_deg = pose, max(self._level_deg, spread)
        self._accept = horizon_band(pose, width=w0, focal_px=focal, centre_row=learner.cy,
                                    tolerance_deg=self._tolerance_deg)
        self._detectors.clear()
        told = self._told
        self._told = (pitch, rise, roll)
        if abs(pitch) > TOO_FAR_OFF_DEG:
            return (f"the camera looks too far off level: pitched {pitch:+.1f}° (from "
                    f"{fit.samples} sightings), near the ±{LEARN_SPAN_DEG:g}° searched while "
                    "learning; level the camera or give camera.pitch_deg")
        if told is None or abs(told[0] - pitch) > 1.0 or abs(told[1] - rise) > 40.0:
            return (f"camera pose learnt from {count(fit.samples, 'sighting')}: pitch "
                    f"{signed(pitch, 1)}°, roll {signed(roll, 1)}°, the marks' centres "
                    f"{signed(rise)} mm above the camera"
                    + ("" if fit.rise_fitted else " (not yet separable from the pitch)")
                    + f"; residual {fit.rms_px:.1f} px"
                    + ("; give camera.pitch_deg (and camera.height_mm, marks.height_mm) to "
                       "start from it" if abs(pitch) > self._level_deg or abs(rise) > 50.0
                       else ""))
        return None

    @classmethod
    def for_mission(cls, mission: Mission, horizon_row: float | None = None) -> CameraDetector:
        """The mission's detector (``horizon_row``: the principal point's row, if known); it
        learns the camera's pose when the mission gives no ``camera.pitch_deg``."""
        cam = mission.camera
        return cls(mission.palette(), width=cam.width, height=cam.height,
                   focal_px=cam.focal_px, mark_radius_mm=mission.marks.radius_mm,
                   max_range_mm=cam.detect.max_range_mm,
                   horizon_tolerance_deg=cam.detect.horizon_tolerance_deg,
                   horizon_row=horizon_row, tint_limit=cam.detect.tint_limit,
                   min_chroma_contrast=cam.detect.min_chroma_contrast,
                   max_readings=cam.detect.max_readings, pose=CameraPose.of_mission(mission),
                   learn=cam.pitch_deg is None)

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
                horizon_row=None if row is None else (row + 0.5) * height / h0 - 0.5,
                pose=self.pose)
            detector = self._detectors[(width, height)] = Detector(self.palette, config)
        return detector

    def detect(self, image: U8Array) -> list[Mark]:
        """The marks in one BGR frame (see :meth:`Detector.detect`). While the pose is being
        learnt, those found outside the band in use are held back (:attr:`held_back`: for
        :meth:`learn`, not for steering)."""
        height, width = image.shape[:2]
        found = self.detector_for(width, height).detect(image)
        if self._accept is None or not found:
            self.held_back = []
            return found
        keep = [m for m in found if self.accepts(m.y, height)]
        self.held_back = [m for m in found if not self.accepts(m.y, height)]
        return keep


def mission_detector(mission: Mission, camera: object = None) -> CameraDetector:
    """The detector of ``mission``'s camera: its palette, ``camera.detect`` settings and the
    horizon row of its principal point (:func:`~marknav.missions.camera.mission_intrinsics`:
    the mission's ``camera.intrinsics``, else those ``camera`` knows of itself, else the image
    centre). Perception and ``marknav detect --mission`` both build theirs here."""
    from marknav.missions.camera import mission_intrinsics

    intrinsics = mission_intrinsics(mission, camera)
    return CameraDetector.for_mission(mission, None if intrinsics is None else intrinsics.cy)
