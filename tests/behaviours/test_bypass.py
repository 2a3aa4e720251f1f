"""BezierBypass: passes on the required side with the clearance, records it, re-plans."""

from __future__ import annotations

import itertools
import math

import py_trees
import pytest
from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.bypass import EXIT_MARGIN_MM, BezierBypass
from marknav.behaviours.target import SelectTarget
from marknav.planning.kinematics import Pose, to_robot_frame
from marknav.testing import FakeRobot, RobotMark

#: Robot radius + mark radius + margin (the default mission's values).
RUN_OUT_MM = 165.0 + 100.0 + EXIT_MARGIN_MM


def bypass_tree(rig, colour="red", **kwargs):
    kwargs.setdefault("margin_mm", 0.0)  # plan at exactly the clearance unless a test says
    node = BezierBypass(**kwargs)
    pass_ = py_trees.composites.Sequence("Pass", memory=True, children=[
        SelectTarget(colour=colour, waypoint=0), node])
    root = py_trees.composites.Sequence("Root", memory=False, children=[rig.perception, pass_])
    return rig.tree(root), node


def true_clearance(rig, mark):
    return min(math.hypot(p.x - mark[0], p.y - mark[1]) for _, p in rig.robot.trajectory)


@pytest.mark.parametrize(("colour", "side"), [("red", "left"), ("green", "right")])
def test_passes_on_the_required_side_and_records_it(rig, colour, side):
    rig.perception.place(colour, x_mm=50, y_mm=800)  # at the bypass threshold, a bit right
    tree, node = bypass_tree(rig, colour)
    log = rig.run(tree, max_ticks=200)
    assert log.reached, log
    pose = rig.robot.true_pose
    # The curve ends beside the mark; the run-out goes on until the mark is robot radius + mark
    # radius + EXIT_MARGIN_MM behind, so a turn toward the next mark cannot clip it.
    assert pose.y == pytest.approx(800.0 + RUN_OUT_MM, abs=15.0)
    if side == "left":  # passed on the mark's left: the robot is west of it
        assert pose.x == pytest.approx(50.0 - 300.0, abs=10.0)
    else:
        assert pose.x == pytest.approx(50.0 + 300.0, abs=10.0)
    assert true_clearance(rig, (50.0, 800.0)) >= 300.0 - 30.0
    (passed,) = rig.bb(keys.PASSED)
    assert (passed.waypoint, passed.colour, passed.side) == (0, colour, side)
    assert (passed.mark_x, passed.mark_y) == (pytest.approx(50.0), pytest.approx(800.0))
    (plan,) = rig.bb(keys.PLANS)
    assert (plan.reason, plan.colour, plan.plan.side) == ("initial", colour, side)
    assert plan.plan.min_clearance_mm == pytest.approx(300.0, abs=1e-6)
    assert rig.bb(keys.TARGET).locked
    assert node.feedback_message.startswith(f"passed {colour} #1 on its {side} (")
    assert rig.robot.wheels == (0, 0)
    assert log.visited("Root/Pass/Bypass")


def test_an_impossible_bypass_fails_with_the_planner_reason(rig):
    rig.perception.place("red", x_mm=0, y_mm=350)  # 350 mm ahead, clearance 300
    tree, node = bypass_tree(rig)
    log = rig.run(tree, Status.FAILURE, max_ticks=3)
    assert log.reached and log.ticks == 1
    assert node.feedback_message.startswith("cannot bypass red #1: mark too close ahead")
    assert rig.bb(keys.PLANS, ()) == ()
    assert rig.robot.wheels == (0, 0)


def test_a_mark_already_beside_on_the_right_side_counts_as_passed(rig):
    py_trees.blackboard.Blackboard.set(keys.TARGET, keys.Target(
        waypoint=0, waypoint_id="waypoint-0-red", colour="red", side="left",
        world_x=320.0, world_y=-20.0))  # on the robot's right, just behind
    tree, node = bypass_tree(rig)
    tree.tick()
    assert node.status == Status.SUCCESS
    assert [p.colour for p in rig.bb(keys.PASSED)] == ["red"]


def biased_camera(rig, mark):
    """Sees ``mark`` from the true pose with a range error growing with distance (8 % at
    800 mm, 4 % at 400 mm), as monocular range estimates do."""

    def script(tick, t):
        forward, left = to_robot_frame(rig.robot.true_pose, mark)
        if not rig.perception.visible(forward, left):
            return []
        k = 1.0 + math.hypot(forward, left) / 10000.0
        return [RobotMark("red", forward * k, left * k)]

    return script


def test_replans_on_a_closer_sighting(rig):
    mark = (150.0, 800.0)
    rig.perception.script = biased_camera(rig, mark)
    tree, node = bypass_tree(rig)
    log = rig.run(tree, max_ticks=200)
    assert log.reached
    plans = rig.bb(keys.PLANS)
    assert next(p.reason for p in plans) == "initial"
    assert node.replans == len(plans) - 1 >= 2
    assert all(p.plan.course == plans[0].plan.course for p in plans)  # same course kept
    errors = [math.dist(p.plan.mark_xy, mark) for p in plans]
    assert errors[0] > 60.0  # the first estimate, from 850 mm, is 8 % long
    assert all(a > b for a, b in itertools.pairwise(errors))  # closer is better
    assert errors[-1] < 0.7 * errors[0]
    # the curve ends beside the last estimate: 45 mm past the true mark instead of 66 mm
    # (then the straight run-out, which is the same length whatever the estimate)
    assert rig.robot.true_pose.y - mark[1] - RUN_OUT_MM < 50.0
    assert true_clearance(rig, mark) >= 300.0 - 30.0


def test_without_replanning_the_first_estimate_stands(rig):
    mark = (150.0, 800.0)
    rig.perception.script = biased_camera(rig, mark)
    tree, node = bypass_tree(rig, replan_ratio=0.01)
    assert rig.run(tree, max_ticks=200).reached
    assert [p.reason for p in rig.bb(keys.PLANS)] == ["initial"]
    assert node.replans == 0
    assert math.dist(rig.bb(keys.PLANS)[0].plan.mark_xy, mark) > 60.0
    # the curve ends beside the 8 % long estimate
    assert rig.robot.true_pose.y - mark[1] - RUN_OUT_MM > 60.0


@pytest.mark.parametrize(("recoveries", "planned"), [(0, 340.0), (1, 400.0), (2, 460.0)])
def test_plans_with_the_drift_margin_widened_after_each_bump(rig, recoveries, planned):
    # mission default: clearance 300 + bypass_margin_mm 40, + RECOVERY_WIDENING_MM per recovery
    py_trees.blackboard.Blackboard.set(keys.RECOVERY, keys.Recovery(count=recoveries))
    rig.perception.place("red", x_mm=50, y_mm=1000)
    tree, node = bypass_tree(rig, margin_mm=None)
    tree.tick()
    (plan,) = rig.bb(keys.PLANS)
    assert plan.plan.min_clearance_mm == pytest.approx(planned, abs=1e-6)
    assert node.planned_clearance_mm() == pytest.approx(planned)


# -- the two ways a bypass fails after it started ---------------------------------------------


class CarriedRobot(FakeRobot):
    """A fake robot that can be picked up and put down elsewhere (a pose jump: carried by a
    person, or odometry re-anchored to a new fix); odometry follows the jump."""

    def carry_to(self, pose: Pose) -> None:
        self.sync()
        self._odometry = self._true = pose
        self.trajectory.append((self.clock.now(), pose))


def test_a_mark_that_ends_up_on_the_wrong_side_fails_the_bypass(rig):
    rig.robot = CarriedRobot(clock=rig.clock)
    rig.perception.place("red", x_mm=50, y_mm=800)  # pass on its left: the robot goes west
    tree, node = bypass_tree(rig)
    statuses = [tick(rig, tree) for _ in range(20)]  # one second into the bypass
    assert statuses == [Status.RUNNING] * 20
    assert rig.robot.pose().x < 0.0  # swerving west, as planned
    # Carried to the east of the mark, already past it by the run-out: the mark is behind the
    # robot (the bypass would be over) but on the robot's left, the side it must not be on.
    rig.robot.carry_to(Pose(250.0, 800.0 + RUN_OUT_MM, math.pi / 2))
    assert tick(rig, tree) == Status.FAILURE
    assert node.status == Status.FAILURE
    assert node.feedback_message == "red #1 ended up on the wrong side (+200 mm to the left)"
    assert rig.bb(keys.PASSED, ()) == ()  # not recorded as passed
    assert rig.robot.wheels == (0, 0)


def test_the_same_jump_to_the_right_side_counts_as_passed(rig):
    # the control case of the test above: carried west of the mark instead, the bypass succeeds
    rig.robot = CarriedRobot(clock=rig.clock)
    rig.perception.place("red", x_mm=50, y_mm=800)
    tree, node = bypass_tree(rig)
    for _ in range(20):
        tick(rig, tree)
    rig.robot.carry_to(Pose(-150.0, 800.0 + RUN_OUT_MM, math.pi / 2))
    assert tick(rig, tree) == Status.SUCCESS
    assert [(p.colour, p.side) for p in rig.bb(keys.PASSED)] == [("red", "left")]
    assert node.feedback_message == "passed red #1 on its left (200 mm beside it)"


def test_a_bypass_that_cannot_keep_up_fails_at_its_deadline(rig):
    # Wheels that only turn at 25 mm/s (a stalling drive, a robot pushing against something
    # soft): the plan wants 200 mm/s, so the bypass takes eight times as long as planned. It must
    # give up at 3 × length / speed + 5 s, not drive on for ever.
    rig.robot = FakeRobot(clock=rig.clock, max_wheel_mm_s=25)
    rig.perception.place("red", x_mm=50, y_mm=800)
    tree, node = bypass_tree(rig)
    dt = 0.1
    assert tick(rig, tree, dt) == Status.RUNNING
    (record,) = rig.bb(keys.PLANS)
    speed = 0.8 * rig.mission.navigation.approach_speed_mm_s
    budget = 3.0 * record.plan.length_mm / speed + 5.0
    assert 15.0 < budget < 30.0
    statuses = [Status.RUNNING]
    while statuses[-1] == Status.RUNNING and len(statuses) < 1000:
        statuses.append(tick(rig, tree, dt))
    failed_at = rig.clock.now() - record.t
    # RUNNING tick by tick up to the deadline, FAILURE on the first tick after it
    assert statuses[-1] == Status.FAILURE
    assert set(statuses[:-1]) == {Status.RUNNING}
    assert budget < failed_at <= budget + dt + 1e-9
    assert node.feedback_message == f"bypass of red #1 did not finish in {failed_at:.1f} s"
    assert rig.bb(keys.PASSED, ()) == ()
    assert rig.robot.wheels == (0, 0)
    # it was moving all along, just too slowly: not half way along the plan
    assert 0.0 < rig.robot.pose().y < 0.5 * (800.0 + RUN_OUT_MM)


def tick(rig, tree, dt=0.05):
    rig.clock.advance(dt)
    tree.tick()
    return tree.root.status
