"""What perception learns while it watches: one interface, three learners, fed one sighting a frame.

Marks stand still, so every frame of them says something about the robot's own instruments.
:class:`~marknav.behaviours.perception.Perception` reads the camera, finds the marks, places them
with the odometry pose at the frame's capture time, and hands the result on as one
:class:`Sighting` to each of its :class:`SightingLearner`\\ s, in order:

- :class:`HorizonLearning` — the camera's pitch, roll and the marks' rise, where the detector's
  horizon band belongs (:mod:`marknav.vision.horizon_learning`, through the mission's
  :class:`~marknav.missions.mission_detector.CameraDetector`), when the mission gives no
  ``camera.pitch_deg``;
- :class:`WheelRatioLearning` — the right wheel's scale from the marks' drift in odometry's
  frame (:mod:`marknav.planning.wheel_ratio`), with ``robot.calibrate_wheels`` and a robot that
  supports it; each precise fit rescales the wheel and re-anchors odometry;
- :class:`RangeLawLearning` — the range law from the distance driven toward a mark against its
  radius change (:mod:`marknav.vision.range_learning`), with ``camera.learn_range``; each
  accepted law is the one perception estimates the next frames with, and a law that moves a
  mark at 1 m by more than :data:`LAW_CHANGE_RESTARTS` restarts the learners placed with the old
  one (the wheel ratio's window).

A learner reads nothing but its sighting and what it was built with; its readout is
:attr:`SightingLearner.steps`, what it has changed so far (oldest first), which the report and
the tests read.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

from marknav.behaviours import keys
from marknav.core.wording import count
from marknav.planning.kinematics import Pose
from marknav.planning.pose_history import PoseHistory
from marknav.planning.wheel_ratio import Sensitivity, WheelRatioCalibrator, WheelRatioStep
from marknav.robot.robot import WheelCalibratable
from marknav.vision.estimate import PowerLaw, upright_extents
from marknav.vision.range_learning import RangeLawLearner, RangeLawStep

if TYPE_CHECKING:
    from marknav.vision.detect import Mark

__all__ = ["EDGE_MARGIN_PX", "LAW_CHANGE_RESTARTS", "HorizonLearning", "RangeLawLearning",
           "Restartable", "SightedMark", "Sighting", "SightingLearner", "WheelRatioLearning"]

#: Perception's own logger: the learners speak for the leaf that feeds them (the lines a run
#: prints, ``INFO marknav.behaviours.perception: range law: ...``, keep their name).
log = logging.getLogger("marknav.behaviours.perception")

#: A learnt range law that moves a mark the old law put at 1 m by more than this fraction
#: (1 %: a few times the wheel fit's own placement scatter) makes the marks placed with the old
#: law useless to the learners that compare placements (the wheel ratio's window).
LAW_CHANGE_RESTARTS = 0.01

#: A mark whose disc comes this close to the image's edge (px; the detector's outline is cut two
#: pixels in, the far edge three because the last column and row are width − 1, height − 1) is
#: cut by it: its radius is not the mark's, and the range law does not learn from it.
EDGE_MARGIN_PX = 2
_FAR_EDGE_PX = EDGE_MARGIN_PX + 1


@dataclass(frozen=True)
class SightedMark:
    """One detected mark: its ``pixels`` (undistorted when the lens is known) and ``seen``, the
    estimate made from them (robot frame and world, placed with the pose at capture)."""

    pixels: Mark
    seen: keys.SeenMark


@dataclass(frozen=True)
class Sighting:
    """The marks of one frame, as perception hands them to its learners.

    ``t``: the capture time and ``now``: the tick that processed it (mission clock, s);
    ``pose``: odometry's pose at ``t`` and ``sensitivity`` its derivative by the right wheel's
    scale then (``None``: the wheels are not calibrated); ``width`` × ``height``: the frame (px);
    ``marks``: what the detector found, nearest first as the detector gives them;
    ``held_back``: marks found outside the horizon band in use while the camera's pose is
    learnt (not steered by); ``bumped``: the robot was bumped when the frame was processed (the
    bump moved it, or the mark, behind odometry's back).
    """

    t: float
    now: float
    pose: Pose
    width: int
    height: int
    marks: tuple[SightedMark, ...]
    held_back: tuple[SightedMark, ...] = ()
    sensitivity: Sensitivity | None = None
    bumped: bool = False


class SightingLearner(Protocol):
    """Something perception teaches with every sighting."""

    @property
    def steps(self) -> Sequence[Any]:
        """What the learner has changed so far, oldest first."""
        ...

    def observe(self, sighting: Sighting) -> None:
        """Learn from one frame's marks."""
        ...


class Restartable(Protocol):
    """A learner whose window of sightings can be dropped (placed with a law no longer in use)."""

    def restart(self) -> None: ...


class HorizonDetector(Protocol):
    """A detector that learns the camera's pose (:meth:`CameraDetector.learn
    <marknav.missions.mission_detector.CameraDetector.learn>`)."""

    def learn(self, sightings: Sequence[tuple[float, float, float]], width: int,
              height: int) -> str | None: ...


class HorizonLearning:
    """The camera's pose, learnt by the detector from every mark found, also those it held back
    (outside the band in use). Its steps are the messages the learnt pose gave (logged: a
    warning when the camera looks too far off level)."""

    def __init__(self, detector: HorizonDetector) -> None:
        self.detector = detector
        self.messages: list[str] = []

    @property
    def steps(self) -> Sequence[str]:
        return self.messages

    def observe(self, sighting: Sighting) -> None:
        rows = [(m.pixels.x, m.pixels.y, m.seen.forward_mm)
                for m in sighting.marks + sighting.held_back]
        message = self.detector.learn(rows, sighting.width, sighting.height)
        if message is None:
            return
        if "too far off" in message:
            log.warning("%s", message)
        else:
            log.info("%s", message)
        self.messages.append(message)


class WheelRatioLearning:
    """The right wheel's scale from the marks' drift in odometry's frame.

    ``odometry()``: the robot to correct (``None``: none that can be); ``poses``: the pose
    history sightings are placed from, whose sensitivities become zero when odometry is
    re-anchored. A sighting without a sensitivity is not learnt from."""

    def __init__(self, odometry: Callable[[], WheelCalibratable | None], poses: PoseHistory,
                 calibrator: WheelRatioCalibrator | None = None) -> None:
        self.odometry = odometry
        self.poses = poses
        self.calibrator = calibrator if calibrator is not None else WheelRatioCalibrator()
        #: Wheel-ratio corrections applied so far (newest last).
        self.calibrations: list[WheelRatioStep] = []

    @property
    def steps(self) -> Sequence[WheelRatioStep]:
        return self.calibrations

    def restart(self) -> None:
        """Forget the window's sightings (they were placed with a law no longer in use)."""
        self.calibrator.reset()

    def observe(self, sighting: Sighting) -> None:
        sensitivity = sighting.sensitivity
        robot = self.odometry()
        if sensitivity is None or robot is None:
            return
        calibrator = self.calibrator
        if calibrator.samples == 0 and sensitivity != (0.0, 0.0, 0.0):
            # a new window: its sensitivities count from here (they stay small and linear)
            robot.anchor_odometry()
            sensitivity = (0.0, 0.0, 0.0)
            # From the new anchor the wheel scale acts on motion after it only: the poses
            # already driven do not depend on it.
            self.poses.set_extra((0.0, 0.0, 0.0))
        pose = sighting.pose
        for m in sighting.marks:
            calibrator.add(m.seen.colour, (pose.x, pose.y), m.seen.world, sensitivity)
        step = calibrator.correction()
        if step is None:
            return
        before = robot.right_wheel_scale
        robot.scale_right_wheel(step.factor)  # re-anchors: as above
        self.poses.set_extra((0.0, 0.0, 0.0))
        self.calibrations.append(step)
        fit = step.fit
        log.info("odometry: right wheel scale %.4f -> %.4f ± %.4f (fit %+.4f ± %.4f from %d "
                 "sightings of %s, residual %.0f mm)", before, robot.right_wheel_scale,
                 step.scale_sigma, fit.epsilon, fit.sigma, fit.samples,
                 count(fit.marks, "mark"), fit.rms_mm)


@dataclass
class RangeLawLearning:
    """The range law from the marks' radii against the distance driven toward them.

    ``model`` is the law to estimate with (the prior until a fit is accepted), handed to
    ``on_law`` when a fit is; ``restarts``: learners whose windows an accepted law that changes
    by more than :data:`LAW_CHANGE_RESTARTS` makes stale. ``times``: the processing time of each
    step."""

    learner: RangeLawLearner
    restarts: Sequence[Restartable] = ()
    on_law: Callable[[PowerLaw], None] | None = None
    model: PowerLaw = field(init=False)
    times: list[float] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.model = self.learner.prior

    @property
    def steps(self) -> Sequence[RangeLawStep]:
        return self.learner.steps

    def observe(self, sighting: Sighting) -> None:
        learner = self.learner
        if sighting.bumped:
            learner.interrupt()  # the bump moved the robot (or the mark) behind odometry's back
            return
        pose = (sighting.pose.x, sighting.pose.y, sighting.pose.theta)
        width, height = sighting.width, sighting.height
        for sighted in sighting.marks:
            m = sighted.pixels
            r = m.radius
            if (m.x - r < EDGE_MARGIN_PX or m.y - r < EDGE_MARGIN_PX
                    or m.x + r > width - _FAR_EDGE_PX or m.y + r > height - _FAR_EDGE_PX):
                continue  # cut by the image edge: its radius is not the mark's
            # the law maps the vertical semi-axis to range (estimate_disc)
            upright = upright_extents(m.axes, m.angle_deg)[1]
            learner.add(m.colour, pose, upright, sighted.seen.left_mm)
        step = learner.update()
        if step is None:
            return
        self.model = step.after
        self.times.append(sighting.now)
        if self.on_law is not None:
            self.on_law(step.after)
        if abs(step.change) > LAW_CHANGE_RESTARTS:
            for other in self.restarts:
                other.restart()  # its window's marks were placed with the old law
        fit = step.fit
        log.info("range law: a %.0f b %.4f -> a %.0f b %.4f (%+.1f %% at 1 m; σ %.1f %%, "
                 "exponent σ %.3f; %d sightings of %s, χ %.2f, %s dropped)",
                 step.before.a, step.before.b, step.after.a, step.after.b, 100.0 * step.change,
                 100.0 * step.sigma_scale, step.sigma_exponent, fit.samples,
                 count(fit.marks, "mark"), fit.chi, count(fit.dropped, "outlier"))
