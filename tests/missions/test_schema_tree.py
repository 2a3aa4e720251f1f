"""The optional ``tree:`` section: checked against the node registry at load time with
line-numbered errors, and built into the right py_trees structure."""

from __future__ import annotations

import sys
import types
from pathlib import Path

import py_trees
import pytest
from py_trees.common import OneShotPolicy, ParallelPolicy, Status
from pydantic import BaseModel, ConfigDict, Field

from marknav.behaviours import builtin_nodes, catalogue
from marknav.behaviours.catalogue import builtin_registry
from marknav.behaviours.pause import Pause, Timeout
from marknav.core.clock import ManualClock
from marknav.core.errors import InputError, InputErrors
from marknav.missions import plugins as plugins_module
from marknav.missions.plugins import default_registry
from marknav.missions.registry import (
    BuildContext,
    NodeRegistry,
    NoParams,
    TreeNode,
    build_tree,
)
from marknav.missions.schema import load_mission

HEAD = """\
name: t
route: [red]
marks:
  colours:
    red: {hue: [170, 10], side: left}
"""  # 5 lines: the tree starts on line 6


def write(tmp_path: Path, tree: str) -> Path:
    path = tmp_path / "m.yaml"
    path.write_text(HEAD + tree, encoding="utf-8")
    return path


def tree_errors(tmp_path: Path, tree: str, registry: NodeRegistry | None = None) -> list[str]:
    path = write(tmp_path, tree)
    with pytest.raises(InputError) as exc:
        load_mission(path, registry)
    return [line.replace(str(path), "M") for line in str(exc.value).splitlines()]


MEMORY_HELP = ("needs 'memory: true' (resume at the running child) or 'memory: false' "
               "(restart from the first child every tick)")


# --- errors ---------------------------------------------------------------------------------


def test_unknown_node_type_with_did_you_mean(tmp_path: Path) -> None:
    tree = """\
tree:
  type: Sequence
  memory: true
  children:
    - type: Success
    - type: Sequnce
      memory: false
      children: [{type: Success}]
"""
    assert tree_errors(tmp_path, tree) == [
        "M:11:13: tree.children[1].type: unknown node type 'Sequnce'; did you mean 'Sequence'?"
    ]


def test_unknown_node_type_without_a_close_match_lists_the_types(tmp_path: Path) -> None:
    errors = tree_errors(tmp_path, "tree: {type: Zzz}\n")
    assert errors == [
        "M:6:14: tree.type: unknown node type 'Zzz' (known: "
        + ", ".join(default_registry().names()) + ")"
    ]


def test_missing_memory_on_a_sequence(tmp_path: Path) -> None:
    tree = """\
tree:
  type: Selector
  memory: false
  children:
    - type: Sequence
      children: [{type: Success}]
"""
    assert tree_errors(tmp_path, tree) == [
        f"M:10:7: tree.children[0].memory: Sequence {MEMORY_HELP}"]


def test_bad_params_for_a_decorator(tmp_path: Path) -> None:
    tree = """\
tree:
  type: Sequence
  memory: true
  children:
    - type: Retry
      params: {num_failures: 0}
      child: {type: Failure}
    - type: Retry
      params: {num_failure: 3}
      child: {type: Failure}
    - type: Timeout
      child: {type: Running}
    - type: Repeat
      params: {num_success: 0}
      child: {type: Success}
    - type: Inverter
      params: {n: 1}
      child: {type: Success}
"""
    assert tree_errors(tmp_path, tree) == [
        "M:11:30: tree.children[0].params.num_failures: Input should be greater than or equal "
        "to 1",
        "M:14:15: tree.children[1].params.num_failures: Field required",
        "M:14:16: tree.children[1].params.num_failure: unknown key 'num_failure'; did you mean "
        "'num_failures'?",
        "M:16:7: tree.children[2].params.duration: Field required",
        "M:19:29: tree.children[3].params.num_success: num_success must be at least 1, or -1 to "
        "repeat for ever",
        "M:22:16: tree.children[4].params.n: unknown key 'n' (Inverter takes no params)",
    ]


def test_shape_errors(tmp_path: Path) -> None:
    tree = """\
tree:
  type: Parallel
  memory: true
  children:
    - type: Timeout
      params: {duration: 1}
      children: [{type: Running}]
    - {type: Inverter}
    - type: Sequence
      memory: true
      policy: success_on_all
      child: {type: Success}
    - {type: Selector, memory: true, children: []}
    - {type: Success, child: {type: Failure}}
"""
    assert tree_errors(tmp_path, tree) == [
        "M:7:3: tree.policy: Parallel needs 'policy: success_on_all' or 'policy: success_on_one'",
        "M:8:11: tree.memory: 'memory' applies only to Sequence and Selector, not Parallel",
        "M:12:17: tree.children[0].children: Timeout is a decorator: give it one 'child', not "
        "'children'",
        "M:13:7: tree.children[1].child: Inverter is a decorator: it needs one 'child' node",
        "M:16:15: tree.children[2].policy: 'policy' applies only to Parallel, not Sequence",
        "M:17:14: tree.children[2].child: Sequence takes a list of 'children', not one 'child'",
        "M:18:48: tree.children[3].children: Selector needs at least one child",
        "M:19:30: tree.children[4].child: Success is a behaviour (a leaf): it takes no 'child'",
    ]


def test_structure_errors_come_from_the_node_model(tmp_path: Path) -> None:
    tree = """\
tree:
  type: Sequence
  memory: maybe
  childs: []
  children: [{type: Success, nmae: x}]
"""
    assert tree_errors(tmp_path, tree) == [
        "M:8:11: tree.memory: Input should be a valid boolean, unable to interpret input",
        "M:9:3: tree.childs: unknown key 'childs'; did you mean 'child'?",
        "M:10:30: tree.children[0].nmae: unknown key 'nmae'; did you mean 'name'?",
    ]


def test_parent_and_child_errors_are_reported_together(tmp_path: Path) -> None:
    tree = """\
tree:
  type: Sequence
  children:
    - {type: Pause, params: {seconds: -1}}
    - {type: Succes}
"""
    assert tree_errors(tmp_path, tree) == [
        f"M:7:3: tree.memory: Sequence {MEMORY_HELP}",
        "M:9:39: tree.children[0].params.seconds: Input should be greater than or equal to 0",
        "M:10:14: tree.children[1].type: unknown node type 'Succes'; did you mean 'Success'?",
    ]


def test_tree_errors_and_other_errors_are_reported_together(tmp_path: Path) -> None:
    path = tmp_path / "m.yaml"
    path.write_text(HEAD.replace("route: [red]", "route: [red, bleu]")
                    + "tree: {type: Sequnce, memory: true, children: [{type: Success}]}\n")
    with pytest.raises(InputErrors) as exc:
        load_mission(path)
    assert [str(e).replace(str(path), "M") for e in exc.value.errors] == [
        "M:2:14: route[1]: colour 'bleu' is not defined in marks.colours (colours: red)",
        "M:6:14: tree.type: unknown node type 'Sequnce'; did you mean 'Sequence'?",
    ]


# --- building ---------------------------------------------------------------------------------

CUSTOM = """\
tree:
  type: Selector
  name: Root
  memory: false
  children:
    - type: Sequence
      name: Wait then go
      memory: true
      children:
        - {type: Pause, params: {seconds: 1.5}}
        - type: Retry
          params: {num_failures: 3}
          child: {type: Success, name: Go}
    - type: Parallel
      policy: success_on_one
      children:
        - type: Timeout
          params: {duration: 2}
          child: {type: Running}
        - {type: TickCounter, params: {ticks: 3, then: failure}}
    - type: OneShot
      params: {policy: on_completion}
      child: {type: Inverter, child: {type: Failure}}
"""


def test_custom_tree_builds_the_right_structure(tmp_path: Path) -> None:
    # py_trees' own node types only (marknav's registry would ask for the route's Waypoints)
    mission = load_mission(write(tmp_path, CUSTOM), builtin_registry())
    assert mission.tree is not None
    root = build_tree(mission.tree, mission.registry, BuildContext(mission=mission))

    assert type(root) is py_trees.composites.Selector
    assert (root.name, root.memory) == ("Root", False)
    seq, par, oneshot = root.children

    assert type(seq) is py_trees.composites.Sequence
    assert (seq.name, seq.memory) == ("Wait then go", True)
    pause, retry = seq.children
    assert type(pause) is Pause and (pause.name, pause.seconds) == ("Pause", 1.5)
    assert type(retry) is py_trees.decorators.Retry
    assert (retry.name, retry.num_failures) == ("Retry", 3)
    assert type(retry.decorated) is py_trees.behaviours.Success and retry.decorated.name == "Go"

    assert type(par) is py_trees.composites.Parallel and par.name == "Parallel"
    assert type(par.policy) is ParallelPolicy.SuccessOnOne
    timeout, counter = par.children
    assert type(timeout) is Timeout and timeout.duration == 2.0
    assert type(timeout.decorated) is py_trees.behaviours.Running
    assert type(counter) is py_trees.behaviours.TickCounter
    assert (counter.duration, counter.completion_status) == (3, Status.FAILURE)

    assert type(oneshot) is py_trees.decorators.OneShot
    assert oneshot.policy is OneShotPolicy.ON_COMPLETION
    inverter = oneshot.decorated
    assert type(inverter) is py_trees.decorators.Inverter
    assert type(inverter.decorated) is py_trees.behaviours.Failure

    # Every node has its parent set: it is one tree.
    assert [n.name for n in root.iterate()] == [
        "Pause", "Go", "Retry", "Wait then go", "Running", "Timeout", "TickCounter", "Parallel",
        "Failure", "Inverter", "OneShot", "Root"]


def test_parallel_default_policy_and_memoryless_sequence() -> None:
    spec = TreeNode.model_validate({
        "type": "Parallel", "policy": "success_on_all",
        "children": [{"type": "Sequence", "memory": False, "children": [{"type": "Success"}]}],
    })
    root = build_tree(spec, default_registry())
    assert isinstance(root, py_trees.composites.Parallel)
    assert type(root.policy) is ParallelPolicy.SuccessOnAll
    sequence = root.children[0]
    assert isinstance(sequence, py_trees.composites.Sequence) and sequence.memory is False


def test_pause_runs_on_the_mission_clock() -> None:
    clock = ManualClock(100.0)
    spec = TreeNode.model_validate({
        "type": "Sequence", "memory": True,
        "children": [{"type": "Pause", "params": {"seconds": 1.5}}, {"type": "Success"}],
    })
    tree = py_trees.trees.BehaviourTree(build_tree(spec, default_registry()))
    tree.setup(clock=clock)
    tree.tick()
    assert tree.root.status is Status.RUNNING
    clock.advance(1.49)
    tree.tick()
    assert tree.root.status is Status.RUNNING
    clock.advance(0.01)
    tree.tick()
    assert tree.root.status is Status.SUCCESS
    assert [c.status for c in tree.root.children] == [Status.SUCCESS, Status.SUCCESS]


def test_timeout_fails_its_running_child_on_the_mission_clock() -> None:
    clock = ManualClock()
    spec = TreeNode.model_validate(
        {"type": "Timeout", "params": {"duration": 2}, "child": {"type": "Running"}})
    tree = py_trees.trees.BehaviourTree(build_tree(spec, default_registry()))
    tree.setup(clock=clock)
    tree.tick()
    clock.advance(1.999)
    tree.tick()
    assert tree.root.status is Status.RUNNING
    clock.advance(0.001)
    tree.tick()
    assert tree.root.status is Status.FAILURE
    assert tree.root.decorated.status is Status.INVALID
    assert tree.root.feedback_message == "timed out after 2 s"


def test_timeout_passes_a_finished_child_through() -> None:
    clock = ManualClock()
    node = Timeout("T", py_trees.behaviours.Failure("F"), 5.0, clock=clock)
    node.tick_once()
    assert node.status is Status.FAILURE


def test_timers_without_a_clock_say_so() -> None:
    pause = Pause("Wait", 1.0)
    with pytest.raises(RuntimeError, match=r"Pause 'Wait' has no clock: set up the tree with "
                       r"tree.setup\(clock=...\)"):
        pause.tick_once()
    with pytest.raises(TypeError, match=r"needs a marknav\.core\.clock\.Clock"):
        pause.setup(clock="now")
    with pytest.raises(ValueError, match="Timeout duration must be a finite number of seconds > 0"):
        Timeout("T", py_trees.behaviours.Success("S"), 0.0)


# --- registry ---------------------------------------------------------------------------------


class WaveParams(BaseModel):
    """Wave the robot's arms."""

    model_config = ConfigDict(extra="forbid")
    times: int = Field(ge=1)


class Wave(py_trees.behaviour.Behaviour):
    def __init__(self, name: str, times: int, mission_name: str) -> None:
        super().__init__(name)
        self.times = times
        self.mission_name = mission_name

    def update(self) -> Status:
        return Status.SUCCESS


def _wave(name: str, params: WaveParams, context: BuildContext) -> Wave:
    assert context.mission is not None
    return Wave(name, params.times, context.mission.name)


def with_wave() -> NodeRegistry:
    reg = builtin_registry()
    reg.register("Wave", _wave, WaveParams)
    return reg


def test_registered_leaf_is_checked_and_built(tmp_path: Path) -> None:
    reg = with_wave()
    tree = "tree: {type: Sequence, memory: true, children: [{type: Wave, params: {times: 2}}]}\n"
    mission = load_mission(write(tmp_path, tree), reg)
    assert mission.tree is not None
    root = build_tree(mission.tree, reg, BuildContext(mission=mission))
    wave = root.children[0]
    assert type(wave) is Wave and (wave.name, wave.times, wave.mission_name) == ("Wave", 2, "t")

    assert tree_errors(tmp_path, tree.replace("times: 2", "times: 0"), reg) == [
        "M:6:78: tree.children[0].params.times: Input should be greater than or equal to 1"
    ]
    # Not in the default registry.
    assert tree_errors(tmp_path, tree) == [
        "M:6:56: tree.children[0].type: unknown node type 'Wave' (known: "
        + ", ".join(default_registry().names()) + ")"
    ]


def test_build_rechecks_against_its_registry_with_file_positions(tmp_path: Path) -> None:
    path = write(tmp_path, "tree:\n  type: Wave\n  params: {times: 1}\n")
    mission = load_mission(path, with_wave())
    assert mission.tree is not None
    reg = builtin_registry()
    reg.register("Wove", _wave, WaveParams)
    with pytest.raises(InputErrors) as exc:
        build_tree(mission.tree, reg, BuildContext(mission=mission))
    assert str(exc.value) == (
        f"{path}:7:9: tree.type: unknown node type 'Wave'; did you mean 'Wove'?")


def test_registration_rules() -> None:
    reg = NodeRegistry()
    reg.register("Wave", _wave, WaveParams)
    with pytest.raises(ValueError, match="'Wave' is already registered"):
        reg.register("Wave", _wave, WaveParams)
    reg.register("Wave", _wave, WaveParams, replace=True)

    class Loose(BaseModel):
        x: int = 0

    with pytest.raises(ValueError, match="must set model_config = ConfigDict"):
        reg.register("Loose", _wave, Loose)
    with pytest.raises(ValueError, match="must be an identifier"):
        reg.register("two words", _wave, NoParams)
    with pytest.raises(TypeError, match="must be a pydantic model class"):
        reg.register("Bad", _wave, dict)  # type: ignore[arg-type]
    with pytest.raises(KeyError, match="unknown node type 'Wav'; did you mean 'Wave'"):
        reg.get("Wav")
    assert reg.get("Wave").description == "Wave the robot's arms."
    assert reg.get("Wave").kind == "leaf"

    copy = reg.copy()
    copy.register("Other", _wave, WaveParams)
    assert "Other" in copy and "Other" not in reg


def test_builtin_types() -> None:
    reg = default_registry()
    kinds = {t.name: t.kind for t in reg}
    assert {n for n, k in kinds.items() if k == "composite"} == {"Sequence", "Selector", "Parallel"}
    assert {"Inverter", "Retry", "Timeout", "Repeat", "SuccessIsRunning", "FailureIsSuccess",
            "RunningIsFailure", "OneShot"} <= {n for n, k in kinds.items() if k == "decorator"}
    assert {"Success", "Failure", "Running", "Pause", "TickCounter"} <= {
        n for n, k in kinds.items() if k == "leaf"}
    assert isinstance(reg.validate_params("Retry", {"num_failures": 2}),
                      builtin_nodes.RetryParams)
    with pytest.raises(ValueError, match=r"params\.num_failures: Field required"):
        reg.validate_params("Retry", {})


def test_behaviour_modules_register_into_the_default_registry(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    module = types.ModuleType("fake_marknav_behaviours")

    def register(reg: NodeRegistry) -> None:
        reg.register("Wave", _wave, WaveParams)

    module.register = register  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "fake_marknav_behaviours", module)
    monkeypatch.setattr(catalogue, "nodes", module)
    monkeypatch.setattr(plugins_module, "_default", None)
    reg = default_registry()
    assert "Wave" in reg and "Sequence" in reg
    assert default_registry() is reg
