"""Wiggle: turn on the spot left, right, left... a few times, then stop and succeed.

A user's behaviour, written and tested with marknav's kit (``marknav.testing``) and registered as
a node type of missions' ``tree:`` by :func:`register` — the function marknav calls for a
mission's ``plugins: [marknav_wiggle]`` and for the entry point ``marknav.nodes``.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

from py_trees.behaviour import Behaviour
from py_trees.common import Status
from pydantic import BaseModel, ConfigDict, Field

from marknav.behaviours.base import DrivingBehaviour
from marknav.missions.registry import BuildContext, NodeRegistry

__all__ = ["Wiggle", "WiggleParams", "register"]


class WiggleParams(BaseModel):
    """Turn on the spot left and right, swings times, then stop."""

    model_config = ConfigDict(extra="forbid")
    swings: int = Field(3, ge=1, le=10, description="Turns, alternately left and right.")
    turn_deg_s: float = Field(60.0, gt=0, le=120, allow_inf_nan=False,
                              description="Turn rate, degrees/s.")
    swing_s: float = Field(0.5, gt=0, le=5, allow_inf_nan=False,
                           description="Duration of each turn, seconds of mission time.")


class Wiggle(DrivingBehaviour):
    """RUNNING while it swings (left first), SUCCESS with the wheels stopped."""

    READS: ClassVar[tuple[str, ...]] = ()

    def __init__(self, name: str = "Wiggle", params: WiggleParams | None = None) -> None:
        super().__init__(name)
        self.params = params or WiggleParams()
        self.wheel_base_mm = 235.0
        self._start = 0.0

    def configure(self, **kwargs: Any) -> None:
        if self.mission is not None:
            self.wheel_base_mm = self.mission.robot.wheel_base_mm

    def initialise(self) -> None:
        self._start = self.now()

    def update(self) -> Status:
        p = self.params
        swing = int((self.now() - self._start) // p.swing_s)
        if swing >= p.swings:
            self.release_wheels()
            self.feedback_message = f"{p.swings} swings done"
            return Status.SUCCESS
        wheel = math.radians(p.turn_deg_s) * self.wheel_base_mm / 2.0
        direction = 1.0 if swing % 2 == 0 else -1.0  # left (counter-clockwise) first
        self.drive(left=-direction * wheel, right=direction * wheel)
        self.feedback_message = f"swing {swing + 1}/{p.swings}"
        return Status.RUNNING


def _wiggle(name: str, params: WiggleParams, _context: BuildContext) -> Behaviour:
    return Wiggle(name, params)


def register(registry: NodeRegistry) -> None:
    """Add ``Wiggle`` to a marknav node registry."""
    registry.register("Wiggle", _wiggle, WiggleParams)
