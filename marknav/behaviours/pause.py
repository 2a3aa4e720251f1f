"""Timing behaviours on the mission's clock: a :class:`Pause` leaf and a :class:`Timeout` decorator.

py_trees' own ``timers.Timer`` reads ``time.time()`` and ``decorators.Timeout`` reads
``time.monotonic()`` (field notes, py_trees 2.6), so neither follows a simulated clock that runs
faster than real time. These two read a :class:`marknav.core.clock.Clock` instead. The clock is
given
at construction (``clock=``) or, as for every marknav behaviour, through the tree's setup:
``tree.setup(clock=clock)`` hands the keyword to each node's ``setup(**kwargs)``
(design brief, "Data flow": the clock is either real time or simulated).

A behaviour without a clock raises :class:`RuntimeError` when it starts, rather than silently
measuring wall time in a simulated run.
"""

from __future__ import annotations

import math
from typing import Any

import py_trees
from py_trees.common import Status

from marknav.core.clock import Clock


def _clock_from(kwargs: dict[str, Any], current: Clock | None, owner: str) -> Clock | None:
    clock = kwargs.get("clock")
    if clock is None:
        return current
    if not isinstance(clock, Clock):
        raise TypeError(
            f"{owner}: setup(clock=...) needs a marknav.core.clock.Clock, got {clock!r}")
    return clock


def _check_seconds(value: float, what: str, *, allow_zero: bool) -> float:
    seconds = float(value)
    if not math.isfinite(seconds) or seconds < 0 or (seconds == 0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{what} must be a finite number of seconds {bound}, got {value!r}")
    return seconds


class Pause(py_trees.behaviour.Behaviour):
    """RUNNING for ``seconds`` of mission time after it starts, then SUCCESS.

    The countdown restarts each time the behaviour is (re)initialised, like py_trees' Timer.
    """

    def __init__(self, name: str = "Pause", seconds: float = 1.0, *, clock: Clock | None = None):
        super().__init__(name=name)
        self.seconds = _check_seconds(seconds, "Pause seconds", allow_zero=True)
        self._clock = clock
        self._finish: float | None = None

    def setup(self, **kwargs: Any) -> None:
        """Take the mission clock from ``clock=`` when the tree is set up."""
        self._clock = _clock_from(kwargs, self._clock, f"Pause {self.name!r}")

    def initialise(self) -> None:
        self._finish = _require(self._clock, f"Pause {self.name!r}").now() + self.seconds

    def update(self) -> Status:
        if self._finish is None:
            raise RuntimeError(f"Pause {self.name!r}: update() before initialise()")
        remaining = self._finish - _require(self._clock, f"Pause {self.name!r}").now()
        if remaining <= 0.0:
            self.feedback_message = f"paused {self.seconds:g} s"
            return Status.SUCCESS
        self.feedback_message = f"{remaining:.1f} s left"
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        # Idempotent: a parent may terminate a finished child a second time.
        self._finish = None


class Timeout(py_trees.decorators.Decorator):
    """Ticks its child; FAILURE once ``duration`` seconds of mission time have passed while the
    child is still RUNNING (the child is then stopped with INVALID, as py_trees' Timeout does).

    Otherwise it returns the child's status. The deadline is set when the decorator starts and is
    checked only when ticked.
    """

    def __init__(
        self,
        name: str,
        child: py_trees.behaviour.Behaviour,
        duration: float,
        *,
        clock: Clock | None = None,
    ):
        super().__init__(name=name, child=child)
        self.duration = _check_seconds(duration, "Timeout duration", allow_zero=False)
        self._clock = clock
        self._deadline: float | None = None

    def setup(self, **kwargs: Any) -> None:
        """Take the mission clock from ``clock=`` when the tree is set up."""
        self._clock = _clock_from(kwargs, self._clock, f"Timeout {self.name!r}")

    def initialise(self) -> None:
        self._deadline = _require(self._clock, f"Timeout {self.name!r}").now() + self.duration
        self.feedback_message = ""

    def update(self) -> Status:
        if self._deadline is None:
            raise RuntimeError(f"Timeout {self.name!r}: update() before initialise()")
        status: Status = self.decorated.status
        if status != Status.RUNNING:
            self.feedback_message = "child finished before the timeout"
            return status
        now = _require(self._clock, f"Timeout {self.name!r}").now()
        if now >= self._deadline:
            self.feedback_message = f"timed out after {self.duration:g} s"
            self.decorated.stop(Status.INVALID)
            return Status.FAILURE
        self.feedback_message = f"{self._deadline - now:.1f} s left"
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        self._deadline = None


def _require(clock: Clock | None, owner: str) -> Clock:
    if clock is None:
        raise RuntimeError(
            f"{owner} has no clock: set up the tree with tree.setup(clock=...) "
            "or pass clock= when constructing it"
        )
    return clock
