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

While it watches, it learns: each frame's marks, with the capture time and the pose then, go as
one :class:`~marknav.behaviours.learners.Sighting` to each of its learners
(:mod:`marknav.behaviours.learners`: horizon, wheel ratio, range law), in that order. It
calibrates odometry (``robot.calibrate_wheels``, on by default, with a robot that supports it):
marks stand still, so their drift in the odometry frame measures the wheels'
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
from marknav.behaviours.learners import (
    HorizonLearning,
    RangeLawLearning,
    SightedMark,
    Sighting,
    SightingLearner,
    WheelRatioLearning,
)
from marknav.behaviours.target import (
    associate,
    describe_target,
    excluded_passes,
    memory_gone,
    remember,
    reselect,
    with_sighting,
)
from marknav.missions.camera import (
    as_power_law,
    mission_intrinsics,
    mission_range_model,
)
from marknav.planning.kinematics import Pose, to_world_frame
from marknav.planning.pose_history import PoseHistory
from marknav.planning.wheel_ratio import Sensitivity, WheelRatioStep
from marknav.robot.robot import BUMPED, WheelCalibratable
from marknav.vision.estimate import PowerLaw, RangeModel, estimate_disc
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

#: A capture time this far (s) outside the pose history counts as beyond it (below: the float
#: rounding of a time at its edge).
CLAMP_TOLERANCE_S = 1e-6


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
    """The camera pipeline: ``FrameSource`` → ``Detector`` → ``estimate`` → blackboard, and a
    :class:`~marknav.behaviours.learners.Sighting` a frame to each of :attr:`learners`.

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
        self._calibratable: tuple[object, bool] | None = None  # (robot, its isinstance)
        self._intrinsics: Intrinsics | None = None
        self._scaled: tuple[int, int, Intrinsics | None] | None = None
        #: The learners fed every frame's sighting, in order (built by setup from the mission).
        self.learners: list[SightingLearner] = []
        self._horizon: HorizonLearning | None = None
        self._wheels: WheelRatioLearning | None = None
        self._range: RangeLawLearning | None = None
        self.range_source = "setup(range_model=...)"
        #: The odometry poses of the last ticks, to place a frame's marks at its capture time.
        self.poses = PoseHistory()
        #: Every processed frame's age when processed (s): capture to the tick.
        self.latencies: list[float] = []
        #: Frames older than the pose history: placed with its oldest pose.
        self.frames_beyond_history = 0

    @property
    def range_learner(self) -> RangeLawLearner | None:
        """The range law's learner (``camera.learn_range``), if any."""
        return self._range.learner if self._range is not None else None

    @property
    def range_calibrations(self) -> Sequence[RangeLawStep]:
        """The range law's accepted steps (oldest first)."""
        return self._range.steps if self._range is not None else ()

    @property
    def wheel_calibrations(self) -> Sequence[WheelRatioStep]:
        """Wheel-ratio corrections applied so far (newest last)."""
        return self._wheels.steps if self._wheels is not None else ()

    @property
    def horizon_messages(self) -> Sequence[str]:
        """What learning the camera's pose said (see CameraDetector.learn)."""
        return self._horizon.steps if self._horizon is not None else ()

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
            self._configure_from(mission)
        self._build_learners()

    def _configure_from(self, mission: Mission) -> None:
        """Mark radius, intrinsics, the range law (and its learner), the detector and wheel
        calibration from the mission."""
        self._mark_radius_mm = mission.marks.radius_mm
        self._intrinsics = mission_intrinsics(mission, self._camera)
        if self._range_model is None:
            self._range_model, self.range_source = mission_range_model(mission, self._camera)
            prior = as_power_law(self._range_model)
            if mission.camera.learn_range and prior is not None:
                self._range = RangeLawLearning(RangeLawLearner(
                    prior=prior, min_radius_px=MIN_RADIUS_FRACTION * mission.camera.width),
                    on_law=self._use_law)
                self._range_model = prior
        if self._detector is None:
            from marknav.missions.mission_detector import mission_detector

            self._detector = mission_detector(mission, self._camera)
        calibrate = mission.robot.calibrate_wheels
        if calibrate and self._wheels is None:
            self._wheels = WheelRatioLearning(self._odometry, self.poses)
        elif not calibrate:
            self._wheels = None

    def _build_learners(self) -> None:
        """The learners in the order they learn from a frame: horizon, wheel ratio, range law
        (a law accepted in a frame restarts the wheel ratio's window after it learnt)."""
        if getattr(self._detector, "learner", None) is not None:
            if self._horizon is None or self._horizon.detector is not self._detector:
                self._horizon = HorizonLearning(self._detector)
        else:
            self._horizon = None
        if self._range is not None:
            self._range.restarts = [self._wheels] if self._wheels is not None else []
        self.learners = [x for x in (self._horizon, self._wheels, self._range) if x is not None]

    def _use_law(self, law: PowerLaw) -> None:
        """Estimate the next frames with a newly learnt range law."""
        self._range_model = law

    def _odometry(self) -> WheelCalibratable | None:
        """The robot, if wheel calibration is on and it can be calibrated."""
        if self._wheels is None:
            return None
        robot = self.robot
        return robot if self._wheel_calibratable(robot) else None

    def observe(self) -> Observation | None:
        camera, detector = self._ready()
        now = self.now()
        odometry = self._odometry()
        if odometry is not None:
            pose_now, sensitivity = odometry.odometry_snapshot()
        else:
            pose_now, sensitivity = self.robot.pose(), None
        self.poses.add(now, pose_now, sensitivity or ())
        frame = camera.read()
        if frame is None or frame.index == self._last_index:
            return None
        self._last_index = frame.index
        height, width = frame.image.shape[:2]
        # The capture time (a source's clock a little ahead of the mission clock counts as now).
        t = min(frame.t, now)
        self.latencies.append(now - t)
        found: list[Mark] = list(detector.detect(frame.image))
        self.last_frame, self.last_detections = frame, tuple(found)
        pose, sensitivity = self._pose_at(t, now, pose_now, sensitivity)
        held = getattr(detector, "held_back", ()) if self._horizon is not None else ()
        sighting = Sighting(t=t, now=now, pose=pose, width=width, height=height,
                            marks=self._sighted(found, width, height, t, pose),
                            held_back=self._sighted(held, width, height, t, pose),
                            sensitivity=sensitivity,
                            bumped=self.robot.safety_state == BUMPED)
        for learner in self.learners:
            learner.observe(sighting)
        sigma = self._range.learner.sigma[0] if self._range is not None else 0.0
        marks = tuple(m.seen for m in sighting.marks)
        info = keys.FrameInfo(index=frame.index, t=t, width=width, height=height,
                              marks=len(marks), range_sigma=sigma, latency_s=now - t)
        return Observation(frame=info, marks=marks, pose=pose)

    def _ready(self) -> tuple[FrameSource, Any]:
        """The camera and the detector, or a :class:`SetupError` saying what is missing."""
        if self._camera is None:
            raise SetupError(f"{self._owner} has no camera: set the tree up with "
                             "tree.setup(camera=..., ...)")
        if self._detector is None or self._range_model is None or self._mark_radius_mm is None:
            raise SetupError(f"{self._owner} needs mission= in tree.setup() (palette, mark "
                             "radius, range model)")
        return self._camera, self._detector

    def _pose_at(self, t: float, now: float, pose_now: Pose,
                 sensitivity: Sensitivity | None) -> tuple[Pose, Sensitivity | None]:
        """The odometry pose at capture time ``t``, and its sensitivity to the wheel scale
        then (the pose now while the history is empty)."""
        at = self.poses.at(t)
        if at is None:
            return pose_now, sensitivity
        if sensitivity is not None and len(at.extra) == len(sensitivity):
            sensitivity = (at.extra[0], at.extra[1], at.extra[2])
        if at.clamped_s > CLAMP_TOLERANCE_S and t < now:
            self.frames_beyond_history += 1
        return at.pose, sensitivity

    def _sighted(self, found: Sequence[Mark], width: int, height: int, t: float,
                 pose: Pose) -> tuple[SightedMark, ...]:
        """Each detection (undistorted when the lens is known) with its estimate, placed with
        ``pose``."""
        if not found:
            return ()
        intr = self._frame_intrinsics(width, height)
        if intr is not None and intr.distorted:
            found = [undistort_mark(m, intr) for m in found]
        cx = intr.cx if intr is not None else keys.image_centre(width)
        focal = self._focal_px(intr, width)
        return tuple(SightedMark(m, self._to_seen(m, width, t, pose, cx, focal)) for m in found)

    def _wheel_calibratable(self, robot: object) -> TypeGuard[WheelCalibratable]:
        """``isinstance(robot, WheelCalibratable)``, asked once per robot (a protocol check
        looks up each member: tens of µs, every frame)."""
        known = self._calibratable
        if known is None or known[0] is not robot:
            known = self._calibratable = (robot, isinstance(robot, WheelCalibratable))
        return known[1]

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

    def learnt_range(self, times: Sequence[float | None] = ()) -> dict[str, Any] | None:
        """The learnt law for the report: ``{a, b, steps, rejected, samples, started_from,
        source, yaml}``, and ``at`` — the law in use at each of ``times`` (e.g. the waypoints'
        pass times; ``None`` stays ``None``). ``None`` without a learner."""
        if self._range is None:
            return None
        learning = self._range
        learner = learning.learner
        law = learner.law

        def at(t: float | None) -> dict[str, float] | None:
            if t is None:
                return None
            k = bisect.bisect_right(learning.times, t)
            used = learning.steps[k - 1].after if k > 0 else learner.prior
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
