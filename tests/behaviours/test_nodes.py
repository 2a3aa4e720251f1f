"""Registration in the mission registry, the lifecycle rules, and the blackboard contract."""

from __future__ import annotations

import py_trees
import pytest
from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.approach import ApproachWhileCentring
from marknav.behaviours.base import SetupError
from marknav.behaviours.bypass import BezierBypass
from marknav.behaviours.catalogue import builtin_registry
from marknav.behaviours.nodes import register
from marknav.behaviours.route import build_route_tree
from marknav.core.errors import InputError
from marknav.missions.registry import BuildContext, TreeNode, build_tree

TYPES = ["ApproachWhileCentring", "BackOff", "BezierBypass", "BumpRecovery", "NotBumped",
         "Perception", "Route", "SafetyGuard", "SearchWhenLost", "SelectTarget", "TargetLocked",
         "TargetSeen", "Waypoint", "WaypointPassed"]


@pytest.fixture
def registry():
    reg = builtin_registry()
    register(reg)
    return reg


def test_every_behaviour_is_registered(registry):
    assert set(TYPES) <= set(registry.names())
    for name in TYPES:
        assert registry.get(name).kind == "leaf"
        assert registry.get(name).description


def test_a_custom_tree_from_yaml_data(registry, mission_factory, blackboard):
    spec = {"type": "Sequence", "memory": False, "children": [
        {"type": "Perception", "params": {"camera_timeout_s": 2}},
        {"type": "SafetyGuard"},
        {"type": "BumpRecovery", "params": {"distance_mm": 200}},
        {"type": "Sequence", "name": "Route", "memory": True, "children": [
            {"type": "Waypoint", "params": {"colour": "red", "index": 0}},
            {"type": "Waypoint", "name": "Green gate", "params": {"colour": "green"}},
        ]},
        {"type": "ApproachWhileCentring", "params": {"steer_gain": 3, "speed_mm_s": 200}},
        {"type": "BezierBypass", "params": {"clearance_mm": 350}},
    ]}
    node = TreeNode.model_validate(spec, context={"registry": registry})
    mission = mission_factory()
    root = build_tree(node, registry, BuildContext(mission=mission))
    names = [c.name for c in root.children]
    assert names == ["Perception", "SafetyGuard", "BumpRecovery", "Route", "ApproachWhileCentring",
                     "BezierBypass"]
    route = root.children[3]
    assert [w.name for w in route.children] == ["Waypoint 1: red (pass on its left)",
                                                "Green gate"]
    assert root.children[0].camera_timeout_s == 2
    assert root.children[2].children[1].distance_mm == 200
    approach = root.children[4]
    assert isinstance(approach, ApproachWhileCentring) and approach.steer_gain == 3
    bypass = root.children[5]
    assert isinstance(bypass, BezierBypass)
    bypass.setup(mission=mission)
    assert bypass.settings["clearance_mm"] == 350
    assert bypass.settings["lookahead_mm"] == 150  # from the mission


def test_bad_params_are_caught_when_the_mission_loads(registry):
    problems = registry.check({"type": "BezierBypass", "params": {"clearence_mm": 300}})
    assert len(problems) == 1
    assert "did you mean 'clearance_mm'" in problems[0]["type"].message()
    assert registry.check({"type": "Waypoint", "params": {}})  # colour is required
    assert registry.check({"type": "BackOff", "params": {"speed_mm_s": -1}})


def test_an_unknown_colour_is_an_input_error(registry, mission_factory):
    node = TreeNode.model_validate({"type": "Waypoint", "params": {"colour": "purple"}},
                                   context={"registry": registry})
    with pytest.raises(InputError, match=r"colour 'purple' is not in marks.colours"):
        build_tree(node, registry, BuildContext(mission=mission_factory()))


def test_trees_build_and_draw_offline_and_need_setup_to_run(mission_factory, blackboard):
    root = build_route_tree(mission_factory())
    dot = py_trees.display.dot_tree(root).to_string()
    assert "Bypass" in dot and "Waypoint 3: red" in dot
    tree = py_trees.trees.BehaviourTree(root)
    with pytest.raises(SetupError, match="has no clock"):
        tree.tick()
    approach = ApproachWhileCentring()
    with pytest.raises(SetupError, match="no approach speed"):
        approach.setup()
    assert ApproachWhileCentring(speed_mm_s=1, bypass_distance_mm=1,
                                 lost_after_s=1).status == Status.INVALID
    with pytest.raises(ValueError, match="steer_gain must be a positive number"):
        ApproachWhileCentring(steer_gain=0)


def test_reset_clears_every_marknav_key(blackboard):
    bb = py_trees.blackboard.Blackboard
    bb.set(keys.PASSED, ("x",))
    bb.set(keys.RECOVERY, keys.Recovery(count=2))
    bb.set("/other/key", 1)
    assert set(keys.snapshot()) == {keys.PASSED, keys.RECOVERY}
    keys.reset()
    assert keys.snapshot() == {}
    assert bb.get("/other/key") == 1


def test_seen_mark_geometry():
    m = keys.SeenMark(colour="red", forward_mm=1000.0, left_mm=-1000.0, world_x=0.0,
                      world_y=0.0, x_px=379.5, radius_px=10.0, image_width=640, t=0.0)
    assert m.range_mm == pytest.approx(1414.2135)
    assert m.bearing_rad == pytest.approx(-0.7853982)
    assert m.pixel_error == 60.0
