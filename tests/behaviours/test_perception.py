"""Perception: real detector and estimation on synthetic frames, world placement, camera loss."""

from __future__ import annotations

import cv2
import numpy as np
import py_trees
import pytest
from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.perception import Perception
from marknav.behaviours.route import build_route_tree, failure_reason
from marknav.missions.camera import range_model_of
from marknav.planning.kinematics import Pose
from marknav.testing import FakeRobot
from marknav.vision.estimate import Pinhole, PowerLaw
from marknav.vision.sources import Frame


class ListSource:
    """A FrameSource playing a list of frames (None = no frame available)."""

    name = "list"

    def __init__(self, frames: list[Frame | None]) -> None:
        self.frames = frames
        self.reads = 0

    def read(self) -> Frame | None:
        i = min(self.reads, len(self.frames) - 1)
        self.reads += 1
        return self.frames[i]

    def close(self) -> None:
        pass


def disc_frame(x_px: float, radius_px: float, index: int, bgr=(0, 0, 230)) -> Frame:
    img = np.full((480, 640, 3), 120, np.uint8)
    shift = 4  # sub-pixel centre via cv2's fixed-point coordinates
    cv2.circle(img, (round(x_px * 16), round(239.5 * 16)), round(radius_px * 16), bgr, -1,
               cv2.LINE_AA, shift)
    return Frame(image=img, t=index / 30.0, index=index)


def test_range_model_from_the_mission(mission_factory):
    assert range_model_of(mission_factory()) == Pinhole(focal_px=590, radius_mm=100)
    m = mission_factory(camera={"range": {"model": "power", "a": 58958, "b": -0.9434}})
    assert range_model_of(m) == PowerLaw(a=58958, b=-0.9434)


def test_frame_to_marks_in_robot_and_world_frames(blackboard, manual_clock, mission_factory):
    robot = FakeRobot(clock=manual_clock, pose=Pose(500.0, 200.0, 0.0))  # facing +x (east)
    # a red disc 1 m ahead, 100 mm to the right: r = 59 px, centre 59 px right of the middle
    source = ListSource([disc_frame(319.5 + 59.0, 59.0, 0)])
    p = Perception()
    p.setup(robot=robot, clock=manual_clock, mission=mission_factory(), camera=source)
    p.tick_once()
    assert p.status == Status.SUCCESS
    (m,) = p.blackboard.get(keys.MARKS)
    assert m.colour == "red"
    assert m.radius_px == pytest.approx(59.0, abs=1.0)
    assert m.forward_mm == pytest.approx(1000.0, rel=0.02)
    assert m.left_mm == pytest.approx(-100.0, abs=5.0)
    # facing east: forward is +x, the robot's left is +y
    assert m.world_x == pytest.approx(1500.0, abs=20.0)
    assert m.world_y == pytest.approx(100.0, abs=5.0)
    # range_sigma: the range learner's prior σ (camera.learn_range is on by default)
    assert p.blackboard.get(keys.FRAME) == keys.FrameInfo(index=0, t=0.0, width=640,
                                                          height=480, marks=1, range_sigma=0.3)
    assert p.blackboard.get(keys.LAST_SEEN) == {"red": m}
    assert p.feedback_message == f"frame 0: red {m.range_mm / 1000:.2f} m"


def test_a_repeated_frame_is_not_processed_again(blackboard, fake_robot, manual_clock,
                                                 mission_factory):
    source = ListSource([disc_frame(319.5, 40.0, 7)])
    p = Perception()
    p.setup(robot=fake_robot, clock=manual_clock, mission=mission_factory(), camera=source)
    p.tick_once()
    manual_clock.advance(0.05)
    p.tick_once()
    assert p.frames == 1
    assert p.blackboard.get(keys.MARKS)[0].t == 0.0  # the marks keep their time
    # Between frames the latest frame's description stays, with its age (not a warning) ...
    m0 = p.blackboard.get(keys.MARKS)[0]
    assert p.feedback_message == f"frame 7: red {m0.range_mm / 1000:.2f} m (0.05 s ago)"
    manual_clock.advance(0.45)  # ... until half the camera timeout (1 s) has passed
    p.tick_once()
    assert p.feedback_message == "no new frame for 0.50 s"


def test_camera_lost_aborts_the_mission_and_stops_the_wheels(blackboard, fake_robot,
                                                             manual_clock, mission_factory):
    mission = mission_factory(route=["red"])
    frames = [disc_frame(319.5, 25.0, i) for i in range(10)] + [None]
    source = ListSource(frames)
    tree = py_trees.trees.BehaviourTree(build_route_tree(mission))
    tree.setup(robot=fake_robot, clock=manual_clock, mission=mission, camera=source)
    statuses = []
    for _ in range(60):
        tree.tick()
        statuses.append(tree.root.status)
        if tree.root.status != Status.RUNNING:
            break
        manual_clock.advance(0.03)
    # ten frames (the last at t = 0.27 s) driving toward the mark; at t = 1.29 s no frame has
    # come for more than 1 s
    assert statuses[:43] == [Status.RUNNING] * 43
    assert statuses[-1] == Status.FAILURE and len(statuses) == 44
    assert manual_clock.now() == pytest.approx(1.29)
    why = failure_reason(tree.root)
    assert why is not None and why.aborted
    assert why.reason == ("Perception: camera lost: no frame for 1.0 s (limit 1 s): "
                          "mission aborted")
    assert any(c.left > 0 and c.right > 0 for c in fake_robot.commands)  # it was driving
    assert fake_robot.wheels == (0, 0)
    # Held from the first tick more than lost_after_s (0.5 s) after the last frame: Approach was
    # stopped then (its terminate zeroed the wheels) and nothing drove afterwards — no search
    # turn on old frames.
    assert fake_robot.commands[-1].t == pytest.approx(0.78)
    assert (fake_robot.commands[-1].left, fake_robot.commands[-1].right) == (0, 0)


def test_a_stalled_camera_holds_the_route_until_frames_come_back(
        blackboard, fake_robot, manual_clock, mission_factory):
    mission = mission_factory(route=["red"])
    frames = ([disc_frame(319.5, 25.0, i) for i in range(5)] + [None] * 25
              + [disc_frame(319.5, 25.0, 100 + i) for i in range(40)])
    tree = py_trees.trees.BehaviourTree(build_route_tree(mission))
    tree.setup(robot=fake_robot, clock=manual_clock, mission=mission, camera=ListSource(frames))
    perception = next(n for n in tree.root.iterate() if n.name == "Perception")
    held = []
    for _ in range(len(frames)):
        tree.tick()
        assert tree.root.status == Status.RUNNING
        if perception.status == Status.RUNNING:
            held.append(manual_clock.now())
            assert fake_robot.wheels == (0, 0)
            assert perception.feedback_message.startswith("holding: no new frame for")
        manual_clock.advance(0.03)
    # frames at 0 … 0.12 s, none until 0.90 s: held from 0.63 s (silent > 0.5 s) to 0.87 s
    assert held == pytest.approx([0.03 * i for i in range(21, 30)])
    assert not any(c.left * c.right < 0 for c in fake_robot.commands)  # never a search turn
    assert fake_robot.commands[-1].left > 0 and fake_robot.commands[-1].right > 0  # driving again


def test_no_camera_is_a_setup_error(blackboard, fake_robot, manual_clock, mission_factory):
    p = Perception()
    p.setup(robot=fake_robot, clock=manual_clock, mission=mission_factory())
    with pytest.raises(RuntimeError, match="no camera"):
        p.tick_once()
