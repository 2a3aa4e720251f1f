"""Safety layer: each guarantee tick by tick with a ManualClock and a recording sink."""

from __future__ import annotations

import dataclasses
import logging
import math
import threading
from typing import Any

import pytest
import serial
from hypothesis import given
from hypothesis import strategies as st
from transitions import MachineError

from marknav.core.clock import ManualClock
from marknav.robot.safety import (
    EVENTS,
    SafetyEvent,
    SafetyFlags,
    SafetyLayer,
    SafetyState,
    fault_conditions,
    scale_wheels,
)

S = SafetyState
CLEAR = SafetyFlags()


def flags(**kw: object) -> SafetyFlags:
    return dataclasses.replace(CLEAR, **kw)  # type: ignore[arg-type]


class RecordingSink:
    """Records each Drive Direct with the clock time and the calling thread; can be made to fail."""

    def __init__(self, clock: ManualClock) -> None:
        self.clock = clock
        self.calls: list[tuple[int, int]] = []
        self.times: list[float] = []
        self.threads: list[int] = []
        self.fail_with: BaseException | None = None

    def clear(self) -> None:
        self.calls.clear()
        self.times.clear()
        self.threads.clear()

    def drive_direct(self, *, left: int, right: int) -> None:
        if self.fail_with is not None:
            raise self.fail_with
        self.calls.append((left, right))
        self.times.append(self.clock.now())
        self.threads.append(threading.get_ident())


def make(start: float = 0.0, **kw: Any) -> tuple[SafetyLayer, RecordingSink, ManualClock]:
    clock = ManualClock(start)
    sink = RecordingSink(clock)
    layer = SafetyLayer(sink, clock=clock, **kw)
    return layer, sink, clock


def connected(**kw: Any) -> tuple[SafetyLayer, RecordingSink, ManualClock]:
    """Connected, one clear frame received, sink history cleared."""
    layer, sink, clock = make(**kw)
    layer.connect()
    layer.on_sensors(CLEAR)
    sink.clear()
    return layer, sink, clock


def driving(left: int = 200, right: int = 200) -> tuple[SafetyLayer, RecordingSink, ManualClock]:
    layer, sink, clock = connected()
    assert layer.command(left=left, right=right) is True
    assert layer.state is S.DRIVING
    sink.clear()
    return layer, sink, clock


def event_names(layer: SafetyLayer) -> list[tuple[str, str]]:
    return [(e.event, e.state) for e in layer.events]


# ---------------------------------------------------------------- pure helpers


def test_scale_wheels_scales_both_by_one_factor_and_rounds() -> None:
    assert scale_wheels(800, 400, 500) == (500, 250)
    assert scale_wheels(-600, 300, 500) == (-500, 250)
    assert scale_wheels(300, -1000, 500) == (150, -500)
    assert scale_wheels(100.4, 99.6, 500) == (100, 100)
    assert scale_wheels(0.3, -0.4, 500) == (0, 0)
    assert scale_wheels(250, 250, 200) == (200, 200)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_scale_wheels_rejects_non_finite(bad: float) -> None:
    with pytest.raises(ValueError, match="finite"):
        scale_wheels(bad, 0.0, 500)


@given(
    left=st.floats(-5000, 5000, allow_nan=False),
    right=st.floats(-5000, 5000, allow_nan=False),
    limit=st.integers(50, 500),
)
def test_scale_wheels_keeps_limit_and_curvature(left: float, right: float, limit: int) -> None:
    lw, rw = scale_wheels(left, right, limit)
    assert abs(lw) <= limit and abs(rw) <= limit
    peak = max(abs(left), abs(right))
    factor = min(1.0, limit / peak) if peak > 0 else 1.0
    # Same single factor on both wheels, up to rounding.
    assert abs(lw - left * factor) <= 0.5 + 1e-9
    assert abs(rw - right * factor) <= 0.5 + 1e-9


def test_fault_conditions_names_each_flag() -> None:
    assert fault_conditions(CLEAR) == []
    assert fault_conditions(flags(bump_left=True, bump_right=True)) == []
    assert fault_conditions(flags(cliff_front_left=True, wheel_drop_right=True)) == [
        "wheel drop right", "cliff front left"]


def test_safety_event_is_frozen_and_serialises() -> None:
    ev = SafetyEvent(t=1.5, event="bump", state="bumped", detail="bump left")
    assert ev.to_dict() == {"t": 1.5, "event": "bump", "state": "bumped", "detail": "bump left"}
    with pytest.raises(dataclasses.FrozenInstanceError):
        ev.t = 2.0  # type: ignore[misc]


@pytest.mark.parametrize(
    ("kw", "message"),
    [
        ({"command_timeout_s": 0}, "command_timeout_s must be a positive"),
        ({"sensor_timeout_s": -0.1}, "sensor_timeout_s must be a positive"),
        ({"sensor_timeout_s": math.nan}, "sensor_timeout_s must be a positive"),
        ({"max_wheel_mm_s": 501}, r"max_wheel_mm_s must be an integer in 1\.\.500"),
        ({"max_wheel_mm_s": 0}, r"max_wheel_mm_s must be an integer in 1\.\.500"),
        ({"max_wheel_mm_s": 300.0}, r"max_wheel_mm_s must be an integer in 1\.\.500"),
    ],
)
def test_constructor_rejects_bad_limits(kw: dict[str, Any], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        make(**kw)


# ---------------------------------------------------------------- the machine itself


def test_machine_has_no_auto_transitions_and_rejects_invalid_triggers() -> None:
    layer, _, _ = make()
    machine = layer.machine
    assert machine.auto_transitions is False
    model = machine.models[0]
    for state in SafetyState:
        assert not hasattr(model, f"to_{state.name}")
        assert not hasattr(model, f"to_{state.value}")
    triggers = set(machine.get_triggers(*[s.name for s in SafetyState]))
    assert triggers == set(EVENTS)
    assert not any(t.startswith("to_") for t in triggers)
    # Guards cannot be skipped from the model either: driving from disconnected is an error.
    with pytest.raises(MachineError):
        model.trigger("drive", left=100, right=100)
    assert layer.state is S.DISCONNECTED


def test_nothing_passes_before_connect() -> None:
    layer, sink, _ = make()
    assert layer.state is S.DISCONNECTED
    assert layer.command(left=100, right=100) is False
    assert layer.command(left=0, right=0) is False
    layer.stop()
    layer.poll()
    assert sink.calls == []
    assert layer.events == []


def test_connect_zeroes_the_wheels_and_is_logged_with_clock_time() -> None:
    layer, sink, _ = make(start=12.5)
    layer.connect()
    assert layer.state is S.READY
    assert sink.calls == [(0, 0)]
    assert [e.to_dict() for e in layer.events] == [
        {"t": 12.5, "event": "connect", "state": "ready", "detail": "link up"}]
    layer.connect()  # ignored once connected
    assert sink.calls == [(0, 0)]
    assert len(layer.events) == 1


def test_drive_and_stop_cycle() -> None:
    layer, sink, clock = connected()
    assert layer.command(left=150, right=-150.4) is True
    assert layer.state is S.DRIVING
    clock.advance(0.05)
    assert layer.command(left=900, right=450) is True  # scaled together to the 500 limit
    assert layer.wheels == (500, 250)
    clock.advance(0.05)
    assert layer.command(left=0.2, right=-0.3) is True  # rounds to zero: a stop
    assert layer.state is S.READY
    assert layer.command(left=0, right=0) is True  # zero passes in ready too
    assert layer.command(left=80, right=80) is True
    layer.stop()
    assert layer.state is S.READY
    assert sink.calls == [(150, -150), (500, 250), (0, 0), (0, 0), (80, 80), (0, 0)]
    assert event_names(layer)[1:] == [
        ("drive", "driving"), ("stop", "ready"), ("drive", "driving"), ("stop", "ready")]


def test_max_wheel_limit_is_configurable() -> None:
    layer, sink, _ = connected(max_wheel_mm_s=300)
    layer.command(left=600, right=-150)
    assert sink.calls == [(300, -75)]


def test_non_finite_command_stops_then_raises() -> None:
    layer, sink, _ = driving()
    with pytest.raises(ValueError, match="finite"):
        layer.command(left=math.nan, right=100)
    assert layer.state is S.READY
    assert sink.calls == [(0, 0)]


# ---------------------------------------------------------------- bump


def test_bump_writes_zero_synchronously_before_the_next_command() -> None:
    layer, sink, clock = driving(left=300, right=250)
    clock.advance(0.015)
    arrival = clock.now()
    layer.on_sensors(flags(bump_right=True))
    # Inside on_sensors, on this thread, at the frame's arrival time (no clock movement needed).
    assert sink.calls == [(0, 0)]
    assert sink.times == [arrival]
    assert sink.threads == [threading.get_ident()]
    assert layer.state is S.BUMPED and layer.bumped
    assert layer.command(left=300, right=250) is False
    assert layer.command(left=-100, right=-100) is False  # command() never backs off
    assert sink.calls == [(0, 0)]
    assert layer.events[-1] == SafetyEvent(t=arrival, event="bump", state="bumped",
                                           detail="bump right")


def test_bump_from_ready_and_repeated_bump_frames() -> None:
    layer, sink, _ = connected()
    layer.on_sensors(flags(bump_left=True, bump_right=True))
    layer.on_sensors(flags(bump_left=True))
    assert layer.state is S.BUMPED
    assert sink.calls == [(0, 0)]  # one stop, not one per frame
    assert [(e.event, e.detail) for e in layer.events[-1:]] == [("bump", "bump left and right")]


def test_bump_clears_to_ready_then_commands_pass() -> None:
    layer, sink, clock = driving()
    layer.on_sensors(flags(bump_left=True))
    assert layer.command(left=0, right=0) is True  # zero commands pass while bumped
    clock.advance(0.015)
    layer.on_sensors(CLEAR)
    assert layer.state is S.READY
    assert layer.command(left=120, right=120) is True
    assert layer.state is S.DRIVING
    assert sink.calls == [(0, 0), (0, 0), (0, 0), (120, 120)]
    assert event_names(layer)[-3:] == [
        ("bump", "bumped"), ("bump_cleared", "ready"), ("drive", "driving")]


@pytest.mark.parametrize(
    ("left", "right", "passes"),
    [(-100, -100, True), (-150, -50, True), (0, -100, True), (-100, 0, True),
     (100, 100, False), (50, -200, False), (-200, 1, False), (0, 0, True)],
)
def test_backoff_while_bumped_lets_only_backward_motion_pass(
    left: int, right: int, passes: bool
) -> None:
    layer, sink, _ = driving()
    layer.on_sensors(flags(bump_left=True))
    sink.clear()
    assert layer.backoff(left=left, right=right) is passes
    assert sink.calls == ([(left, right)] if passes else [])
    assert layer.state is S.BUMPED


def test_backoff_then_release_goes_to_ready_and_zeroes() -> None:
    layer, sink, clock = driving()
    layer.on_sensors(flags(bump_left=True))
    assert layer.backoff(left=-100, right=-100) is True
    clock.advance(0.015)
    layer.on_sensors(CLEAR)  # bumper released while backing off
    assert layer.state is S.READY
    assert layer.backoff(left=-100, right=-100) is True  # outside bumped it is a plain command
    assert layer.state is S.DRIVING
    assert layer.backoff(left=100, right=100) is True
    assert sink.calls == [(0, 0), (-100, -100), (0, 0), (-100, -100), (100, 100)]


def test_backoff_motion_is_watched_by_the_command_timeout() -> None:
    layer, sink, clock = driving()
    layer.on_sensors(flags(bump_left=True))
    layer.backoff(left=-80, right=-80)  # at t = 0
    for t in (0.015 * k for k in range(1, 20)):  # bump frames keep coming, no new command
        clock.set(t)
        layer.on_sensors(flags(bump_left=True))
    assert sink.calls == [(0, 0), (-80, -80)]  # 0.285 s: within the 0.3 s limit
    clock.set(0.3)
    layer.poll()
    assert sink.calls == [(0, 0), (-80, -80)]  # exactly the limit is still fine
    clock.set(0.315)
    layer.on_sensors(flags(bump_left=True))
    assert sink.calls == [(0, 0), (-80, -80), (0, 0)]
    assert layer.state is S.BUMPED
    ev = layer.events[-1]
    assert (ev.t, ev.event, ev.state) == (0.315, "command_timeout", "bumped")
    assert ev.detail == "no command for 0.315 s (limit 0.3 s)"
    for t in (0.4, 0.5, 0.6):
        clock.set(t)
        layer.on_sensors(flags(bump_left=True))
        layer.poll()  # wheels already stopped: no second timeout
    assert [e.event for e in layer.events].count("command_timeout") == 1
    assert sink.calls == [(0, 0), (-80, -80), (0, 0)]


# ---------------------------------------------------------------- faults


FAULT_FLAGS = [
    "wheel_drop_left", "wheel_drop_right", "caster_drop", "cliff_left", "cliff_front_left",
    "cliff_front_right", "cliff_right", "overcurrent_left_wheel", "overcurrent_right_wheel",
]


@pytest.mark.parametrize("flag", FAULT_FLAGS)
def test_hazard_flags_latch_fault_with_an_immediate_stop(flag: str) -> None:
    layer, sink, clock = driving(left=250, right=200)
    clock.advance(0.015)
    layer.on_sensors(flags(**{flag: True}))
    assert sink.calls == [(0, 0)]
    assert sink.threads == [threading.get_ident()]
    assert layer.state is S.FAULT
    assert layer.fault_reason == flag.replace("_", " ")  # e.g. "cliff front left"
    assert layer.command(left=250, right=200) is False
    clock.advance(0.015)
    layer.on_sensors(CLEAR)  # the condition going away does not unlatch
    assert layer.state is S.FAULT
    assert layer.command(left=250, right=200) is False
    assert layer.command(left=0, right=0) is True
    assert sink.calls == [(0, 0), (0, 0)]
    assert event_names(layer)[-1] == ("fault", "fault")


def test_fault_wins_over_bump_in_the_same_frame() -> None:
    layer, sink, _ = driving()
    layer.on_sensors(flags(bump_left=True, cliff_front_left=True, wheel_drop_left=True))
    assert layer.state is S.FAULT
    assert layer.fault_reason == "wheel drop left, cliff front left"
    assert sink.calls == [(0, 0)]


def test_hazard_while_bumped_faults() -> None:
    layer, sink, _ = driving()
    layer.on_sensors(flags(bump_left=True))
    layer.backoff(left=-100, right=-100)
    layer.on_sensors(flags(bump_left=True, cliff_right=True))
    assert layer.state is S.FAULT
    assert sink.calls == [(0, 0), (-100, -100), (0, 0)]
    assert layer.backoff(left=-100, right=-100) is False


def test_drop_to_passive_after_safe_is_a_fault() -> None:
    layer, sink, _ = driving()
    layer.on_sensors(flags(oi_mode=1))
    assert layer.state is S.FAULT
    assert layer.fault_reason == "OI mode dropped to passive (1)"
    assert sink.calls == [(0, 0)]


def test_full_mode_is_accepted() -> None:
    layer, _, _ = driving()
    layer.on_sensors(flags(oi_mode=3))
    assert layer.state is S.DRIVING


def test_passive_before_safe_was_ever_seen_is_not_a_drop() -> None:
    layer, _, _ = make()
    layer.connect()
    layer.on_sensors(flags(oi_mode=1))  # the Safe command has not taken effect yet
    assert layer.state is S.READY
    layer.on_sensors(CLEAR)
    layer.on_sensors(flags(oi_mode=0))
    assert layer.state is S.FAULT
    assert layer.fault_reason == "OI mode dropped to off (0)"


def test_latched_fault_ignores_bumps() -> None:
    layer, _, _ = driving()
    layer.on_sensors(flags(overcurrent_right_wheel=True))
    layer.on_sensors(flags(bump_left=True))
    layer.on_sensors(CLEAR)
    assert layer.state is S.FAULT


# ---------------------------------------------------------------- reset


def test_reset_only_when_the_condition_is_gone_and_sensors_are_fresh() -> None:
    layer, sink, clock = driving()
    layer.on_sensors(flags(cliff_left=True))
    assert layer.reset() is False  # cliff still in the latest frame
    clock.advance(0.015)
    layer.on_sensors(CLEAR)
    clock.advance(0.25)
    assert layer.reset() is False  # latest frame too old
    clock.advance(0.015)
    layer.on_sensors(flags(oi_mode=1))
    assert layer.reset() is False  # robot dropped to passive: Safe must be sent again
    clock.advance(0.015)
    layer.on_sensors(CLEAR)
    assert layer.state is S.FAULT
    assert layer.reset() is True
    assert layer.state is S.READY
    assert layer.fault_reason is None
    assert sink.calls == [(0, 0), (0, 0)]  # stop on the cliff, zero again on reset
    last = layer.events[-1]
    assert (last.event, last.state, last.detail) == ("reset", "ready", "cleared: cliff left")
    assert layer.command(left=100, right=100) is True


def test_reset_with_bumper_still_pressed_goes_to_bumped() -> None:
    layer, _, _ = driving()
    layer.on_sensors(flags(overcurrent_left_wheel=True, bump_left=True))
    layer.on_sensors(flags(bump_left=True))
    assert layer.reset() is True
    assert layer.state is S.BUMPED
    assert layer.command(left=100, right=100) is False
    assert layer.backoff(left=-100, right=-100) is True


def test_reset_outside_latched_states_is_refused() -> None:
    layer, sink, _ = driving()
    assert layer.reset() is False
    assert layer.state is S.DRIVING
    assert sink.calls == []


# ---------------------------------------------------------------- watchdogs


def test_command_timeout_tick_by_tick() -> None:
    layer, sink, clock = connected(command_timeout_s=0.3, sensor_timeout_s=10.0)
    for k in range(10):  # 20 Hz commands at t = 0.00 .. 0.45: never times out
        clock.set(0.05 * k)
        layer.poll()
        assert layer.command(left=200, right=200) is True
    assert layer.state is S.DRIVING
    clock.set(0.749)
    layer.poll()
    assert layer.state is S.DRIVING
    clock.set(0.76)
    layer.poll()
    assert layer.state is S.READY
    assert sink.calls == [(200, 200)] * 10 + [(0, 0)]
    ev = layer.events[-1]
    assert (ev.t, ev.event, ev.state) == (0.76, "command_timeout", "ready")
    assert ev.detail == "no command for 0.310 s (limit 0.3 s)"
    layer.poll()
    assert len(sink.calls) == 11  # one stop, not one per poll


def test_command_timeout_is_checked_on_sensor_frames() -> None:
    layer, sink, clock = driving()
    for k in range(1, 21):
        clock.set(0.015 * k)
        layer.on_sensors(CLEAR)
    assert layer.state is S.DRIVING  # 0.300 s
    clock.set(0.315)
    layer.on_sensors(CLEAR)
    assert layer.state is S.READY
    assert sink.calls == [(0, 0)]


def test_late_command_first_trips_the_watchdog_then_passes() -> None:
    layer, sink, clock = driving(left=100, right=100)
    for t in (0.1, 0.2, 0.3):
        clock.set(t)
        layer.on_sensors(CLEAR)
    clock.set(0.31)  # 0.31 s since the last command; no poll in between
    assert layer.command(left=150, right=150) is True
    assert sink.calls == [(0, 0), (150, 150)]
    assert event_names(layer)[-2:] == [("command_timeout", "ready"), ("drive", "driving")]


def test_sensor_timeout_faults_tick_by_tick() -> None:
    layer, sink, clock = driving()
    for k in range(1, 6):
        clock.set(0.015 * k)
        layer.on_sensors(CLEAR)
        layer.command(left=200, right=200)
    clock.set(0.075 + 0.199)
    layer.poll()
    assert layer.state is S.DRIVING
    clock.set(0.075 + 0.21)
    layer.poll()
    assert layer.state is S.FAULT
    assert sink.calls == [(200, 200)] * 5 + [(0, 0)]
    assert layer.fault_reason == "no sensor frame for 0.210 s (limit 0.2 s)"
    ev = layer.events[-1]
    assert (ev.t, ev.event, ev.state) == (0.075 + 0.21, "sensor_timeout", "fault")
    assert layer.command(left=200, right=200) is False


def test_a_frame_from_before_connect_does_not_start_the_sensor_watchdog() -> None:
    """The watchdog counts from the later of connect and the last frame: a frame that came while
    disconnected (a stream left running by a previous program) is older than the link."""
    layer, sink, clock = make(start=1.0, sensor_timeout_s=0.2)
    layer.on_sensors(CLEAR)  # disconnected: recorded, no state change
    assert layer.state is S.DISCONNECTED
    clock.set(5.0)
    layer.connect()
    clock.set(5.15)  # 4.15 s after that frame, 0.15 s after connect
    layer.poll()
    assert layer.state is S.READY
    assert layer.command(left=100, right=100) is True
    clock.set(5.21)
    layer.poll()
    assert layer.state is S.FAULT
    assert layer.fault_reason == "no sensor frame since connect for 0.210 s (limit 0.2 s)"
    assert sink.calls[-2:] == [(100, 100), (0, 0)]  # driven, then stopped by the watchdog


def test_sensor_timeout_counts_from_connect_when_no_frame_ever_came() -> None:
    layer, sink, clock = make(start=3.0)
    layer.connect()
    clock.set(3.19)
    layer.poll()
    assert layer.state is S.READY
    clock.set(3.21)
    assert layer.command(left=100, right=100) is False  # the command's own check trips it
    assert layer.state is S.FAULT
    assert layer.fault_reason == "no sensor frame since connect for 0.210 s (limit 0.2 s)"
    assert sink.calls == [(0, 0), (0, 0)]


def test_late_sensor_frame_trips_the_watchdog_before_it_counts() -> None:
    layer, sink, clock = driving()
    clock.set(0.25)
    layer.on_sensors(CLEAR)
    assert layer.state is S.FAULT
    assert sink.calls == [(0, 0)]
    assert layer.last_sensors_t == 0.25
    assert layer.reset() is True  # the late frame itself is fresh


# ---------------------------------------------------------------- link loss and sink errors


def test_link_lost_faults_with_a_clear_message_and_never_raises() -> None:
    layer, sink, _ = driving()
    sink.fail_with = serial.SerialException("device reports readiness to read but returned no data")
    layer.on_link_lost("/dev/ttyUSB0 disappeared")
    assert layer.state is S.FAULT
    assert layer.fault_reason == (
        "serial link lost: /dev/ttyUSB0 disappeared; wheel write failed: SerialException: "
        "device reports readiness to read but returned no data")
    assert [(e.event, e.state, e.detail) for e in layer.events[-2:]] == [
        ("fault", "fault", "serial link lost: /dev/ttyUSB0 disappeared"),
        ("fault", "fault", "wheel write failed: SerialException: device reports readiness to "
                           "read but returned no data"),
    ]
    layer.on_link_lost("/dev/ttyUSB0 disappeared")  # repeated: no new event
    assert len([e for e in layer.events if e.event == "fault"]) == 2
    assert layer.command(left=100, right=100) is False


def test_link_lost_while_disconnected_does_nothing() -> None:
    layer, sink, _ = make()
    layer.on_link_lost("gone")
    assert layer.state is S.DISCONNECTED
    assert layer.events == [] and sink.calls == []


@pytest.mark.parametrize("exc", [serial.SerialException("write failed"),
                                 OSError(5, "Input/output error")])
def test_sink_error_while_stopping_for_a_bump_goes_to_fault(exc: BaseException) -> None:
    layer, _, _ = driving()
    layer._sink.fail_with = exc  # type: ignore[attr-defined]
    layer.on_sensors(flags(bump_left=True))  # must not raise
    assert layer.state is S.FAULT
    assert layer.fault_reason == f"wheel write failed: {type(exc).__name__}: {exc}"
    # The second failed stop (on entering fault) has the same reason: recorded once.
    assert event_names(layer)[-3:] == [("drive", "driving"), ("bump", "bumped"), ("fault", "fault")]


def test_sink_error_on_a_drive_command_refuses_and_faults() -> None:
    layer, sink, _ = connected()
    sink.fail_with = serial.SerialException("port closed")
    assert layer.command(left=100, right=100) is False
    assert layer.state is S.FAULT
    assert layer.fault_reason == "wheel write failed: SerialException: port closed"
    assert layer.wheels == (0, 0)


def test_sink_error_on_stop_command_is_caught() -> None:
    layer, sink, _ = driving()
    sink.fail_with = OSError("EIO")
    assert layer.command(left=0, right=0) is False
    assert layer.state is S.FAULT


# ---------------------------------------------------------------- e-stop


def test_estop_latches_until_reset() -> None:
    layer, sink, clock = driving()
    layer.estop("operator")
    assert layer.state is S.ESTOPPED
    assert layer.fault_reason == "e-stop: operator"
    assert sink.calls == [(0, 0)]
    assert layer.command(left=100, right=100) is False
    assert layer.backoff(left=-100, right=-100) is False
    layer.on_sensors(flags(bump_left=True))
    layer.on_sensors(flags(cliff_left=True))  # faults do not replace the e-stop
    assert layer.state is S.ESTOPPED
    assert layer.reset() is False
    clock.advance(0.015)
    layer.on_sensors(CLEAR)
    assert layer.reset() is True
    assert layer.state is S.READY
    assert event_names(layer)[-2:] == [("estop", "estopped"), ("reset", "ready")]
    assert layer.events[-2].detail == "operator"


def test_estop_from_fault_and_twice() -> None:
    layer, sink, _ = driving()
    layer.on_sensors(flags(wheel_drop_left=True))
    layer.estop()
    layer.estop("again")
    assert layer.state is S.ESTOPPED
    assert layer.fault_reason == "e-stop"
    assert sink.calls == [(0, 0), (0, 0)]


def test_estop_before_connect_latches_and_resets_to_disconnected() -> None:
    layer, sink, _ = make()
    layer.estop("before start")
    assert layer.state is S.ESTOPPED
    layer.connect()
    assert layer.state is S.ESTOPPED  # connect cannot bypass the e-stop
    assert sink.calls == []
    assert layer.reset() is True
    assert layer.state is S.DISCONNECTED
    layer.connect()
    assert layer.state is S.READY
    assert sink.calls == [(0, 0)]


# ---------------------------------------------------------------- log and report


def test_transition_log_uses_the_injected_clock(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger="marknav.robot.safety")
    layer, _, clock = make(start=100.0)
    layer.connect()
    clock.set(100.125)
    layer.on_sensors(CLEAR)
    clock.set(100.25)
    layer.command(left=100, right=100)
    clock.set(100.265)
    layer.on_sensors(flags(bump_left=True))
    assert [(e.t, e.event, e.state) for e in layer.events] == [
        (100.0, "connect", "ready"), (100.25, "drive", "driving"), (100.265, "bump", "bumped")]
    records = [r for r in caplog.records if r.name == "marknav.robot.safety"]
    messages = [r.getMessage() for r in records]
    assert messages == [
        "t=100.000 safety connect: disconnected -> ready (link up)",
        "t=100.250 safety drive: ready -> driving",
        "t=100.265 safety bump: driving -> bumped (bump left)",
    ]
    assert records[-1].levelno == logging.WARNING


def test_events_property_is_a_copy() -> None:
    layer, _, _ = connected()
    events = layer.events
    events.clear()
    assert len(layer.events) == 1


def test_any_object_with_the_fields_is_accepted() -> None:
    class Frame:  # a mutable, non-dataclass sensor record, as a driver might have
        def __init__(self) -> None:
            for name in dataclasses.asdict(CLEAR):
                setattr(self, name, False)
            self.oi_mode = 2

    layer, sink, _ = driving()
    frame = Frame()
    frame.bump_left = True  # type: ignore[attr-defined]
    layer.on_sensors(frame)  # type: ignore[arg-type]
    assert layer.state is S.BUMPED
    assert sink.calls == [(0, 0)]


# ---------------------------------------------------------------- found by mutation testing


def details(layer: SafetyLayer) -> list[tuple[str, str, str]]:
    return [(e.event, e.state, e.detail) for e in layer.events]


def test_every_stop_records_why() -> None:
    layer, _, _ = driving()
    assert layer.command(left=0, right=0) is True
    assert layer.command(left=100, right=100) is True
    layer.stop()
    assert layer.command(left=100, right=100) is True
    with pytest.raises(ValueError):
        layer.command(left=math.nan, right=100)
    assert details(layer)[-5:] == [
        ("stop", "ready", "zero command"), ("drive", "driving", ""),
        ("stop", "ready", "stop()"), ("drive", "driving", ""),
        ("stop", "ready", "non-finite command")]


def test_a_failed_wheel_write_refuses_the_command_and_names_the_error() -> None:
    layer, sink, _ = driving()
    sink.fail_with = serial.SerialException("write timeout")
    assert layer.command(left=120, right=120) is False
    assert layer.state is S.FAULT
    assert layer.fault_reason == "wheel write failed: SerialException: write timeout"


def test_backoff_is_only_backward_even_by_a_fraction() -> None:
    layer, sink, _ = connected()
    layer.on_sensors(flags(bump_left=True))
    sink.clear()
    assert layer.backoff(left=0.6, right=-100) is False  # rounds to 1 mm/s forward
    assert layer.backoff(left=0.0, right=-100) is True
    assert sink.calls == [(0, -100)]


def test_reset_refusals_say_what_blocks_them(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger="marknav.robot.safety")
    layer, _, clock = make(sensor_timeout_s=0.25)
    layer.connect()
    layer.estop("test")
    assert layer.reset() is False  # connected, but no frame yet
    layer.on_sensors(flags(oi_mode=1))
    assert layer.reset() is False
    layer.on_sensors(flags(oi_mode=7))
    assert layer.reset() is False
    refusals = [r.getMessage() for r in caplog.records if "reset refused" in r.getMessage()]
    assert refusals == [
        "safety: reset refused: no sensor frame yet",
        "safety: reset refused: OI mode is passive (1), not safe or full",
        "safety: reset refused: OI mode is unknown (7), not safe or full"]
    # a frame exactly sensor_timeout_s old is still fresh
    clock.set(0.5)
    layer.on_sensors(CLEAR)
    clock.set(0.75)
    assert layer.reset() is True and layer.state is S.READY
    assert details(layer)[-1] == ("reset", "ready", "cleared: e-stop: test")


def test_after_a_reset_the_next_fault_starts_afresh() -> None:
    layer, _, clock = driving()
    layer.on_sensors(flags(cliff_left=True))
    layer.on_sensors(CLEAR)
    assert layer.reset() is True
    # the old command does not count for the watchdog; the old reasons are gone
    for _ in range(10):
        clock.advance(0.1)
        layer.on_sensors(CLEAR)
        layer.poll()
    assert layer.state is S.READY
    assert layer.command(left=100, right=100) is True
    layer.on_sensors(flags(wheel_drop_right=True))
    layer.on_sensors(CLEAR)
    assert layer.fault_reason == "wheel drop right"
    assert layer.reset() is True
    assert details(layer)[-1] == ("reset", "ready", "cleared: wheel drop right")
    layer.on_link_lost("")
    assert layer.fault_reason == "serial link lost"


def test_bump_back_off_and_timeout_events_record_why() -> None:
    layer, _, clock = connected(sensor_timeout_s=0.25)
    layer.on_sensors(flags(bump_right=True))
    assert layer.backoff(left=-80, right=-80) is True
    layer.on_sensors(CLEAR)
    assert details(layer)[-2:] == [("bump", "bumped", "bump right"),  # back-off not recorded
                                   ("bump_cleared", "ready", "no bump in frame")]
    # a frame exactly sensor_timeout_s old is not late; a moment later it is
    clock.set(0.125)
    layer.on_sensors(CLEAR)
    clock.set(0.375)
    layer.poll()
    assert layer.state is S.READY
    clock.set(0.425)
    layer.poll()
    assert details(layer)[-1] == ("sensor_timeout", "fault",
                                  "no sensor frame for 0.300 s (limit 0.25 s)")


def test_a_wheel_write_that_raises_anything_faults_with_its_name() -> None:
    layer, sink, _ = driving()
    sink.fail_with = RuntimeError("adapter gone")
    assert layer.command(left=150, right=150) is False
    assert layer.fault_reason == "wheel write failed: RuntimeError: adapter gone"


def test_the_smallest_wheel_limit_is_accepted() -> None:
    layer, sink, _ = connected(max_wheel_mm_s=1)
    assert layer.command(left=300, right=150) is True
    assert sink.calls == [(1, 0)]  # both scaled by one factor: 1 and 0.5, rounded to even


def test_every_transition_and_sink_write_runs_under_the_layers_lock() -> None:
    """The machine has no lock of its own: each public entry takes the layer's RLock before
    any transition, so every wheel write (transitions' callbacks included) happens under it."""
    clock = ManualClock(0.0)
    holders: list[bool] = []

    class CheckingSink(RecordingSink):
        def drive_direct(self, *, left: int, right: int) -> None:
            holders.append(layer._lock._is_owned())  # type: ignore[attr-defined]
            super().drive_direct(left=left, right=right)

    sink = CheckingSink(clock)
    layer = SafetyLayer(sink, clock=clock)
    layer.connect()
    layer.on_sensors(CLEAR)
    assert layer.command(left=100, right=100)  # ready -> driving
    assert layer.command(left=120, right=100)  # driving: direct write
    layer.stop()  # driving -> ready
    assert layer.command(left=100, right=100)
    layer.on_sensors(flags(bump_left=True))  # bump: zero written on this thread
    assert layer.backoff(left=-50, right=-50)
    layer.on_sensors(CLEAR)  # bump cleared -> ready
    clock.advance(5.0)
    layer.poll()  # sensor timeout -> fault
    layer.estop("test")
    assert layer.state is S.ESTOPPED
    assert len(holders) >= 8 and all(holders)
