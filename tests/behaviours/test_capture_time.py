"""Capture time: a late frame's marks are placed where the robot was when it was taken, and
staleness is measured between capture times."""

from __future__ import annotations

import math

import py_trees
import pytest
from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.perception import Perception
from marknav.behaviours.target import TargetSeen
from marknav.core.clock import ManualClock
from marknav.planning.kinematics import Pose
from marknav.testing import FakeRobot
from marknav.vision.sources import Frame
from tests.behaviours.test_perception import ListSource, disc_frame

F = 590.0  # the test mission's focal length (px) and mark radius (mm)
R = 100.0


def late_frame_world_x(mission_factory, latency_s: float) -> tuple[float, Pose]:
    """Drive east at 200 mm/s; a frame taken at t = 0 (the mark 1.5 m ahead, 100 mm right)
    arrives ``latency_s`` later. Returns the mark's world x and the odometry pose then."""
    keys.reset()
    clock = ManualClock()
    robot = FakeRobot(clock=clock, pose=Pose(0.0, 0.0, 0.0))  # facing east
    d, right = 1500.0, 100.0
    shot = disc_frame(319.5 + F * right / d, F * R / d, 1)
    frames: list[Frame | None] = [None] * round(latency_s / 0.05) + [
        Frame(image=shot.image, t=0.0, index=1)]
    p = Perception()
    p.setup(robot=robot, clock=clock,
            mission=mission_factory(camera={"learn_range": False}), camera=ListSource(frames))
    for _ in frames:
        robot.drive(left=200.0, right=200.0)
        p.tick_once()
        if p.frames:
            break
        clock.advance(0.05)
    (m,) = p.blackboard.get(keys.MARKS)
    info = p.blackboard.get(keys.FRAME)
    assert info.t == 0.0 and info.latency_s == pytest.approx(latency_s)
    assert m.t == 0.0  # the sighting carries the capture time
    return m.world_x, robot.pose()


@pytest.mark.parametrize("latency_s", [0.2, 0.5])
def test_a_late_frame_places_the_mark_where_it_was_at_capture(blackboard, mission_factory,
                                                               latency_s):
    at_once, _ = late_frame_world_x(mission_factory, 0.0)
    late, pose = late_frame_world_x(mission_factory, latency_s)
    moved = pose.x  # the robot drove this far (east) between capture and processing
    assert moved == pytest.approx(200.0 * latency_s, rel=0.1)
    # The invariant: the same image, however late it is processed, puts the mark at the same
    # place (the pose at its capture time), here 1.5 m east of the start within the range
    # estimate's error; placed with the pose at processing it would be `moved` farther east.
    assert late == pytest.approx(at_once, abs=1.0)
    assert at_once == pytest.approx(1500.0, rel=0.03)


def test_the_report_counts_the_frames_latency(blackboard, manual_clock, mission_factory):
    robot = FakeRobot(clock=manual_clock)
    frames: list[Frame | None] = []
    p = Perception()
    source = ListSource(frames)
    p.setup(robot=robot, clock=manual_clock, mission=mission_factory(), camera=source)
    for k in range(1, 6):
        manual_clock.set(0.1 * k)
        frames.append(Frame(image=disc_frame(319.5, 30.0, k).image, t=0.1 * k - 0.3, index=k))
        source.reads = k - 1
        p.tick_once()
    assert p.latencies == [pytest.approx(0.3)] * 5


def seen_at(t: float) -> keys.SeenMark:
    return keys.SeenMark(colour="red", forward_mm=1000.0, left_mm=0.0, world_x=0.0,
                         world_y=1000.0, x_px=319.5, radius_px=59.0, image_width=640, t=t)


@pytest.mark.parametrize(("newest_frame_t", "status"), [(1.2, Status.SUCCESS),
                                                         (1.55, Status.FAILURE)])
def test_staleness_is_measured_between_capture_times(rig, newest_frame_t, status):
    """Seen in a frame captured at 1.0 s; now 1.6 s; lost after 0.5 s. With frames 0.4 s late,
    the newest (captured 1.2 s) is only 0.2 s newer: the mark is not lost, though 0.6 s passed
    since it was captured. A newest frame captured at 1.55 s without it: lost."""
    rig.clock.set(1.6)
    bb = py_trees.blackboard.Blackboard
    bb.set(keys.TARGET, keys.Target(waypoint=0, waypoint_id="w0", colour="red", side="left",
                                    sighting=seen_at(1.0), world_x=0.0, world_y=1000.0))
    bb.set(keys.FRAME, keys.FrameInfo(index=9, t=newest_frame_t, width=640, height=480,
                                      marks=0, latency_s=1.6 - newest_frame_t))
    node = TargetSeen(lost_after_s=0.5)
    tree = rig.tree(node)
    tree.tick()
    assert node.status == status
    unseen = newest_frame_t - 1.0
    assert node.feedback_message == (f"red #1 seen {unseen:.2f} s ago" if status == Status.SUCCESS
                                     else f"red #1 unseen for {unseen:.2f} s")
    assert math.isclose(keys.unseen_s(seen_at(1.0), None, 1.6), 0.6)  # no frame yet: now
