"""Clocks behind one small protocol, so time can be real, simulated or driven by a test.

Everything that needs the time (safety timeouts, the control loop, the simulator) takes a
:class:`Clock` instead of calling :func:`time.monotonic`, which makes tests deterministic.
"""

from __future__ import annotations

import threading
import time
from typing import Protocol, runtime_checkable


@runtime_checkable
class Clock(Protocol):
    """A monotonic source of seconds."""

    def now(self) -> float:
        """Seconds since an arbitrary fixed origin; never decreases."""
        ...


class MonotonicClock:
    """Wall-clock time from :func:`time.monotonic`."""

    def now(self) -> float:
        return time.monotonic()


class ManualClock:
    """A clock that moves only when told to: for tests and the simulator.

    Thread-safe, because the driver's reader thread and the controller may both read it.
    """

    def __init__(self, start: float = 0.0) -> None:
        self._t = float(start)
        self._lock = threading.Lock()

    def now(self) -> float:
        # No lock: reading one attribute is atomic (the GIL; the free-threaded build keeps
        # attribute reads atomic too), so a reader sees the time before or after a concurrent
        # advance/set, as it would waiting for the lock. The lock keeps the writers'
        # read-modify-write whole. now() runs ~10 times per tree tick.
        return self._t

    def advance(self, dt: float) -> float:
        """Move the clock forward by ``dt`` seconds (``dt >= 0``) and return the new time."""
        if dt < 0:
            raise ValueError(f"a clock cannot go backwards (dt={dt})")
        with self._lock:
            self._t += dt
            return self._t

    def set(self, t: float) -> None:
        """Jump to time ``t``, which must not be earlier than now."""
        with self._lock:
            if t < self._t:
                raise ValueError(f"a clock cannot go backwards ({t} < {self._t})")
            self._t = float(t)
