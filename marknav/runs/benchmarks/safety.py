"""Bump-to-stop latency of the safety layer (:mod:`marknav.robot.safety`).

The guarantee under test: a bump in the sensor stream (OI packet 7) makes the layer write a zero
Drive Direct (opcode 145) within one stream period (15 ms, OI spec *Stream*) of the frame's
arrival. The layer does it synchronously inside ``on_sensors``; this measures how long that takes
on this machine, from ``on_sensors`` entry to the sink's zero write, with
:func:`time.perf_counter`.
"""

from __future__ import annotations

import dataclasses
import logging
import time

from marknav.core.clock import ManualClock
from marknav.robot import safety
from marknav.robot.safety import SafetyFlags, SafetyLayer, SafetyState

__all__ = ["measure_bump_to_stop"]

#: OI stream period (s): one frame every 15 ms.
STREAM_PERIOD_S = 0.015


class _StampingSink:
    """A wheel sink that notes the perf_counter time of its latest zero write."""

    def __init__(self) -> None:
        self.zero_at: float | None = None

    def drive_direct(self, *, left: int, right: int) -> None:
        if left == 0 and right == 0:
            self.zero_at = time.perf_counter()


def measure_bump_to_stop(n: int, *, speed_mm_s: int = 200) -> list[float]:
    """Drive, deliver a bump frame, and time ``on_sensors`` entry -> zero write; ``n`` times.

    Returns the ``n`` latencies in seconds. Raises ``RuntimeError`` if a bump ever failed to stop
    the wheels (which would be a bug in the layer), ``ValueError`` if ``n < 1``.
    """
    if n < 1:
        raise ValueError(f"n must be at least 1, got {n}")
    safety_logger = logging.getLogger(safety.__name__)
    level = safety_logger.level
    safety_logger.setLevel(logging.ERROR)  # measure the stop path, not the log handlers
    try:
        return _measure(n, speed_mm_s)
    finally:
        safety_logger.setLevel(level)


def _measure(n: int, speed_mm_s: int) -> list[float]:
    clock = ManualClock()
    sink = _StampingSink()
    layer = SafetyLayer(sink, clock=clock)
    clear = SafetyFlags()
    bumped = dataclasses.replace(clear, bump_left=True)
    layer.connect()
    layer.on_sensors(clear)
    latencies: list[float] = []
    for i in range(n):
        clock.advance(STREAM_PERIOD_S)
        layer.on_sensors(clear)  # releases the previous bump: bumped -> ready
        if not layer.command(left=speed_mm_s, right=speed_mm_s):
            raise RuntimeError(f"run {i}: command refused in state {layer.state.value}")
        sink.zero_at = None
        t0 = time.perf_counter()
        layer.on_sensors(bumped)
        stopped_at = sink.zero_at
        if stopped_at is None or layer.state is not SafetyState.BUMPED:
            raise RuntimeError(f"run {i}: the bump did not stop the wheels "
                               f"(state {layer.state.value})")
        latencies.append(stopped_at - t0)
    return latencies
