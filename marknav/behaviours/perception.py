"""Perception: frame → marks in pixels → marks in millimetres → blackboard (paper §3, §4.5).

Each tick :class:`Perception` reads the latest frame from the camera (``FrameSource.read()``),
finds the marks (:class:`marknav.vision.detect.Detector`), estimates each one's position in the
robot frame (:func:`marknav.vision.estimate.estimate`: range by eq. 19 or eq. 2, lateral offset by
eq. 21; camera assumed at the robot's centre, looking along its heading) and places it in the world
frame with the robot's odometry pose. It writes ``/marknav/frame``, ``/marknav/marks``,
``/marknav/last_seen`` and refreshes the target's sighting (:func:`~marknav.behaviours.target.
associate`), so every later node of the tick sees one consistent picture.

While it watches, it calibrates odometry (``robot.calibrate_wheels``, on by default, with a robot
that supports it): marks stand still, so their drift in the odometry frame measures the wheels'
ratio (:mod:`marknav.planning.wheel_ratio`); each precise fit rescales the right wheel.

Status: SUCCESS every tick, also when no new frame came (the previous marks stay, with their
time), until no frame has come for ``camera_timeout_s``: then FAILURE, "camera lost", and the
mission aborts.

:class:`PerceptionBase` holds everything but where the marks come from, so the test kit's
``FakePerception`` publishes exactly as the real one does.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.base import MarknavBehaviour, SetupError, check_positive
from marknav.behaviours.target import (
    associate,
    describe,
    excluded_passes,
    remember,
    with_sighting,
)
from marknav.drivers.robot import WheelCalibratable
from marknav.planning.kinematics import Pose, to_world_frame
from marknav.planning.wheel_ratio import WheelRatioCalibrator, WheelRatioStep
from marknav.vision.estimate import Pinhole, PowerLaw, RangeModel, estimate
from marknav.vision.sources import FrameSource

if TYPE_CHECKING:
    from marknav.missions.schema import Mission
    from marknav.vision.detect import Mark

__all__ = ["DEFAULT_CAMERA_TIMEOUT_S", "Observation", "Perception", "PerceptionBase",
           "range_model_of"]

log = logging.getLogger(__name__)

#: The feedback message names this many marks (the nearest), then "+N more".
FEEDBACK_MARKS = 3

#: No frame for this long (mission-clock seconds) means the camera is lost.
DEFAULT_CAMERA_TIMEOUT_S = 1.0


@dataclass(frozen=True)
class Observation:
    """One processed frame: its description, the marks in it, and the odometry pose they were
    placed with (``None``: ask the robot)."""

    frame: keys.FrameInfo
    marks: tuple[keys.SeenMark, ...]
    pose: Pose | None = None


def range_model_of(mission: Mission) -> RangeModel:
    """The mission's ``camera.range`` as an estimation model (eq. 19 power law or eq. 2 pinhole)."""
    spec = mission.camera.range
    if spec.model == "power":
        return PowerLaw(a=spec.a, b=spec.b)
    return Pinhole(focal_px=spec.focal_px, radius_mm=mission.marks.radius_mm)


class PerceptionBase(MarknavBehaviour):
    """Publishes observations to the blackboard and watches for a lost camera.

    Subclasses implement :meth:`observe`: the newest frame's marks, or ``None`` when no new frame
    is available this tick.
    """

    READS: ClassVar[tuple[str, ...]] = (keys.PASSED,)
    WRITES: ClassVar[tuple[str, ...]] = (keys.FRAME, keys.MARKS, keys.LAST_SEEN, keys.TARGET,
                                         keys.KNOWN)
    ABORTS: ClassVar[bool] = True

    def __init__(self, name: str = "Perception", *,
                 camera_timeout_s: float = DEFAULT_CAMERA_TIMEOUT_S) -> None:
        super().__init__(name)
        check_positive(camera_timeout_s, "camera_timeout_s")
        self.camera_timeout_s = float(camera_timeout_s)
        self._last_frame_t: float | None = None  # mission time of the last frame (or first wait)
        self._half_fov: tuple[Mission, float] | None = None
        self.frames = 0

    def observe(self) -> Observation | None:  # pragma: no cover - abstract
        raise NotImplementedError

    def update(self) -> Status:
        now = self.now()
        obs = self.observe()
        if obs is None:
            if self._last_frame_t is None:
                self._last_frame_t = now  # the wait for the first frame starts now
            silent = now - self._last_frame_t
            if silent > self.camera_timeout_s:
                return self.fail(f"camera lost: no frame for {silent:.1f} s "
                                 f"(limit {self.camera_timeout_s:g} s)")
            self.feedback_message = f"no new frame for {silent:.2f} s"
            return Status.SUCCESS
        self._last_frame_t = now
        self.frames += 1
        self.publish(obs)
        return Status.SUCCESS

    def publish(self, obs: Observation) -> None:
        """Write one observation: frame, marks, last sighting per colour, the target's sighting."""
        self.write(keys.FRAME, obs.frame)
        self.write(keys.MARKS, obs.marks)
        last_seen: dict[str, keys.SeenMark] = dict(self.read(keys.LAST_SEEN, {}) or {})
        for mark in sorted(obs.marks, key=lambda m: -m.range_mm):
            last_seen[mark.colour] = mark  # the nearest of each colour is written last
        self.write(keys.LAST_SEEN, last_seen)
        known: tuple[keys.KnownMark, ...] = self.read(keys.KNOWN, ())
        if obs.marks or known:
            pose = obs.pose if obs.pose is not None else self.robot.pose()
            self.write(keys.KNOWN, remember(known, obs.marks, pose=pose,
                                            half_fov_rad=self.half_fov_rad()))
        target = self.target()
        sighting = None
        if target is not None:
            passed = excluded_passes(self.read(keys.PASSED, ()), self.mission)
            where = None
            if target.remembered and not target.locked:
                where = obs.pose if obs.pose is not None else self.robot.pose()
            sighting = associate(obs.marks, target, passed, where)
            if sighting is not None:
                self.write(keys.TARGET, with_sighting(target, sighting))
        shown = obs.marks[:FEEDBACK_MARKS]  # nearest first (the detector's and the fake's order)
        seen = ", ".join(f"{m.colour} {m.range_mm / 1000.0:.2f} m" for m in shown) or "no marks"
        if len(obs.marks) > len(shown):
            seen += f" (+{len(obs.marks) - len(shown)} more)"
        focus = f"; target {target.label}: {describe(sighting)}" if target is not None else ""
        self.feedback_message = f"frame {obs.frame.index}: {seen}{focus}"

    def half_fov_rad(self) -> float | None:
        """Half the camera's horizontal field of view (from the mission), if known."""
        m = self.mission
        if m is None:
            return None
        if self._half_fov is None or self._half_fov[0] is not m:
            self._half_fov = (m, math.radians(0.5 * m.camera.hfov_deg))
        return self._half_fov[1]

    def seen_mark(self, *, colour: str, forward_mm: float, left_mm: float, x_px: float,
                  radius_px: float, image_width: int, t: float,
                  pose: Pose | None = None) -> keys.SeenMark:
        """A :class:`~marknav.behaviours.keys.SeenMark`, placed in the world by odometry
        (``pose``, default the robot's pose now)."""
        wx, wy = to_world_frame(pose if pose is not None else self.robot.pose(),
                                (forward_mm, left_mm))
        return keys.SeenMark(colour=colour, forward_mm=forward_mm, left_mm=left_mm, world_x=wx,
                             world_y=wy, x_px=x_px, radius_px=radius_px, image_width=image_width,
                             t=t)


class Perception(PerceptionBase):
    """The camera pipeline: ``FrameSource`` → ``Detector`` → ``estimate`` → blackboard.

    Setup keywords: ``camera`` (a :class:`~marknav.vision.sources.FrameSource`, required),
    ``mission`` (palette, mark radius, range model), ``robot`` (odometry pose), ``clock``;
    optionally ``detector`` (anything with ``detect(image) -> list[Mark]``; default
    ``Detector(mission.palette())``) and ``range_model`` (default from ``mission.camera.range``).
    A frame whose index repeats the previous one is not processed again.
    """

    def __init__(self, name: str = "Perception", *,
                 camera_timeout_s: float = DEFAULT_CAMERA_TIMEOUT_S) -> None:
        super().__init__(name, camera_timeout_s=camera_timeout_s)
        self._camera: FrameSource | None = None
        self._detector: Any = None
        self._range_model: RangeModel | None = None
        self._mark_radius_mm: float | None = None
        self._last_index: int | None = None
        self._calibrator: WheelRatioCalibrator | None = None
        #: Wheel-ratio corrections applied so far (newest last).
        self.wheel_calibrations: list[WheelRatioStep] = []

    def configure(self, **kwargs: Any) -> None:
        camera = kwargs.get("camera")
        if camera is not None:
            if not isinstance(camera, FrameSource):
                raise TypeError(f"{self._owner}: setup(camera=...) needs a FrameSource, "
                                f"got {camera!r}")
            self._camera = camera
        detector = kwargs.get("detector")
        if detector is not None:
            self._detector = detector
        range_model = kwargs.get("range_model")
        if range_model is not None:
            self._range_model = range_model
        mission = self.mission
        if mission is not None:
            self._mark_radius_mm = mission.marks.radius_mm
            if self._range_model is None:
                self._range_model = range_model_of(mission)
            if self._detector is None:
                from marknav.vision.detect import Detector

                self._detector = Detector(mission.palette())
            calibrate = mission.robot.calibrate_wheels
            if calibrate and self._calibrator is None:
                self._calibrator = WheelRatioCalibrator()
            elif not calibrate:
                self._calibrator = None

    def observe(self) -> Observation | None:
        if self._camera is None:
            raise SetupError(f"{self._owner} has no camera: set the tree up with "
                             "tree.setup(camera=..., ...)")
        if self._detector is None or self._range_model is None or self._mark_radius_mm is None:
            raise SetupError(f"{self._owner} needs mission= in tree.setup() (palette, mark "
                             "radius, range model)")
        frame = self._camera.read()
        if frame is None or frame.index == self._last_index:
            return None
        self._last_index = frame.index
        height, width = frame.image.shape[:2]
        t = self.now()
        found: list[Mark] = list(self._detector.detect(frame.image))
        robot = self.robot
        calibrated = (robot if self._calibrator is not None
                      and isinstance(robot, WheelCalibratable) else None)
        if calibrated is not None:
            pose, sensitivity = calibrated.odometry_snapshot()
        else:
            pose, sensitivity = robot.pose(), None
        marks = tuple(self._to_seen(m, width, t, pose) for m in found)
        if calibrated is not None and sensitivity is not None:
            self._calibrate(calibrated, pose, sensitivity, marks)
        info = keys.FrameInfo(index=frame.index, t=t, width=width, height=height,
                              marks=len(marks))
        return Observation(frame=info, marks=marks, pose=pose)

    def _calibrate(self, robot: WheelCalibratable, pose: Pose,
                   sensitivity: tuple[float, float, float],
                   marks: tuple[keys.SeenMark, ...]) -> None:
        calibrator = self._calibrator
        assert calibrator is not None
        if calibrator.samples == 0 and sensitivity != (0.0, 0.0, 0.0):
            # a new window: its sensitivities count from here (they stay small and linear)
            robot.anchor_odometry()
            sensitivity = (0.0, 0.0, 0.0)
        for m in marks:
            calibrator.add(m.colour, (pose.x, pose.y), m.world, sensitivity)
        step = calibrator.correction()
        if step is None:
            return
        before = robot.right_wheel_scale
        robot.scale_right_wheel(step.factor)
        self.wheel_calibrations.append(step)
        fit = step.fit
        log.info("odometry: right wheel scale %.4f -> %.4f ± %.4f (fit %+.4f ± %.4f from %d "
                 "sightings of %d marks, residual %.0f mm)", before, robot.right_wheel_scale,
                 step.scale_sigma, fit.epsilon, fit.sigma, fit.samples, fit.marks, fit.rms_mm)

    def _to_seen(self, mark: Mark, width: int, t: float, pose: Pose) -> keys.SeenMark:
        assert self._range_model is not None and self._mark_radius_mm is not None
        est = estimate(x_px=mark.x, radius_px=mark.radius, minor_px=mark.axes[1],
                       cx=keys.image_centre(width), model=self._range_model,
                       mark_radius_mm=self._mark_radius_mm)
        return self.seen_mark(colour=mark.colour, forward_mm=est.forward_mm,
                              left_mm=est.left_mm, x_px=mark.x, radius_px=mark.radius,
                              image_width=width, t=t, pose=pose)
