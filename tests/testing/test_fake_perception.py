"""FakePerception: pinhole pixels, field of view, scripts, camera loss, odometry vs truth."""

import math

import py_trees
import pytest
from py_trees.common import Status

from marknav.behaviours import keys
from marknav.testing import FakePerception, FakeRobot, RobotMark, pinhole_pixels


def _setup(perception, robot, clock, mission):
    perception.setup(robot=robot, clock=clock, mission=mission)
    return perception


def _bb(key):
    return py_trees.blackboard.Blackboard.get(key)


def _marks():
    return _bb(keys.MARKS)


def test_pinhole_pixels():
    x_px, r_px = pinhole_pixels(1000.0, -100.0, focal_px=590.0, radius_mm=100.0,
                                image_width=640)
    assert r_px == pytest.approx(59.0)
    assert x_px == pytest.approx(319.5 + 59.0)  # a mark to the right is right of centre
    with pytest.raises(ValueError):
        pinhole_pixels(0.0, 0.0, focal_px=590.0, radius_mm=100.0, image_width=640)


def test_world_mark_is_seen_with_synthesised_pixels(blackboard, fake_robot, manual_clock,
                                                    mission_factory):
    p = _setup(FakePerception(), fake_robot, manual_clock, mission_factory())
    p.place("red", x_mm=100, y_mm=1000)  # robot at the origin facing +y
    p.tick_once()
    assert p.status == Status.SUCCESS
    (m,) = _marks()
    assert (m.colour, m.forward_mm, m.left_mm) == ("red", pytest.approx(1000.0),
                                                   pytest.approx(-100.0))
    assert m.radius_px == pytest.approx(59.0)
    assert m.pixel_error == pytest.approx(59.0)
    assert (m.world_x, m.world_y) == (pytest.approx(100.0), pytest.approx(1000.0))
    assert _bb(keys.LAST_SEEN)["red"] == m


def test_field_of_view(blackboard, fake_robot, manual_clock, mission_factory):
    p = _setup(FakePerception(), fake_robot, manual_clock, mission_factory())
    half_fov = math.atan(319.5 / 590.0)  # 28.4 degrees to the image edge
    for deg in (-25.0, 25.0):  # disc inside the image
        p.world = []
        p.place("red", x_mm=-2000 * math.sin(math.radians(deg)),
                y_mm=2000 * math.cos(math.radians(deg)))
        p.tick_once()
        assert len(_marks()) == 1, deg
    for deg in (math.degrees(half_fov) - 0.5, 90.0, 180.0):  # centre in view but disc cut, ...
        p.world = []
        p.place("red", x_mm=-2000 * math.sin(math.radians(deg)),
                y_mm=2000 * math.cos(math.radians(deg)))
        p.tick_once()
        assert _marks() == (), deg


def test_script_and_camera_loss(blackboard, fake_robot, manual_clock, mission_factory):
    script = [[RobotMark("green", 1500.0, 200.0)], None, None]
    p = _setup(FakePerception(script=script, camera_timeout_s=0.5), fake_robot, manual_clock,
               mission_factory())
    p.tick_once()
    assert [m.colour for m in _marks()] == ["green"]
    assert _bb(keys.FRAME).index == 0
    statuses = []
    for _ in range(3):  # None, None, then the end of the script: frames again
        manual_clock.advance(0.3)
        p.tick_once()
        statuses.append(p.status)
    assert statuses == [Status.SUCCESS, Status.FAILURE, Status.SUCCESS]
    p.camera_on = False
    manual_clock.advance(0.3)
    p.tick_once()
    assert p.status == Status.SUCCESS
    assert p.feedback_message == "no new frame for 0.30 s"
    manual_clock.advance(0.3)
    p.tick_once()
    assert p.status == Status.FAILURE
    assert p.feedback_message == ("camera lost: no frame for 0.6 s (limit 0.5 s): "
                                  "mission aborted")


def test_visibility_from_true_pose_world_position_from_odometry(blackboard, manual_clock,
                                                                mission_factory):
    robot = FakeRobot(clock=manual_clock, wheel_scale=(1.0, 0.9))
    for _ in range(20):
        robot.drive(left=200, right=200)
        manual_clock.advance(0.05)
    p = _setup(FakePerception(), robot, manual_clock, mission_factory())
    p.place("red", x_mm=0, y_mm=2000)
    p.tick_once()
    (m,) = _marks()
    truth = robot.true_pose
    odo = robot.pose()
    assert truth != odo
    # the estimate is relative to the true pose (what the camera sees) ...
    dx, dy = 0 - truth.x, 2000 - truth.y
    assert m.forward_mm == pytest.approx(dx * math.cos(truth.theta) + dy * math.sin(truth.theta))
    # ... and placed in the world with odometry, as the real perception does
    wx = odo.x + m.forward_mm * math.cos(odo.theta) - m.left_mm * math.sin(odo.theta)
    assert m.world_x == pytest.approx(wx)
    assert m.world_x != pytest.approx(0.0, abs=1.0)


def _in_view_reference(p, pose):
    """FakePerception._in_view as it was before the cull's pixel test was inlined: the cull,
    then pinhole_pixels and _fits."""
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    radius = p.mark_radius_mm
    far = p.focal_px * radius / p.min_radius_px + 1.0
    half = 0.5 * p.image_width / p.focal_px
    out = []
    for w in p.world:
        dx, dy = w.x_mm - pose.x, w.y_mm - pose.y
        forward = c * dx + s * dy
        if forward <= radius or forward > far:
            continue
        left = c * dy - s * dx
        if abs(left) > forward * half + radius + 1.0:
            continue
        x_px, r_px = pinhole_pixels(forward, left, focal_px=p.focal_px, radius_mm=radius,
                                    image_width=p.image_width)
        if p._fits(x_px, r_px):
            out.append((w.colour, forward, left, x_px, r_px))
    return out


@pytest.mark.parametrize("camera", [(590.0, 640, 480, 4.0), (300.0, 320, 240, 2.5),
                                    (800.0, 1280, 720, 6.0)])
def test_in_view_is_bitwise_the_pinhole_and_fit_tests(camera):
    """The inlined pixel test gives exactly the floats (and the marks) of pinhole_pixels and
    _fits, for many poses over a random field of marks."""
    import random

    from marknav.planning.kinematics import Pose

    focal, width, height, min_r = camera
    rng = random.Random(16)
    p = FakePerception(focal_px=focal, image_width=width, image_height=height,
                       min_radius_px=min_r, mark_radius_mm=rng.choice([60.0, 100.0, 150.0]))
    for _ in range(80):
        p.place(rng.choice(["red", "green", "blue"]), x_mm=rng.uniform(-6000, 6000),
                y_mm=rng.uniform(-6000, 6000))
    seen = 0
    for _ in range(3000):
        pose = Pose(rng.uniform(-5000, 5000), rng.uniform(-5000, 5000),
                    rng.uniform(-math.pi, math.pi))
        got = p._in_view(pose)
        assert got == _in_view_reference(p, pose)
        seen += len(got)
    assert seen > 1000  # marks at every edge of the image were compared, not only empty views
