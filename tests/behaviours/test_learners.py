"""Perception's learners through their one interface (a Sighting a frame), and the leaf that
feeds them: every learner once per new frame, with the pose at the frame's capture time."""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import replace

import pytest

from marknav.behaviours import keys
from marknav.behaviours.learners import (
    LAW_CHANGE_RESTARTS,
    HorizonLearning,
    RangeLawLearning,
    SightedMark,
    Sighting,
    SightingLearner,
    WheelRatioLearning,
)
from marknav.behaviours.perception import Perception
from marknav.missions.mission_detector import CameraDetector
from marknav.planning.kinematics import Pose, integrate_pose, to_robot_frame, to_world_frame
from marknav.planning.pose_history import PoseHistory
from marknav.robot.odometry import Odometry
from marknav.robot.packets import Model
from marknav.testing import FakeRobot
from marknav.vision.detect import Mark
from marknav.vision.estimate import PowerLaw
from marknav.vision.range_learning import RangeLawLearner
from marknav.vision.sources import Frame
from tests.behaviours.test_perception import ListSource, disc_frame
from tests.vision.test_horizon_learning import sightings as horizon_sightings

F, W, H = 590.0, 640, 480
CX = (W - 1) / 2.0
BASE = 235.0  # the Create 2's wheel base (mm)
TRUE_LAW = PowerLaw(59752.0, -1.00242)
PERCEPTION_LOG = "marknav.behaviours.perception"


def sighted(colour: str = "red", *, x: float = CX, y: float = 239.5, radius: float = 30.0,
            forward: float = 1000.0, left: float = 0.0, world: tuple[float, float] = (0.0, 0.0),
            t: float = 0.0) -> SightedMark:
    pixels = Mark(colour, x, y, radius, (radius, radius), 0.0, "circle", 1.0)
    seen = keys.SeenMark(colour=colour, forward_mm=forward, left_mm=left, world_x=world[0],
                         world_y=world[1], x_px=x, radius_px=radius, image_width=W, t=t)
    return SightedMark(pixels, seen)


NORTH = Pose(0.0, 0.0, math.pi / 2)  # at the start, facing +y


def sighting(*marks: SightedMark, t: float = 0.0, pose: Pose = NORTH,
             **fields: object) -> Sighting:
    return replace(Sighting(t=t, now=t, pose=pose, width=W, height=H, marks=marks), **fields)


def test_every_learner_satisfies_the_interface(mission_factory) -> None:
    learners: list[SightingLearner] = [
        HorizonLearning(CameraDetector.for_mission(mission_factory())),
        WheelRatioLearning(lambda: None, PoseHistory()),
        RangeLawLearning(RangeLawLearner(prior=TRUE_LAW))]
    for learner in learners:
        learner.observe(sighting())  # a frame without marks teaches nothing
        assert list(learner.steps) == []


# -- horizon -------------------------------------------------------------------------------------

@pytest.mark.parametrize(("camera", "pitch", "held", "said", "level"), [
    # a camera 8° up, its marks used: the learnt pose moves the band, and says so
    ({}, 8.0, False, "camera pose learnt from 20 sightings: pitch +8.0°", logging.INFO),
    # the same marks all held back (outside the level band): they teach just as well
    ({}, 8.0, True, "camera pose learnt from 20 sightings: pitch +8.0°", logging.INFO),
    # 11° up: near the edge of what is searched while learning, a warning
    ({}, 11.0, False, "the camera looks too far off level: pitched +11.0°", logging.WARNING),
    # a pitch given in the mission: nothing to learn
    ({"pitch_deg": 0.0}, 8.0, False, None, None),
])
def test_horizon_learning(mission_factory, caplog, camera, pitch, held, said, level) -> None:
    learning = HorizonLearning(CameraDetector.for_mission(mission_factory(camera=camera)))
    caplog.set_level(logging.INFO, logger=PERCEPTION_LOG)
    for u, v, d in horizon_sightings(40, pitch=pitch, rise=0.0, roll=0.0):
        mark = sighted(x=u, y=v, forward=d)
        learning.observe(sighting(held_back=(mark,)) if held else sighting(mark))
    if said is None:
        assert learning.steps == [] and caplog.records == []
        return
    assert learning.steps and learning.steps[0].startswith(said)
    first = caplog.records[0]
    assert (first.name, first.levelno, first.getMessage()) == (PERCEPTION_LOG, level,
                                                               learning.steps[0])


# -- wheel ratio ---------------------------------------------------------------------------------

class OdometryRobot:
    """A robot whose odometry can be calibrated (WheelCalibratable), counting its anchors."""

    def __init__(self, pose: Pose) -> None:
        self.odometry = Odometry(Model.CREATE2, pose=pose)
        self.anchors = 0

    def odometry_snapshot(self) -> tuple[Pose, tuple[float, float, float]]:
        return self.odometry.pose, self.odometry.sensitivity()

    def scale_right_wheel(self, factor: float) -> None:
        self.odometry.scale_right_wheel(factor)

    def anchor_odometry(self) -> None:
        self.anchors += 1
        self.odometry.anchor()

    @property
    def right_wheel_scale(self) -> float:
        return self.odometry.right_scale


def weave(learning: WheelRatioLearning, robot: OdometryRobot, true_ratio: float, *,
          with_sensitivity: bool = True) -> None:
    """Weave toward a mark 2.5 m ahead for 6 s, a frame each 50 ms (exact range and bearing),
    the right wheel travelling ``true_ratio`` × what its encoder says."""
    mark = (150.0, 2500.0)
    truth = robot.odometry.pose
    for k in range(120):
        for _ in range(3):
            bias = 0.4 * math.sin(k / 10.0)
            left, right = 3.3 - bias, 3.3 + bias
            truth = integrate_pose(truth, left=left, right=right * true_ratio, dt=1.0,
                                   wheel_base_mm=BASE)
            robot.odometry.advance(left_mm=left, right_mm=right)
        pose, sensitivity = robot.odometry_snapshot()
        learning.poses.add(0.05 * k, pose, sensitivity)
        seen = to_world_frame(pose, to_robot_frame(truth, mark))
        learning.observe(sighting(sighted(world=seen), t=0.05 * k, pose=pose,
                                  sensitivity=sensitivity if with_sensitivity else None))


@pytest.mark.parametrize(("true_ratio", "calibratable", "with_sensitivity", "learns"), [
    (0.955, True, True, True),    # a right wheel 4.5 % short: found and corrected
    (1.045, True, True, True),    # 4.5 % long
    (1.045, False, True, False),  # a robot that cannot be calibrated: left as it is
    (1.045, True, False, False),  # sightings without odometry's sensitivity: nothing to fit
])
def test_wheel_ratio_learning(true_ratio, calibratable, with_sensitivity, learns) -> None:
    robot = OdometryRobot(Pose(0.0, 0.0, math.pi / 2))
    learning = WheelRatioLearning(lambda: robot if calibratable else None, PoseHistory())
    weave(learning, robot, true_ratio, with_sensitivity=with_sensitivity)
    if not learns:
        assert learning.steps == [] and robot.anchors == 0 and robot.right_wheel_scale == 1.0
        return
    assert robot.right_wheel_scale == pytest.approx(true_ratio, abs=0.005)
    assert learning.steps and robot.anchors >= 1
    # the poses driven before the last step no longer depend on the wheel's scale
    last = learning.poses.at(0.05 * 119)
    assert last is not None and last.extra == pytest.approx(robot.odometry.sensitivity())


def test_a_new_window_anchors_odometry_and_zeroes_the_history() -> None:
    robot = OdometryRobot(Pose(0.0, 0.0, math.pi / 2))
    robot.odometry.advance(left_mm=100.0, right_mm=110.0)
    poses = PoseHistory()
    pose, sensitivity = robot.odometry_snapshot()
    poses.add(0.0, pose, sensitivity)
    learning = WheelRatioLearning(lambda: robot, poses)
    learning.observe(sighting(sighted(world=(0.0, 1000.0)), pose=pose, sensitivity=sensitivity))
    at = poses.at(0.0)
    assert robot.anchors == 1 and at is not None and at.extra == (0.0, 0.0, 0.0)
    assert learning.calibrator.samples == 1
    learning.restart()
    assert learning.calibrator.samples == 0


# -- range law -----------------------------------------------------------------------------------

@pytest.mark.parametrize(("mark", "bumped", "learnt"), [
    (sighted(radius=30.0), False, 1),              # whole, in view: one sighting learnt
    (sighted(radius=30.0), True, 0),               # the robot bumped: odometry is not trusted
    (sighted(x=31.0, radius=30.0), False, 0),      # touches the left edge: radius cut
    (sighted(x=W - 32.0, radius=30.0), False, 0),  # touches the right edge
    (sighted(y=H - 32.0, radius=30.0), False, 0),  # touches the bottom edge
    (sighted(y=33.0, radius=30.0), False, 1),      # 3 px inside the top edge: whole
])
def test_range_law_learning_takes_whole_marks_only(mark, bumped, learnt) -> None:
    learning = RangeLawLearning(RangeLawLearner(prior=TRUE_LAW))
    learning.observe(sighting(mark, bumped=bumped))
    assert learning.learner.samples == learnt


class Restarts:
    def __init__(self) -> None:
        self.count = 0

    def restart(self) -> None:
        self.count += 1


@pytest.mark.parametrize(("scale", "restarted"), [
    (1.25, True),   # a law 25 % off: corrected, the wheel window's placements are stale
    (1.0, False),   # the right law: any accepted step moves it by less than 1 %
])
def test_range_law_learning_on_an_approach(scale, restarted) -> None:
    prior = PowerLaw(scale * TRUE_LAW.a, TRUE_LAW.b)
    wheels = Restarts()
    laws: list[PowerLaw] = []
    learning = RangeLawLearning(RangeLawLearner(prior=prior), restarts=[wheels],
                                on_law=laws.append)
    assert learning.model == prior
    for k, y in enumerate(range(0, 1700, 12)):
        forward, left = 2600.0 - y, -150.0
        r = TRUE_LAW.radius_px(forward)
        learning.observe(sighting(sighted(radius=r, forward=forward, left=left), t=0.05 * k,
                                  pose=Pose(0.0, float(y), math.pi / 2)))
    steps = learning.steps
    if restarted:
        assert steps and learning.model == steps[-1].after
        assert learning.model.distance_mm(TRUE_LAW.radius_px(1000.0)) == pytest.approx(
            1000.0, rel=0.05)
        assert len(learning.times) == len(steps) and laws == [s.after for s in steps]
        assert wheels.count == sum(abs(s.change) > LAW_CHANGE_RESTARTS for s in steps) >= 1
    else:
        assert all(abs(s.change) <= LAW_CHANGE_RESTARTS for s in steps)
        assert wheels.count == 0


# -- the leaf ------------------------------------------------------------------------------------

def spy(learner: SightingLearner, seen: list[Sighting]) -> Callable[[Sighting], None]:
    observe = learner.observe

    def recorded(s: Sighting) -> None:
        seen.append(s)
        observe(s)

    return recorded


def test_the_leaf_hands_every_learner_each_new_frame_once_with_the_pose_at_capture(
        blackboard, manual_clock, mission_factory, monkeypatch) -> None:
    """Driving east at 200 mm/s, frames arrive 0.2 s after capture; one repeats its index and
    one tick has no frame. Each learner sees each new frame once, in order, placed with the
    odometry pose at its capture time; the blackboard's marks are the sighting's."""
    dt, late = 0.05, 4  # tick period (s), and a frame's age in ticks
    robot = FakeRobot(clock=manual_clock, pose=Pose(0.0, 0.0, 0.0))
    frames: list[Frame | None] = []
    source = ListSource(frames)
    p = Perception()
    p.setup(robot=robot, clock=manual_clock, mission=mission_factory(), camera=source)
    assert [type(x) for x in p.learners] == [HorizonLearning, WheelRatioLearning,
                                             RangeLawLearning]
    seen: dict[int, list[Sighting]] = {}
    for i, learner in enumerate(p.learners):
        monkeypatch.setattr(learner, "observe", spy(learner, seen.setdefault(i, [])))
    poses: dict[int, Pose] = {}
    published = []
    for k in range(12):
        manual_clock.set(dt * k)
        robot.drive(left=200.0, right=200.0)
        poses[k] = robot.pose()
        index = k - late
        if k < late or k == 9:
            frames.append(None)  # nothing new this tick
        elif k == 10:
            frames.append(frames[-2])  # the previous frame again
        else:
            frames.append(disc_frame(319.5, 40.0, index))
            frames[-1] = Frame(image=frames[-1].image, t=dt * index, index=index)
        source.reads = k
        p.tick_once()
        if frames[-1] is not None and k != 10:
            published.append(p.blackboard.get(keys.MARKS))
    new = [0, 1, 2, 3, 4, 7]  # the frames' indices (tick 9: no frame; tick 10: a repeat)
    for got in seen.values():
        assert [round(s.t / dt) for s in got] == new
        assert got == seen[0]  # the same sighting for each learner
    for s, marks in zip(seen[0], published, strict=True):
        captured = poses[round(s.t / dt)]
        assert (s.pose.x, s.pose.y) == pytest.approx((captured.x, captured.y), abs=1e-6)
        assert s.now == pytest.approx(s.t + late * dt)
        # not the pose when processed: the robot drove 40 mm since
        assert poses[round(s.now / dt)].x - s.pose.x == pytest.approx(200.0 * late * dt, abs=5.0)
        assert tuple(m.seen for m in s.marks) == marks and len(marks) == 1
        assert s.sensitivity is None and not s.bumped  # a FakeRobot: no wheel calibration
