"""A real Create and a real camera as the run loop's environment.

The driver's reader thread parses the sensor stream and feeds the safety layer on its own (a bump
stops the wheels within one stream period, whatever the control loop is doing); the loop polls
the safety timeouts each cycle and sleeps until the next one. Ground truth does not exist here:
the report's ``passed_on`` and ``min_clearance_mm`` stay null.
"""

from __future__ import annotations

import time
from typing import Any

from marknav.core.clock import Clock, MonotonicClock
from marknav.robot.driver import CreateDriver
from marknav.robot.robot import Robot
from marknav.runs.records.report import RunReport
from marknav.vision.sources import FrameSource


class HardwareEnvironment:
    """A connected :class:`CreateDriver` (or any :class:`Robot` with ``safety``) and a camera."""

    def __init__(self, driver: CreateDriver, camera: FrameSource,
                 clock: Clock | None = None) -> None:
        self.name = f"robot {driver.port_url}, camera {camera.name}"
        self.driver = driver
        self.camera = camera
        self.clock = clock or MonotonicClock()
        self._closed = False

    @property
    def robot(self) -> Robot:
        return self.driver

    def poll(self) -> None:
        self.driver.safety.poll()

    def advance(self, until: float) -> None:
        delay = until - self.clock.now()
        if delay > 0:
            time.sleep(delay)

    def safety_events(self) -> list[dict[str, Any]]:
        return [e.to_dict() for e in self.driver.safety_events]

    def finish(self, report: RunReport) -> None:
        report.collisions = sum(1 for e in self.driver.safety_events if e.event == "bump")

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            self.driver.close()  # wheels stopped, stream paused, Passive, port closed
        finally:
            self.camera.close()
