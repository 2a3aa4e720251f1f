"""SafetyGuard, bump recovery and preemption of the running behaviour, in the route tree."""

from __future__ import annotations

import pytest
from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.bypass import BezierBypass
from marknav.behaviours.route import build_route_tree, failure_reason
from marknav.behaviours.safety import BackOff, SafetyGuard
from marknav.testing import FakeRobot, active_path

from .conftest import tick_while


def nodes_of(root, cls):
    return [n for n in root.iterate() if isinstance(n, cls)]


def route_tree(rig, route=("red",), marks=(("red", 0.0, 1500.0),)):
    for colour, x, y in marks:
        rig.perception.place(colour, x_mm=x, y_mm=y)
    rig.mission = rig.mission.model_copy(update={"route": list(route)})
    return rig.tree(build_route_tree(rig.mission, perception=rig.perception))


def test_safety_guard_reports_the_fault_reason(blackboard, manual_clock):
    robot = FakeRobot(clock=manual_clock)
    guard = SafetyGuard()
    guard.setup(robot=robot, clock=manual_clock)
    guard.tick_once()
    assert (guard.status, guard.feedback_message) == (Status.SUCCESS, "ready")
    robot.set_sensors(cliff_front_left=True)
    guard.tick_once()
    assert (guard.status, guard.feedback_message) == (Status.FAILURE, "cliff front left")
    robot.set_sensors(cliff_front_left=False)
    robot.reset()
    robot.estop("operator")
    guard.tick_once()
    assert (guard.status, guard.feedback_message) == (Status.FAILURE, "e-stop: operator")
    offline = SafetyGuard()
    offline.setup(robot=FakeRobot(clock=manual_clock, connect=False), clock=manual_clock)
    offline.tick_once()
    assert (offline.status, offline.feedback_message) == (Status.FAILURE, "robot disconnected")


def test_a_bump_preempts_the_running_bypass_on_that_very_tick(rig):
    tree = route_tree(rig)
    bypass = nodes_of(tree.root, BezierBypass)[0]
    tick_while(rig, tree, lambda: bypass.status == Status.RUNNING)
    for _ in range(5):  # well into the curve
        rig.clock.advance(0.05)
        tree.tick()
    assert rig.robot.wheels[0] > 0 and rig.robot.wheels[1] > 0
    n_before = len(rig.robot.commands)
    rig.robot.bump(left=True, right=False)
    bump_t = rig.clock.now()
    tree.tick()  # same clock time: the very next tick
    assert bypass.status == Status.INVALID  # halted, terminate() ran
    assert active_path(tree.root) == "Mission/BumpRecovery/BackOff"
    after = rig.robot.commands[n_before:]
    # the safety layer zeroed the wheels on the bump frame, then BackOff reversed; no forward
    # command reached the wheels after the bump
    assert [(c.t, c.left, c.right) for c in after] == [(bump_t, 0, 0), (bump_t, -150, -150)]
    assert rig.bb(keys.DRIVER).name == "BackOff"  # so the bypass's terminate left them alone


def test_a_fault_aborts_at_once_and_the_bypass_stops_the_wheels(rig):
    tree = route_tree(rig)
    bypass = nodes_of(tree.root, BezierBypass)[0]
    tick_while(rig, tree, lambda: bypass.status == Status.RUNNING)
    rig.clock.advance(0.05)
    rig.robot.lose_link("USB unplugged")  # the layer latches fault; the wheels were driving
    n_requests = len(rig.robot.requests)
    tree.tick()
    assert tree.root.status == Status.FAILURE
    assert bypass.status == Status.INVALID
    why = failure_reason(tree.root)
    assert why is not None and why.aborted
    assert why.reason == "SafetyGuard: serial link lost: USB unplugged"
    assert why.path == "Mission/SafetyGuard"
    assert [r.kind for r in rig.robot.requests[n_requests:]] == ["stop"]  # from terminate()
    assert rig.robot.wheels == (0, 0)


def test_terminate_is_idempotent_and_only_stops_its_own_driving(rig):
    tree = route_tree(rig)
    bypass = nodes_of(tree.root, BezierBypass)[0]
    tick_while(rig, tree, lambda: bypass.status == Status.RUNNING)
    n = len(rig.robot.requests)
    bypass.stop(Status.INVALID)
    bypass.stop(Status.INVALID)  # a parent may halt it again
    assert [r.kind for r in rig.robot.requests[n:]] == ["stop"]
    assert rig.bb(keys.DRIVER) is None


def test_bump_recovery_backs_off_then_the_route_resumes(rig):
    tree = route_tree(rig, marks=(("red", 0.0, 2500.0),))
    tick_while(rig, tree, lambda: rig.robot.pose().y > 500.0)
    rig.robot.bump()
    y_bump = rig.robot.pose().y
    backoff = nodes_of(tree.root, BackOff)[0]
    tree.tick()
    assert backoff.status == Status.RUNNING
    rig.clock.advance(0.1)
    rig.robot.release_bump()  # the bumper springs back as soon as the robot reverses
    ticks = tick_while(rig, tree, lambda: backoff.status == Status.SUCCESS)
    assert ticks == 20  # 150 mm at 150 mm/s: 1 s
    assert y_bump - rig.robot.pose().y == pytest.approx(150.0, abs=8.0)
    assert backoff.feedback_message.startswith("backed off 15")
    assert backoff.feedback_message.endswith("(recovery 1 of 2)")
    recovery = rig.bb(keys.RECOVERY)
    assert (recovery.count, recovery.active) == (1, False)
    # the route took over in that same tick and goes on to pass the mark
    assert "Waypoint 1: red" in active_path(tree.root)
    log = rig.run(tree, max_ticks=400)
    assert log.reached
    assert [p.colour for p in rig.bb(keys.PASSED)] == ["red"]


def test_too_many_bumps_abort_the_mission(rig):
    tree = route_tree(rig, marks=(("red", 0.0, 4000.0),))
    backoff = nodes_of(tree.root, BackOff)[0]
    for n in (1, 2):
        tick_while(rig, tree, lambda: "Approach" in active_path(tree.root))
        rig.robot.bump()
        tree.tick()
        rig.robot.release_bump()
        tick_while(rig, tree, lambda: backoff.status == Status.SUCCESS)
        assert rig.bb(keys.RECOVERY).count == n
    tick_while(rig, tree, lambda: "Approach" in active_path(tree.root))
    rig.robot.bump()
    tree.tick()
    assert tree.root.status == Status.FAILURE
    why = failure_reason(tree.root)
    assert why is not None and why.aborted
    assert why.reason == "BackOff: bumped 3 times (max_bump_recoveries 2): mission aborted"
    assert rig.robot.wheels == (0, 0)
    assert not rig.bb(keys.RECOVERY).active
