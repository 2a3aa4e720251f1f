"""Safety layer under two threads (controller + reader), and the bump-to-stop latency helper."""

from __future__ import annotations

import dataclasses
import logging
import math
import threading
import time
from collections.abc import Callable

import pytest

from marknav.core.clock import ManualClock
from marknav.robot.safety import SafetyFlags, SafetyLayer, SafetyState
from marknav.runs.benchmarks.safety import measure_bump_to_stop

CLEAR = SafetyFlags()
BUMP = dataclasses.replace(CLEAR, bump_left=True)


class SlowSink:
    """A sink with its own port lock that yields the GIL mid-write, like a real serial write."""

    def __init__(self) -> None:
        self.port_lock = threading.Lock()
        self.calls: list[tuple[int, int]] = []

    def drive_direct(self, *, left: int, right: int) -> None:
        with self.port_lock:
            time.sleep(0)  # let the other thread run while "writing"
            self.calls.append((left, right))


def wait_until(predicate: Callable[[], bool], timeout: float = 5.0) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError("timed out waiting for the other thread")
        time.sleep(0.0002)


def test_no_nonzero_command_reaches_the_sink_after_a_bump_returns() -> None:
    clock = ManualClock()  # never advanced: no watchdog interferes
    sink = SlowSink()
    layer = SafetyLayer(sink, clock=clock)
    layer.connect()
    layer.on_sensors(CLEAR)

    stop = threading.Event()
    attempts = [0]
    errors: list[BaseException] = []

    def controller() -> None:
        speed = 100
        try:
            while not stop.is_set():
                layer.command(left=speed, right=speed + 7)
                attempts[0] += 1
                speed = 100 + (speed - 99) % 300
        except BaseException as exc:  # reported by the main thread
            errors.append(exc)
            raise

    thread = threading.Thread(target=controller, daemon=True)
    thread.start()
    try:
        for _ in range(60):
            layer.on_sensors(CLEAR)  # release: ready, then the controller drives again
            wait_until(lambda: layer.state is SafetyState.DRIVING or bool(errors))
            assert errors == []
            layer.on_sensors(BUMP)
            # on_sensors has returned: the zero is on the wire and the state is latched.
            mark = len(sink.calls)
            assert sink.calls[mark - 1] == (0, 0)
            assert layer.state is SafetyState.BUMPED
            target = attempts[0] + 5  # let the controller try (and fail) a few more times
            wait_until(lambda: attempts[0] >= target)  # noqa: B023 - called before target changes
            assert all(call == (0, 0) for call in sink.calls[mark - 1:]), sink.calls[mark - 1:]
    finally:
        stop.set()
        thread.join(timeout=5)
    assert not thread.is_alive()
    assert errors == []
    assert any(call != (0, 0) for call in sink.calls)  # the controller really was driving


class Timeline(logging.Handler):
    """Puts the layer's transition log lines and the sink's writes on one ordered timeline."""

    def __init__(self) -> None:
        super().__init__(level=logging.INFO)
        self.items: list[tuple[str, object]] = []
        self.port_lock = threading.Lock()

    def emit(self, record: logging.LogRecord) -> None:
        event = record.args[1] if isinstance(record.args, tuple) and len(record.args) > 1 else None
        if record.getMessage().startswith("t="):
            self.items.append(("event", event))

    def drive_direct(self, *, left: int, right: int) -> None:
        with self.port_lock:
            time.sleep(0)
            self.items.append(("wire", (left, right)))


def test_reader_and_controller_threads_do_not_deadlock_and_keep_the_bump_rule() -> None:
    clock = ManualClock()
    timeline = Timeline()
    safety_logger = logging.getLogger("marknav.robot.safety")
    old_level = safety_logger.level
    safety_logger.setLevel(logging.INFO)
    safety_logger.addHandler(timeline)
    layer = SafetyLayer(timeline, clock=clock)
    layer.connect()
    frames = 3000
    errors: list[BaseException] = []

    def reader() -> None:
        try:
            for i in range(frames):
                layer.on_sensors(BUMP if i % 7 in (3, 4) else CLEAR)
                layer.poll()
        except BaseException as exc:  # pragma: no cover - reported below
            errors.append(exc)

    def controller() -> None:
        try:
            for i in range(frames):
                if i % 2:
                    layer.backoff(left=-50, right=-40)
                else:
                    layer.command(left=150 if i % 5 else 0, right=150)
                layer.poll()
        except BaseException as exc:  # pragma: no cover - reported below
            errors.append(exc)

    threads = [threading.Thread(target=reader), threading.Thread(target=controller)]
    try:
        for t in threads:
            t.start()
        for t in threads:
            t.join(timeout=20)
    finally:
        safety_logger.removeHandler(timeline)
        safety_logger.setLevel(old_level)
    assert not any(t.is_alive() for t in threads), "deadlock"
    assert errors == []
    events = [what for kind, what in timeline.items if kind == "event"]
    assert events.count("bump") >= 100 and events.count("bump_cleared") >= 100
    # On the wire: a zero just before every bump is logged, then only backward motion (or
    # zeros) until the bump clears.
    bumped = False
    last_wire: object = None
    for kind, what in timeline.items:
        if kind == "event":
            if what == "bump":
                assert last_wire == (0, 0)
                bumped = True
            elif what in ("bump_cleared", "fault", "estop"):
                bumped = False
        else:
            last_wire = what
            if bumped:
                assert isinstance(what, tuple) and what[0] <= 0 and what[1] <= 0, what


def test_measure_bump_to_stop_times_every_bump() -> None:
    # Every one of the 300 bumps zeroed the wheels (measure_bump_to_stop raises otherwise) and
    # got a positive, finite latency. How fast is `marknav bench safety`'s figure (p50/p99
    # against one 15 ms stream period), not a test's: the machine may be loaded.
    latencies = measure_bump_to_stop(300)
    assert len(latencies) == 300
    assert all(0.0 < lat < math.inf for lat in latencies)


def test_measure_bump_to_stop_rejects_zero_runs() -> None:
    with pytest.raises(ValueError, match="at least 1"):
        measure_bump_to_stop(0)
