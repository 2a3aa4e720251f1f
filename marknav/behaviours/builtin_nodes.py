"""The built-in node types of a mission's ``tree:``: the py_trees composites (``Sequence``,
``Selector``, ``Parallel``), its status-converting decorators, ``Retry``, ``Repeat``,
``OneShot``, the leaves ``Success``, ``Failure``, ``Running``, ``TickCounter``, and marknav's
clock-driven ``Pause`` and ``Timeout`` — each a factory and a pydantic model of its ``params``,
added to a :class:`~marknav.missions.registry.NodeRegistry` by :func:`register_builtins`."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Literal

import py_trees
from py_trees.behaviour import Behaviour
from pydantic import BaseModel, ConfigDict, Field, field_validator

from marknav.behaviours.pause import Pause, Timeout
from marknav.missions.registry import (
    BuildContext,
    DecoratorFactory,
    LeafFactory,
    NodeRegistry,
    NoParams,
    TreeNode,
)

__all__ = ["register_builtins"]


class RetryParams(BaseModel):
    """Re-run the child after a failure, up to num_failures failures in all."""

    model_config = ConfigDict(extra="forbid")
    num_failures: int = Field(ge=1, description="Failures allowed before the decorator fails.")


class RepeatParams(BaseModel):
    """Re-run the child after each success until it has succeeded num_success times."""

    model_config = ConfigDict(extra="forbid")
    num_success: int = Field(description="Successes needed; -1 repeats for ever.")

    @field_validator("num_success")
    @classmethod
    def _positive_or_forever(cls, value: int) -> int:
        if value == 0 or value < -1:
            raise ValueError("num_success must be at least 1, or -1 to repeat for ever")
        return value


class TimeoutParams(BaseModel):
    """Fail if the child is still running after duration seconds of mission time."""

    model_config = ConfigDict(extra="forbid")
    duration: float = Field(gt=0, allow_inf_nan=False, description="Seconds of mission time.")


class OneShotParams(BaseModel):
    """Run the child to completion once, then keep returning its final status."""

    model_config = ConfigDict(extra="forbid")
    policy: Literal["on_completion", "on_successful_completion"] = Field(
        default="on_successful_completion",
        description="on_successful_completion: only a success is final (failures are retried); "
        "on_completion: success or failure is final.",
    )


class PauseParams(BaseModel):
    """Wait for seconds of mission time, then succeed."""

    model_config = ConfigDict(extra="forbid")
    seconds: float = Field(ge=0, allow_inf_nan=False, description="Seconds of mission time.")


class TickCounterParams(BaseModel):
    """RUNNING for a number of ticks, then a final status."""

    model_config = ConfigDict(extra="forbid")
    ticks: int = Field(ge=1, description="Ticks spent RUNNING before finishing.")
    then: Literal["success", "failure"] = Field(default="success", description="The final status.")


def _sequence(name: str, children: list[Behaviour], node: TreeNode, _: BuildContext) -> Behaviour:
    """Run children in order; fail as soon as one fails."""
    return py_trees.composites.Sequence(name=name, memory=bool(node.memory), children=children)


def _selector(name: str, children: list[Behaviour], node: TreeNode, _: BuildContext) -> Behaviour:
    """Try children in priority order until one succeeds or runs."""
    return py_trees.composites.Selector(name=name, memory=bool(node.memory), children=children)


def _parallel(name: str, children: list[Behaviour], node: TreeNode, _: BuildContext) -> Behaviour:
    """Tick all children every tick."""
    policy: py_trees.common.ParallelPolicy.Base = (
        py_trees.common.ParallelPolicy.SuccessOnOne()
        if node.policy == "success_on_one"
        else py_trees.common.ParallelPolicy.SuccessOnAll()
    )
    return py_trees.composites.Parallel(name=name, policy=policy, children=children)


def _plain_decorator(cls: type[py_trees.decorators.Decorator]) -> DecoratorFactory:
    def make(name: str, child: Behaviour, _params: Any, _context: BuildContext) -> Behaviour:
        return cls(name=name, child=child)

    return make


def _retry(name: str, child: Behaviour, params: RetryParams, _: BuildContext) -> Behaviour:
    return py_trees.decorators.Retry(name=name, child=child, num_failures=params.num_failures)


def _repeat(name: str, child: Behaviour, params: RepeatParams, _: BuildContext) -> Behaviour:
    return py_trees.decorators.Repeat(name=name, child=child, num_success=params.num_success)


def _timeout(name: str, child: Behaviour, params: TimeoutParams, _: BuildContext) -> Behaviour:
    return Timeout(name=name, child=child, duration=params.duration)


def _oneshot(name: str, child: Behaviour, params: OneShotParams, _: BuildContext) -> Behaviour:
    policy = (
        py_trees.common.OneShotPolicy.ON_COMPLETION
        if params.policy == "on_completion"
        else py_trees.common.OneShotPolicy.ON_SUCCESSFUL_COMPLETION
    )
    return py_trees.decorators.OneShot(name=name, child=child, policy=policy)


def _fixed_status(cls: Callable[..., Behaviour], doc: str) -> LeafFactory:
    def make(name: str, _params: Any, _context: BuildContext) -> Behaviour:
        return cls(name=name)

    make.__doc__ = doc
    return make


def _pause(name: str, params: PauseParams, _: BuildContext) -> Behaviour:
    return Pause(name=name, seconds=params.seconds)


def _tick_counter(name: str, params: TickCounterParams, _: BuildContext) -> Behaviour:
    status = py_trees.common.Status.SUCCESS if params.then == "success" else (
        py_trees.common.Status.FAILURE
    )
    return py_trees.behaviours.TickCounter(name=name, duration=params.ticks,
                                           completion_status=status)


#: py_trees decorators that only map the child's status, with what each does.
_STATUS_DECORATORS: tuple[tuple[type[py_trees.decorators.Decorator], str], ...] = (
    (py_trees.decorators.Inverter, "SUCCESS becomes FAILURE and FAILURE becomes SUCCESS."),
    (py_trees.decorators.SuccessIsFailure, "SUCCESS becomes FAILURE."),
    (py_trees.decorators.SuccessIsRunning, "SUCCESS becomes RUNNING."),
    (py_trees.decorators.FailureIsSuccess, "FAILURE becomes SUCCESS."),
    (py_trees.decorators.FailureIsRunning, "FAILURE becomes RUNNING."),
    (py_trees.decorators.RunningIsFailure, "RUNNING becomes FAILURE."),
    (py_trees.decorators.RunningIsSuccess, "RUNNING becomes SUCCESS."),
    (py_trees.decorators.PassThrough, "The child's status, unchanged."),
)


def register_builtins(registry: NodeRegistry) -> None:
    """Add the py_trees composites, decorators and simple leaves, and Pause/Timeout."""
    registry.register_composite("Sequence", _sequence, needs_memory=True)
    registry.register_composite("Selector", _selector, needs_memory=True)
    registry.register_composite("Parallel", _parallel, needs_policy=True)
    for cls, what in _STATUS_DECORATORS:
        registry.register(cls.__name__, _plain_decorator(cls), NoParams, leaf=False,
                          description=what)
    registry.register("Retry", _retry, RetryParams, leaf=False)
    registry.register("Repeat", _repeat, RepeatParams, leaf=False)
    registry.register("Timeout", _timeout, TimeoutParams, leaf=False)
    registry.register("OneShot", _oneshot, OneShotParams, leaf=False)
    registry.register("Success", _fixed_status(py_trees.behaviours.Success, "Always succeed."))
    registry.register("Failure", _fixed_status(py_trees.behaviours.Failure, "Always fail."))
    registry.register("Running", _fixed_status(py_trees.behaviours.Running, "Always run."))
    registry.register("Pause", _pause, PauseParams)
    registry.register("TickCounter", _tick_counter, TickCounterParams)


