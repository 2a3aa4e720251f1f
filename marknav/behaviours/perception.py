"""Perception: frame → marks in pixels → marks in millimetres → blackboard (paper §3, §4.5).

Each tick :class:`Perception` reads the latest frame from the camera (``FrameSource.read()``),
finds the marks (:class:`marknav.vision.detect.Detector`), estimates each one's position in the
robot frame (:func:`marknav.vision.estimate.estimate_disc`: a disc standing at camera height,
range by eq. 19 or eq. 2 from the ellipse's vertical semi-axis, bearing from its horizontal ends;
camera assumed at the robot's centre, looking along its heading) and places it in the world
frame with the robot's odometry pose *at the frame's capture time* (``Frame.t``: a short history
of the poses of the last ticks, interpolated — :mod:`marknav.planning.pose_history`); a mark
placed with the pose at processing time would sit v·τ too far along the robot's motion for a
frame τ old. Sightings and the frame carry the capture time; ``FrameInfo.latency_s`` is the
frame's age when processed (capture to this tick), which the status panel, the event log and
the report show. It writes ``/marknav/frame``, ``/marknav/marks``,
``/marknav/last_seen`` and refreshes the target's sighting (:func:`~marknav.behaviours.target.
associate`), so every later node of the tick sees one consistent picture.

While it watches, it calibrates odometry (``robot.calibrate_wheels``, on by default, with a robot
that supports it): marks stand still, so their drift in the odometry frame measures the wheels'
ratio (:mod:`marknav.planning.wheel_ratio`); each precise fit rescales the right wheel. The same
stillness measures the range law (``camera.learn_range``, on by default): the distance driven
toward a mark is what its radius change must mean (:mod:`marknav.vision.range_learning`); each
accepted fit replaces the law (and restarts the wheel ratio's window, whose marks were placed
with the old law). The two learners see different things: a wrong law moves a mark along the
line of sight, unequal wheels mostly across it. With intrinsics (the mission's, or the simulated
camera's own), every detection is undistorted (:mod:`marknav.vision.undistort`) before it is
estimated, and the lateral offset is measured from the principal point; the law to start from is
chosen by
:func:`marknav.missions.camera.mission_range_model`.

Status: SUCCESS every tick, also when no new frame came (the previous marks stay, with their
time), until no frame has come for ``camera_timeout_s``: then FAILURE, "camera lost", and the
mission aborts.

:class:`PerceptionBase` holds everything but where the marks come from, so the test kit's
``FakePerception`` publishes exactly as the real one does.
"""

from __future__ import annotations

import bisect
import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, TypeGuard

from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.base import MarknavBehaviour, SetupError, check_positive
from marknav.behaviours.target import (
    associate,
    describe_target,
    excluded_passes,
    memory_gone,
    remember,
    reselect,
    with_sighting,
)
from marknav.core.wording import count
from marknav.missions.camera import (
    as_power_law,
    mission_intrinsics,
    mission_range_model,
)
from marknav.planning.kinematics import Pose, to_world_frame
from marknav.planning.pose_history import PoseHistory
from marknav.planning.wheel_ratio import WheelRatioCalibrator, WheelRatioStep
from marknav.robot.robot import BUMPED, WheelCalibratable
from marknav.vision.estimate import RangeModel, estimate_disc, upright_extents
from marknav.vision.range_learning import MIN_RADIUS_FRACTION, RangeLawLearner, RangeLawStep
from marknav.vision.sources import Frame, FrameSource
from marknav.vision.undistort import Intrinsics, undistort_mark

if TYPE_CHECKING:
    from marknav.missions.schema import Mission
    from marknav.vision.detect import Mark

__all__ = ["DEFAULT_CAMERA_TIMEOUT_S", "Observation", "Perception", "PerceptionBase"]

log = logging.getLogger(__name__)

#: The feedback message names this many marks (the nearest), then "+N more".
FEEDBACK_MARKS = 3

#: No frame for this long (mission-clock seconds) means the camera is lost.
DEFAULT_CAMERA_TIMEOUT_S = 1.0


@dataclass(frozen=True, init=False)
class Observation:
    """One processed frame: its description, the marks in it, and the odometry pose they were
    placed with (``None``: ask the robot). (Made every frame: one-step constructor, as
    :class:`~marknav.behaviours.keys.SeenMark`'s.)"""

    frame: keys.FrameInfo
    marks: tuple[keys.SeenMark, ...]
    pose: Pose | None = None

    def __init__(self, frame: keys.FrameInfo, marks: tuple[keys.SeenMark, ...],
                 pose: Pose | None = None) -> None:
        self.__dict__.update(frame=frame, marks=marks, pose=pose)


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
        self._frame_message: str | None = ""
        self._frame_text: tuple[Observation, keys.Target | None, keys.SeenMark | None] | None = None

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
            hold = self.mission.navigation.lost_after_s if self.mission is not None else None
            if hold is not None and silent > hold:
                # Old frames cannot say a target is lost: without this, a stalled camera made
                # the route start a search turn, blind. RUNNING stops the rest of the tree (its
                # drivers stop the wheels) until frames come back or the camera is lost.
                self.feedback_message = (f"holding: no new frame for {silent:.2f} s "
                                         f"(camera lost after {self.camera_timeout_s:g} s)")
                return Status.RUNNING
            if silent >= 0.5 * self.camera_timeout_s:
                self.feedback_message = f"no new frame for {silent:.2f} s"
            elif self.frames == 0:
                self.feedback_message = f"waiting for the first frame ({silent:.2f} s)"
            else:  # between frames (the camera is slower than the tick): nothing is wrong
                self.feedback_message = f"{self.frame_message} ({silent:.2f} s ago)"
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
        pose: Pose | None = None
        if obs.marks or known:
            pose = obs.pose if obs.pose is not None else self.robot.pose()
            known = remember(known, obs.marks, pose=pose, half_fov_rad=self.half_fov_rad())
            self.write(keys.KNOWN, known)
        target = self.target()
        sighting = None
        if target is not None:
            passed = excluded_passes(self.read(keys.PASSED, ()), self.mission)
            if pose is not None and memory_gone(target, known):
                # The remembered mark was looked at where it should be and is not there (a
                # misplaced sighting): choose again, from what is in view and the memory.
                target = reselect(target, obs.marks, known, passed, pose)
                self.write(keys.TARGET, target)
            sighting = associate(obs.marks, target, passed, pose, known)
            if sighting is not None:
                self.write(keys.TARGET, with_sighting(target, sighting))
        # The text is built when something reads it (the live view, a failure's reason), not
        # every frame: most frames nobody does.
        self._frame_text = (obs, target, sighting)
        self._frame_message = None
        self._feedback_is_frame = True

    @property
    def feedback_message(self) -> str:
        """py_trees' feedback: the last frame's text (built on first read), or what was set."""
        return self.frame_message if self._feedback_is_frame else self._feedback

    @feedback_message.setter
    def feedback_message(self, text: str) -> None:
        self._feedback = text
        self._feedback_is_frame = False

    @property
    def frame_message(self) -> str:
        """What the last frame showed: its nearest marks and the target's sighting."""
        if self._frame_message is None and self._frame_text is not None:
            obs, target, sighting = self._frame_text
            shown = obs.marks[:FEEDBACK_MARKS]  # nearest first (the detector's and the fake's)
            seen = ", ".join(f"{m.colour} {m.range_mm / 1000.0:.2f} m" for m in shown) \
                or "no marks"
            if len(obs.marks) > len(shown):
                seen += f" (+{len(obs.marks) - len(shown)} more)"
            focus = (f"; target {target.label}: {describe_target(target, sighting, obs.marks)}"
                     if target is not None else "")
            self._frame_message = f"frame {obs.frame.index}: {seen}{focus}"
        return self._frame_message or ""

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
    :class:`~marknav.missions.mission_detector.CameraDetector` of the mission's camera: minimum
    radius and horizon prior from ``camera.detect``) and ``range_model`` (default from
    ``mission.camera.range``).
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
        #: The latest frame processed and its detections (pixels), for the run log and viewer.
        self.last_frame: Frame | None = None
        self.last_detections: tuple[Mark, ...] = ()
        self._calibrator: WheelRatioCalibrator | None = None
        self._calibratable: tuple[object, bool] | None = None  # (robot, its isinstance)
        #: Wheel-ratio corrections applied so far (newest last).
        self.wheel_calibrations: list[WheelRatioStep] = []
        self._intrinsics: Intrinsics | None = None
        self._scaled: tuple[int, int, Intrinsics | None] | None = None
        #: The range law's learner (``camera.learn_range``), its steps and where the law began.
        self.range_learner: RangeLawLearner | None = None
        self.range_calibrations: list[RangeLawStep] = []
        self._range_times: list[float] = []
        self.range_source = "setup(range_model=...)"
        #: The odometry poses of the last ticks, to place a frame's marks at its capture time.
        self.poses = PoseHistory()
        #: Every processed frame's age when processed (s): capture to the tick.
        self.latencies: list[float] = []
        #: Frames older than the pose history: placed with its oldest pose.
        self.frames_beyond_history = 0
        #: What learning the camera's pose said (see CameraDetector.learn).
        self.horizon_messages: list[str] = []

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
            self._intrinsics = mission_intrinsics(mission, self._camera)
            if self._range_model is None:
                self._range_model, self.range_source = mission_range_model(mission,
                                                                          self._camera)
                prior = as_power_law(self._range_model)
                if mission.camera.learn_range and prior is not None:
                    self.range_learner = RangeLawLearner(
                        prior=prior, min_radius_px=MIN_RADIUS_FRACTION * mission.camera.width)
                    self._range_model = prior
            if self._detector is None:
                from marknav.missions.mission_detector import mission_detector

                self._detector = mission_detector(mission, self._camera)
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
        now = self.now()
        robot = self.robot
        calibrated = (robot if self._calibrator is not None
                      and self._wheel_calibratable(robot) else None)
        if calibrated is not None:
            pose_now, sensitivity = calibrated.odometry_snapshot()
        else:
            pose_now, sensitivity = robot.pose(), None
        self.poses.add(now, pose_now, sensitivity or ())
        frame = self._camera.read()
        if frame is None or frame.index == self._last_index:
            return None
        self._last_index = frame.index
        height, width = frame.image.shape[:2]
        # The capture time (a source's clock a little ahead of the mission clock counts as now).
        t = min(frame.t, now)
        self.latencies.append(now - t)
        found: list[Mark] = list(self._detector.detect(frame.image))
        self.last_frame, self.last_detections = frame, tuple(found)
        intr = self._frame_intrinsics(width, height)
        if intr is not None and intr.distorted:
            found = [undistort_mark(m, intr) for m in found]
        # The odometry pose at capture time, and its sensitivity to the wheel scale then.
        at = self.poses.at(t)
        pose = pose_now
        if at is not None:
            pose = at.pose
            if sensitivity is not None and len(at.extra) == 3:
                sensitivity = (at.extra[0], at.extra[1], at.extra[2])
            if at.clamped_s > 1e-6 and t < now:
                self.frames_beyond_history += 1
        cx = intr.cx if intr is not None else keys.image_centre(width)
        focal = self._focal_px(intr, width)
        marks = tuple(self._to_seen(m, width, t, pose, cx, focal) for m in found)
        if getattr(self._detector, "learner", None) is not None:
            self._learn_horizon(found, marks, width, height, t, pose, cx)
        if calibrated is not None and sensitivity is not None:
            self._calibrate(calibrated, pose, sensitivity, marks)
        if self.range_learner is not None:
            self._learn_range(pose, found, marks, width, height)
        sigma = self.range_learner.sigma[0] if self.range_learner is not None else 0.0
        info = keys.FrameInfo(index=frame.index, t=t, width=width, height=height,
                              marks=len(marks), range_sigma=sigma, latency_s=now - t)
        return Observation(frame=info, marks=marks, pose=pose)

    def _learn_horizon(self, found: list[Mark], marks: tuple[keys.SeenMark, ...], width: int,
                       height: int, t: float, pose: Pose, cx: float) -> None:
        """While the camera's pose is learnt (no ``camera.pitch_deg``): the marks used and
        those the detector held back (outside the band in use) feed the fit."""
        detector = self._detector
        held = list(getattr(detector, "held_back", ()))
        intr = self._frame_intrinsics(width, height)
        if intr is not None and intr.distorted:
            held = [undistort_mark(m, intr) for m in held]
        sightings = [(m.x, m.y, s.forward_mm) for m, s in zip(found, marks, strict=True)]
        focal = self._focal_px(intr, width)
        sightings += [(m.x, m.y, self._to_seen(m, width, t, pose, cx, focal).forward_mm)
                      for m in held]
        message = detector.learn(sightings, width, height)
        if message is not None:
            if "too far off" in message:
                log.warning("%s", message)
            else:
                log.info("%s", message)
            self.horizon_messages.append(message)

    def _wheel_calibratable(self, robot: object) -> TypeGuard[WheelCalibratable]:
        """``isinstance(robot, WheelCalibratable)``, asked once per robot (a protocol check
        looks up each member: tens of µs, every frame)."""
        known = self._calibratable
        if known is None or known[0] is not robot:
            known = self._calibratable = (robot, isinstance(robot, WheelCalibratable))
        return known[1]

    def _calibrate(self, robot: WheelCalibratable, pose: Pose,
                   sensitivity: tuple[float, float, float],
                   marks: tuple[keys.SeenMark, ...]) -> None:
        calibrator = self._calibrator
        assert calibrator is not None
        if calibrator.samples == 0 and sensitivity != (0.0, 0.0, 0.0):
            # a new window: its sensitivities count from here (they stay small and linear)
            robot.anchor_odometry()
            sensitivity = (0.0, 0.0, 0.0)
            # From the new anchor the wheel scale acts on motion after it only: the poses
            # already driven do not depend on it.
            self.poses.set_extra((0.0, 0.0, 0.0))
        for m in marks:
            calibrator.add(m.colour, (pose.x, pose.y), m.world, sensitivity)
        step = calibrator.correction()
        if step is None:
            return
        before = robot.right_wheel_scale
        robot.scale_right_wheel(step.factor)  # re-anchors: as above
        self.poses.set_extra((0.0, 0.0, 0.0))
        self.wheel_calibrations.append(step)
        fit = step.fit
        log.info("odometry: right wheel scale %.4f -> %.4f ± %.4f (fit %+.4f ± %.4f from %d "
                 "sightings of %s, residual %.0f mm)", before, robot.right_wheel_scale,
                 step.scale_sigma, fit.epsilon, fit.sigma, fit.samples,
                 count(fit.marks, "mark"), fit.rms_mm)

    def _frame_intrinsics(self, width: int, height: int) -> Intrinsics | None:
        """The intrinsics at this frame's size (scaled if the camera delivers another size than
        the mission's camera.width × height)."""
        intr = self._intrinsics
        if intr is None or self.mission is None:
            return intr
        if self._scaled is None or self._scaled[:2] != (width, height):
            cam = self.mission.camera
            same = (width, height) == (cam.width, cam.height)
            self._scaled = (width, height, intr if same else
                            intr.scaled(width / cam.width, height / cam.height))
        return self._scaled[2]

    def _learn_range(self, pose: Pose, found: list[Mark], marks: tuple[keys.SeenMark, ...],
                     width: int, height: int) -> None:
        learner = self.range_learner
        assert learner is not None
        if self.robot.safety_state == BUMPED:
            learner.interrupt()  # the bump moved the robot (or the mark) behind odometry's back
            return
        for m, seen in zip(found, marks, strict=True):
            r = m.radius
            if m.x - r < 2 or m.y - r < 2 or m.x + r > width - 3 or m.y + r > height - 3:
                continue  # cut by the image edge: its radius is not the mark's
            # the law maps the vertical semi-axis to range (estimate_disc)
            upright = upright_extents(m.axes, m.angle_deg)[1]
            learner.add(m.colour, (pose.x, pose.y, pose.theta), upright, seen.left_mm)
        step = learner.update()
        if step is None:
            return
        self._range_model = step.after
        self.range_calibrations.append(step)
        self._range_times.append(self.now())
        if self._calibrator is not None and abs(step.change) > 0.01:
            self._calibrator.reset()  # its window's marks were placed with the old law
        fit = step.fit
        log.info("range law: a %.0f b %.4f -> a %.0f b %.4f (%+.1f %% at 1 m; σ %.1f %%, "
                 "exponent σ %.3f; %d sightings of %s, χ %.2f, %s dropped)",
                 step.before.a, step.before.b, step.after.a, step.after.b, 100.0 * step.change,
                 100.0 * step.sigma_scale, step.sigma_exponent, fit.samples,
                 count(fit.marks, "mark"), fit.chi,
                 count(fit.dropped, "outlier"))

    def learnt_range(self, times: Sequence[float | None] = ()) -> dict[str, Any] | None:
        """The learnt law for the report: ``{a, b, steps, rejected, samples, started_from,
        source, yaml}``, and ``at`` — the law in use at each of ``times`` (e.g. the waypoints'
        pass times; ``None`` stays ``None``). ``None`` without a learner."""
        learner = self.range_learner
        if learner is None:
            return None
        law = learner.law

        def at(t: float | None) -> dict[str, float] | None:
            if t is None:
                return None
            k = bisect.bisect_right(self._range_times, t)
            used = self.range_calibrations[k - 1].after if k > 0 else learner.prior
            return {"a": round(used.a, 1), "b": round(used.b, 5)}

        return {"a": round(law.a, 1), "b": round(law.b, 5), "steps": len(learner.steps),
                "rejected": learner.rejected, "samples": learner.samples,
                "started_from": {"a": round(learner.prior.a, 1), "b": learner.prior.b},
                "source": self.range_source, "at": [at(t) for t in times],
                "yaml": f"range: {{model: power, a: {law.a:.6g}, b: {law.b:.6g}}}"}

    def _focal_px(self, intr: Intrinsics | None, width: int) -> float | None:
        """The focal length at this frame's width: the intrinsics' fx, else the mission's
        ``camera.focal_px`` scaled to the frame."""
        if intr is not None:
            return intr.fx
        mission = self.mission
        if mission is None:
            return None
        return mission.camera.focal_px * width / mission.camera.width

    def _to_seen(self, mark: Mark, width: int, t: float, pose: Pose,
                 cx: float | None = None, focal_px: float | None = None) -> keys.SeenMark:
        assert self._range_model is not None and self._mark_radius_mm is not None
        est = estimate_disc(x_px=mark.x, axes=mark.axes, angle_deg=mark.angle_deg,
                            cx=keys.image_centre(width) if cx is None else cx,
                            model=self._range_model, mark_radius_mm=self._mark_radius_mm,
                            focal_px=focal_px)
        # x_px is kept relative to the principal point, as if it were the image centre (what
        # SeenMark.pixel_error, the approach's steering, measures from).
        x_px = mark.x if cx is None else mark.x - cx + keys.image_centre(width)
        return self.seen_mark(colour=mark.colour, forward_mm=est.forward_mm,
                              left_mm=est.left_mm, x_px=x_px, radius_px=mark.radius,
                              image_width=width, t=t, pose=pose)
