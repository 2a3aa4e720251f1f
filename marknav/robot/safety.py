"""Safety layer: a latched state machine between every wheel command and the Create's wire.

What it implements, from the Create Open Interface specifications (``shared/reference/``):

- *Open Interface Modes*: Safe mode stops the motors by itself on a cliff (moving forward), a wheel
  drop or a charger, and then reverts to **Passive**; it does **not** stop on a bump, and nothing in
  the robot stops a wheel command that is never followed by another. This layer adds the missing
  stops: bumps, a command watchdog and a sensor watchdog, and treats an unexpected drop to Passive
  as a fault.
- Packet 7 (*Bumps and Wheel Drops*), packets 9-12 (*Cliff Left / Front Left / Front Right /
  Right*), packet 14 (*Wheel Overcurrents*), packets 25/26 (*Battery Charge / Capacity*: a charge
  under :data:`LOW_BATTERY_FRACTION` of capacity is a fault) and packet 35 (*OI Mode*: 0 off,
  1 passive, 2 safe, 3 full) are the inputs, read through the small :class:`SafetyInputs`
  protocol so this module does not depend on the wire decoder.
- *Drive Direct* (opcode 145, ±500 mm/s per wheel) is the output, through :class:`WheelSink`.
  Speeds over the limit are scaled together (the curve is kept) and rounded to whole mm/s.

States and events: a ``transitions.Machine`` over :class:`SafetyState` with
``auto_transitions=False``, so no ``to_<state>()`` jumps past the guards. Its transition table, in
:class:`SafetyLayer`'s constructor, is the only drawing of the chart:
:func:`marknav.robot.safety_chart.safety_chart` renders it, and the documentation's page on the
safety machine (``docs/explanation/safety.md``) shows that rendering. In short: ``connect`` leads
to ``ready``, ``drive`` to ``driving``, a bump to the latched ``bumped``, a fault or a silent
sensor stream to the latched ``fault``, ``estop`` to ``estopped``, and ``reset`` (with the
condition gone) back to ``ready`` — to ``bumped`` while a bumper is still pressed, and to
``disconnected`` after an e-stop made before any connect.

Every way into ``ready``, ``bumped``, ``fault`` and ``e-stopped`` writes a zero Drive Direct as the
state is entered (once connected; before connect() nothing is written). A sink that raises
(``serial.SerialException`` is an ``OSError``) latches ``fault``; nothing is re-raised.
In ``bumped``, ``fault`` and ``e-stopped`` a non-zero command is refused (``False``); zero
commands always pass. To back away from an obstacle while ``bumped``, use
:meth:`SafetyLayer.backoff`: it lets through only motions with both wheels <= 0.

Threading: one re-entrant lock is held around every transition *and*
every sink write, so a bump seen by the reader thread inside :meth:`SafetyLayer.on_sensors` writes
its zero before any later command can reach the sink, and on the reader's own thread. The sink
therefore runs under this lock: a driver must not call into the layer while it holds a lock that
its ``drive_direct`` also takes, or the two threads can deadlock. No timer threads: timeouts are
checked in :meth:`SafetyLayer.poll` and on every command and sensor frame, against an injected
:class:`~marknav.core.clock.Clock`.
"""

from __future__ import annotations

import logging
import math
import threading
from dataclasses import dataclass
from enum import Enum
from typing import Any, Protocol

from transitions import Machine

from marknav.core.clock import Clock

__all__ = [
    "EVENTS",
    "LOW_BATTERY_FRACTION",
    "OI_MODE_NAMES",
    "SafetyEvent",
    "SafetyFlags",
    "SafetyInputs",
    "SafetyLayer",
    "SafetyState",
    "WheelSink",
    "fault_conditions",
    "scale_wheels",
]

logger = logging.getLogger(__name__)

#: Largest wheel speed the Drive Direct command accepts (OI spec, opcode 145), mm/s.
OI_MAX_WHEEL_MM_S = 500

#: OI mode numbers (packet 35) and their names.
OI_MODE_NAMES: dict[int, str] = {0: "off", 1: "passive", 2: "safe", 3: "full"}
_ACTIVE_MODES = frozenset({2, 3})

#: Every event the machine knows, in the order of the module docstring.
EVENTS: tuple[str, ...] = (
    "connect", "drive", "backoff", "stop", "bump", "bump_cleared", "fault", "reset",
    "command_timeout", "sensor_timeout", "estop",
)


class SafetyState(Enum):
    """States of the safety layer; the value is the name used in logs and reports."""

    DISCONNECTED = "disconnected"
    READY = "ready"  # connected, Safe mode, wheels stopped
    DRIVING = "driving"
    BUMPED = "bumped"  # latched until a frame without bump
    FAULT = "fault"  # latched until reset()
    ESTOPPED = "estopped"  # latched until reset()


_S = SafetyState
_CONNECTED = frozenset({_S.READY, _S.DRIVING, _S.BUMPED})
_LATCHED = frozenset({_S.FAULT, _S.ESTOPPED})
# Events recorded even when the state does not change (internal transitions worth a report line).
_RECORDED_INTERNAL = frozenset({"command_timeout", "fault"})
_WARNING_EVENTS = frozenset({"bump", "fault", "command_timeout", "sensor_timeout", "estop"})


class SafetyInputs(Protocol):
    """The sensor fields the safety layer reads from one stream frame (read-only)."""

    @property
    def bump_left(self) -> bool: ...
    @property
    def bump_right(self) -> bool: ...
    @property
    def wheel_drop_left(self) -> bool: ...
    @property
    def wheel_drop_right(self) -> bool: ...
    @property
    def caster_drop(self) -> bool: ...
    @property
    def cliff_left(self) -> bool: ...
    @property
    def cliff_front_left(self) -> bool: ...
    @property
    def cliff_front_right(self) -> bool: ...
    @property
    def cliff_right(self) -> bool: ...
    @property
    def overcurrent_left_wheel(self) -> bool: ...
    @property
    def overcurrent_right_wheel(self) -> bool: ...
    @property
    def charge_mah(self) -> int:
        """Battery charge, mAh (packet 25)."""
        ...
    @property
    def capacity_mah(self) -> int:
        """Battery capacity, mAh (packet 26; 0: unknown, no battery check)."""
        ...
    @property
    def oi_mode(self) -> int:
        """0 off, 1 passive, 2 safe, 3 full (packet 35)."""
        ...


class WheelSink(Protocol):
    """Where wheel speeds go: the driver's Drive Direct writer (mm/s, already in range)."""

    def drive_direct(self, *, left: int, right: int) -> None: ...


@dataclass(frozen=True)
class SafetyFlags:
    """A plain :class:`SafetyInputs` value: all clear, Safe mode, unless told otherwise.

    For tests, benchmarks and fakes that have no decoded sensor frame at hand.
    """

    bump_left: bool = False
    bump_right: bool = False
    wheel_drop_left: bool = False
    wheel_drop_right: bool = False
    caster_drop: bool = False
    cliff_left: bool = False
    cliff_front_left: bool = False
    cliff_front_right: bool = False
    cliff_right: bool = False
    overcurrent_left_wheel: bool = False
    overcurrent_right_wheel: bool = False
    charge_mah: int = 0
    capacity_mah: int = 0
    oi_mode: int = 2


@dataclass(frozen=True)
class SafetyEvent:
    """One recorded transition: clock time, event name, state after it, and why."""

    t: float
    event: str
    state: str
    detail: str = ""

    def to_dict(self) -> dict[str, float | str]:
        """``{t, event, state, detail}`` for the run report's ``safety_events``."""
        return {"t": self.t, "event": self.event, "state": self.state, "detail": self.detail}


_FAULT_FIELDS: tuple[tuple[str, str], ...] = (
    ("wheel_drop_left", "wheel drop left"),
    ("wheel_drop_right", "wheel drop right"),
    ("caster_drop", "caster drop"),
    ("cliff_left", "cliff left"),
    ("cliff_front_left", "cliff front left"),
    ("cliff_front_right", "cliff front right"),
    ("cliff_right", "cliff right"),
    ("overcurrent_left_wheel", "overcurrent left wheel"),
    ("overcurrent_right_wheel", "overcurrent right wheel"),
)


#: A battery charge under this fraction of its capacity is a fault: the pack's voltage collapses
#: near empty (a NiMH cell falls from 1.2 V towards 1.0 V), the motors lose speed and the robot
#: may brown out mid-motion; the Roomba itself goes home to its dock long before.
LOW_BATTERY_FRACTION = 0.05


def fault_conditions(inputs: SafetyInputs) -> list[str]:
    """Names of the latched-fault conditions present in a frame (wheel drops, cliffs,
    overcurrents, a battery under :data:`LOW_BATTERY_FRACTION` of its capacity).

    The OI mode is judged separately (a drop to Passive is a fault only once Safe/Full was seen).
    """
    out = [name for attr, name in _FAULT_FIELDS if getattr(inputs, attr)]
    capacity = inputs.capacity_mah
    if capacity > 0 and inputs.charge_mah < LOW_BATTERY_FRACTION * capacity:
        out.append(f"low battery ({inputs.charge_mah} of {capacity} mAh)")
    return out


def scale_wheels(left: float, right: float, max_wheel_mm_s: int) -> tuple[int, int]:
    """Scale both wheels by one factor so neither exceeds ``max_wheel_mm_s``; round to int mm/s.

    Scaling both (never clamping one) keeps the commanded curvature (architecture.md, *Wheels*).
    Raises ``ValueError`` for a non-finite speed.
    """
    if not (math.isfinite(left) and math.isfinite(right)):
        raise ValueError(f"wheel speeds must be finite, got left={left!r}, right={right!r}")
    peak = max(abs(left), abs(right))
    if peak > max_wheel_mm_s:
        factor = max_wheel_mm_s / peak
        left, right = left * factor, right * factor
    lo, hi = -max_wheel_mm_s, max_wheel_mm_s
    return min(hi, max(lo, round(left))), min(hi, max(lo, round(right)))


class _Model:
    """The object whose ``state`` the machine drives (kept apart so its triggers stay private)."""

    state: SafetyState


class SafetyLayer:
    """Latched safety state machine in front of a :class:`WheelSink` (see the module docstring).

    Thread-safe: the driver's reader thread calls :meth:`on_sensors`, :meth:`poll` and
    :meth:`on_link_lost`; the controller calls :meth:`command`, :meth:`backoff`, :meth:`stop` and
    :meth:`poll`. No method raises on a serial failure; bad arguments raise ``ValueError``.
    """

    def __init__(
        self,
        sink: WheelSink,
        *,
        clock: Clock,
        command_timeout_s: float = 0.3,
        sensor_timeout_s: float = 0.2,
        max_wheel_mm_s: int = 500,
    ) -> None:
        for name, value in (("command_timeout_s", command_timeout_s),
                            ("sensor_timeout_s", sensor_timeout_s)):
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number of seconds, got {value!r}")
        if isinstance(max_wheel_mm_s, bool) or not isinstance(max_wheel_mm_s, int) or not (
            0 < max_wheel_mm_s <= OI_MAX_WHEEL_MM_S
        ):
            raise ValueError(f"max_wheel_mm_s must be an integer in 1..{OI_MAX_WHEEL_MM_S}, "
                             f"got {max_wheel_mm_s!r}")
        self._sink = sink
        self._clock = clock
        self._command_timeout_s = float(command_timeout_s)
        self._sensor_timeout_s = float(sensor_timeout_s)
        self._max_wheel = max_wheel_mm_s

        self._lock = threading.RLock()
        self._events: list[SafetyEvent] = []
        self._reasons: list[str] = []  # why we are latched in fault / e-stop
        self._wheels: tuple[int, int] = (0, 0)  # last speeds the sink accepted
        self._write_error: str | None = None  # set by a failed sink write, handled by _fire
        self._connected = False
        self._connect_t: float | None = None
        self._last_cmd_t: float | None = None
        self._sensors: SafetyInputs | None = None
        self._last_sensors_t: float | None = None
        self._seen_active_mode = False

        self._model = _Model()
        conn = [_S.READY, _S.DRIVING, _S.BUMPED]
        # Every trigger runs under our own RLock (each public method takes it before _fire), so
        # transitions and sink writes share one lock. A plain Machine, not transitions'
        # LockedMachine: its locking would take the same lock again and wraps every attribute
        # access of the machine (~70 per transition): a stop or a start cost ~55 us instead of
        # ~17 us, in the control cycles where a behaviour hands the wheels over.
        table: list[Any] = [
            {"trigger": "connect", "source": _S.DISCONNECTED, "dest": _S.READY},
            {"trigger": "drive", "source": _S.READY, "dest": _S.DRIVING,
             "after": self._write_command},
            {"trigger": "drive", "source": _S.DRIVING, "dest": None,
             "after": self._write_command},
            {"trigger": "backoff", "source": _S.BUMPED, "dest": None,
             "conditions": self._is_backward, "after": self._write_command},
            {"trigger": "stop", "source": _S.DRIVING, "dest": _S.READY},
            {"trigger": "stop", "source": [_S.READY, _S.BUMPED, _S.FAULT, _S.ESTOPPED],
             "dest": None, "after": self._halt},
            {"trigger": "bump", "source": [_S.READY, _S.DRIVING], "dest": _S.BUMPED},
            {"trigger": "bump_cleared", "source": _S.BUMPED, "dest": _S.READY},
            {"trigger": "fault", "source": conn, "dest": _S.FAULT},
            {"trigger": "fault", "source": _S.FAULT, "dest": None},
            {"trigger": "command_timeout", "source": _S.DRIVING, "dest": _S.READY},
            {"trigger": "command_timeout", "source": _S.BUMPED, "dest": None,
             "after": self._halt},
            {"trigger": "sensor_timeout", "source": conn, "dest": _S.FAULT},
            {"trigger": "estop", "source": [s for s in SafetyState if s is not _S.ESTOPPED],
             "dest": _S.ESTOPPED},
            {"trigger": "reset", "source": _S.ESTOPPED, "dest": _S.DISCONNECTED,
             "conditions": self._never_connected},
            {"trigger": "reset", "source": [_S.FAULT, _S.ESTOPPED], "dest": _S.BUMPED,
             "conditions": [self._clear_to_reset, self._bump_pressed]},
            {"trigger": "reset", "source": [_S.FAULT, _S.ESTOPPED], "dest": _S.READY,
             "conditions": self._clear_to_reset},
        ]
        self._machine = Machine(
            model=self._model,
            states=SafetyState,
            initial=_S.DISCONNECTED,
            transitions=table,
            auto_transitions=False,
            ignore_invalid_triggers=False,
            name="safety",
        )
        for stopped in (_S.READY, _S.BUMPED, _S.FAULT, _S.ESTOPPED):
            self._machine.get_state(stopped).add_callback("enter", self._halt)

    # ------------------------------------------------------------------ properties

    @property
    def state(self) -> SafetyState:
        """The current state."""
        with self._lock:
            return self._model.state

    @property
    def events(self) -> list[SafetyEvent]:
        """A copy of the recorded transitions, oldest first."""
        with self._lock:
            return list(self._events)

    @property
    def fault_reason(self) -> str | None:
        """Why the layer is latched in ``fault`` or ``e-stopped`` (``"; "``-joined), else None."""
        with self._lock:
            if self._model.state in _LATCHED and self._reasons:
                return "; ".join(self._reasons)
            return None

    @property
    def bumped(self) -> bool:
        """True while the layer is in the ``bumped`` state."""
        return self.state is _S.BUMPED

    @property
    def last_sensors_t(self) -> float | None:
        """Clock time of the latest sensor frame, None before the first."""
        with self._lock:
            return self._last_sensors_t

    @property
    def wheels(self) -> tuple[int, int]:
        """(left, right) mm/s last accepted by the sink."""
        with self._lock:
            return self._wheels

    @property
    def machine(self) -> Machine:
        """The underlying ``transitions`` machine (for inspection and diagrams; do not trigger)."""
        return self._machine

    # ------------------------------------------------------------------ public API

    def connect(self) -> None:
        """Mark the link up (port open, OI in Safe mode, stream requested): ready, wheels zeroed.

        The sensor watchdog counts from here, so call it once the stream has been requested.
        Ignored (with a log line) in any state but ``disconnected``.
        """
        with self._lock:
            if self._model.state is not _S.DISCONNECTED:
                logger.info("safety: connect ignored in state %s", self._model.state.value)
                return
            self._connected = True
            self._connect_t = self._clock.now()
            self._fire("connect", "link up")

    def command(self, *, left: float, right: float) -> bool:
        """Send a wheel command (mm/s) if the state allows it; return whether it reached the sink.

        Over ``max_wheel_mm_s`` both wheels are scaled by one factor, then rounded. A non-zero
        command moves ``ready`` to ``driving``; a zero one (after rounding) moves ``driving`` to
        ``ready`` and passes in every connected or latched state. Non-zero commands are refused in
        ``bumped``, ``fault``, ``e-stopped`` and ``disconnected``. A non-finite speed stops the
        wheels and raises ``ValueError``.
        """
        return self._command("command", left, right)

    def backoff(self, *, left: float, right: float) -> bool:
        """Like :meth:`command`, but while ``bumped`` lets through a motion with both wheels <= 0.

        This is how a recovery behaviour backs away from what it hit. The state stays ``bumped``
        until a frame without bump arrives (``bump_cleared`` -> ``ready``, which zeroes the wheels;
        keep calling :meth:`backoff` or :meth:`command` to go on moving). The command watchdog
        applies to the back-off motion too. In other states it behaves exactly like
        :meth:`command`.
        """
        return self._command("backoff", left, right)

    def stop(self) -> None:
        """Zero the wheels; ``driving`` goes to ``ready``. A no-op when disconnected."""
        with self._lock:
            self._fire("stop", "stop()")

    def on_sensors(self, state: SafetyInputs) -> None:
        """Take one decoded sensor frame (called by the reader thread, or the simulator).

        A wheel drop, cliff, wheel overcurrent or a drop to Passive/Off (after Safe or Full was
        seen) latches ``fault``; a bump latches ``bumped``; both write the zero command here, on
        the caller's thread, before returning. A frame that arrives more than
        ``sensor_timeout_s`` after the previous one first trips the sensor watchdog.
        """
        with self._lock:
            now = self._clock.now()
            self._check_sensor_timeout(now)
            self._sensors = state
            self._last_sensors_t = now
            if state.oi_mode in _ACTIVE_MODES:
                self._seen_active_mode = True
            current = self._model.state
            if current in _CONNECTED:
                faults = fault_conditions(state)
                if self._seen_active_mode and state.oi_mode not in _ACTIVE_MODES:
                    mode = OI_MODE_NAMES.get(state.oi_mode, "unknown")
                    faults.append(f"OI mode dropped to {mode} ({state.oi_mode})")
                if faults:
                    self._fault(", ".join(faults))
                elif state.bump_left or state.bump_right:
                    if current is not _S.BUMPED:
                        self._fire("bump", _bump_detail(state))
                elif current is _S.BUMPED:
                    self._fire("bump_cleared", "no bump in frame")
            self._check_command_timeout(now)

    def poll(self) -> None:
        """Check the command and sensor watchdogs against the clock (call often, both threads)."""
        with self._lock:
            now = self._clock.now()
            self._check_sensor_timeout(now)
            self._check_command_timeout(now)

    def on_link_lost(self, message: str) -> None:
        """The serial port failed (the driver caught ``SerialException``): latch ``fault``.

        Never raises. A stop is still attempted in case the write side works.
        """
        with self._lock:
            detail = f"serial link lost: {message}" if message else "serial link lost"
            if self._model.state is _S.DISCONNECTED:
                logger.warning("safety: %s (while disconnected)", detail)
                return
            self._fault(detail)

    def estop(self, reason: str = "") -> None:
        """Emergency stop: zero the wheels and latch ``e-stopped`` until :meth:`reset`."""
        with self._lock:
            if self._model.state is _S.ESTOPPED:
                logger.warning("safety: e-stop again (%s) while e-stopped", reason or "no reason")
                return
            self._reasons = [f"e-stop: {reason}" if reason else "e-stop"]
            self._fire("estop", reason)

    def reset(self) -> bool:
        """Leave ``fault`` or ``e-stopped`` once the condition is gone; return whether it did.

        Needs a sensor frame no older than ``sensor_timeout_s`` showing no wheel drop, cliff or
        overcurrent and the OI in Safe or Full mode (after a drop to Passive, send Safe again
        first). Goes to ``bumped`` if a bumper is still pressed, else ``ready``; the wheels are
        zeroed either way. An e-stop made before any :meth:`connect` resets to ``disconnected``.
        """
        with self._lock:
            current = self._model.state
            if current not in _LATCHED:
                logger.info("safety: reset ignored in state %s", current.value)
                return False
            if self._connected:
                blockers = self._reset_blockers(self._clock.now())
                if blockers:
                    logger.warning("safety: reset refused: %s", "; ".join(blockers))
                    return False
            cleared = "; ".join(self._reasons)
            ok = self._fire("reset", f"cleared: {cleared}" if cleared else "")
            if self._model.state not in _LATCHED:
                self._reasons = []
                self._last_cmd_t = None
            return ok

    # ------------------------------------------------------------------ internals

    def _command(self, kind: str, left: float, right: float) -> bool:
        with self._lock:
            now = self._clock.now()
            try:
                lw, rw = scale_wheels(left, right, self._max_wheel)
            except ValueError:
                logger.error("safety: non-finite wheel command (left=%r, right=%r): stopping",
                             left, right)
                self._fire("stop", "non-finite command")
                raise
            self._check_sensor_timeout(now)
            self._check_command_timeout(now)
            current = self._model.state
            if (lw, rw) == (0, 0):
                ok = self._fire("stop", "zero command")
            elif current is _S.DRIVING:
                # Already driving: the internal 'drive' transition only writes the wheels (and
                # is not recorded), so write them directly. Going through the machine's trigger
                # cost a third of a mission tree's tick at 20 Hz.
                ok = self._write_checked(lw, rw)
            elif current is _S.READY:
                ok = self._fire("drive", "", left=lw, right=rw)
            elif current is _S.BUMPED and kind == "backoff":
                ok = self._fire("backoff", "", left=lw, right=rw)
                if not ok:
                    logger.debug("safety: back-off (%d, %d) refused: not backwards", lw, rw)
            else:
                logger.debug("safety: %s (%d, %d) refused in state %s", kind, lw, rw,
                             current.value)
                ok = False
            if ok:
                self._last_cmd_t = now
            return ok

    def _fire(self, event: str, detail: str = "", **kwargs: int) -> bool:
        """Trigger ``event`` if valid from the current state; record it; handle write failures.

        Returns True when the transition ran and every sink write in it succeeded.
        """
        before = self._model.state
        if before.name not in self._machine.events[event].transitions:
            return False
        self._write_error = None
        ok = self._machine.events[event].trigger(self._model, **kwargs)
        after = self._model.state
        if ok and (after is not before or event in _RECORDED_INTERNAL):
            self._record(event, before, after, detail)
        error, self._write_error = self._write_error, None
        if error is not None:
            self._fault(f"wheel write failed: {error}")
            return False
        return ok

    def _fault(self, detail: str) -> None:
        current = self._model.state
        if current is _S.FAULT:
            if detail in self._reasons:
                return
            self._reasons.append(detail)
        elif current in _CONNECTED:
            self._reasons = [detail]
        else:
            logger.warning("safety: fault in state %s: %s", current.value, detail)
            return
        self._fire("fault", detail)

    def _record(self, event: str, before: SafetyState, after: SafetyState, detail: str) -> None:
        t = self._clock.now()
        self._events.append(SafetyEvent(t=t, event=event, state=after.value, detail=detail))
        level = logging.WARNING if event in _WARNING_EVENTS else logging.INFO
        logger.log(level, "t=%.3f safety %s: %s -> %s%s", t, event, before.value, after.value,
                   f" ({detail})" if detail else "")

    def _check_sensor_timeout(self, now: float) -> None:
        if self._model.state not in _CONNECTED:
            return
        connect_t, sensors_t = self._connect_t, self._last_sensors_t  # the later one counts
        if sensors_t is None:
            if connect_t is None:
                return
            ref = connect_t
        else:
            ref = sensors_t if connect_t is None else max(connect_t, sensors_t)
        gap = now - ref
        if gap > self._sensor_timeout_s:
            since = "sensor frame" if self._last_sensors_t == ref else "sensor frame since connect"
            detail = f"no {since} for {gap:.3f} s (limit {self._sensor_timeout_s:g} s)"
            self._reasons = [detail]
            self._fire("sensor_timeout", detail)

    def _check_command_timeout(self, now: float) -> None:
        current = self._model.state
        moving = current is _S.DRIVING or (current is _S.BUMPED and self._wheels != (0, 0))
        if not moving or self._last_cmd_t is None:
            return
        gap = now - self._last_cmd_t
        if gap > self._command_timeout_s:
            self._fire("command_timeout",
                       f"no command for {gap:.3f} s (limit {self._command_timeout_s:g} s)")

    def _reset_blockers(self, now: float) -> list[str]:
        sensors, t = self._sensors, self._last_sensors_t
        if sensors is None or t is None:
            return ["no sensor frame yet"]
        blockers: list[str] = []
        age = now - t
        if age > self._sensor_timeout_s:
            blockers.append(f"latest sensor frame is {age:.3f} s old "
                            f"(limit {self._sensor_timeout_s:g} s)")
        blockers.extend(f"{name} present" for name in fault_conditions(sensors))
        if sensors.oi_mode not in _ACTIVE_MODES:
            mode = OI_MODE_NAMES.get(sensors.oi_mode, "unknown")
            blockers.append(f"OI mode is {mode} ({sensors.oi_mode}), not safe or full")
        return blockers

    # machine callbacks (receive the trigger's keyword arguments)

    def _write(self, left: int, right: int) -> None:
        try:
            self._sink.drive_direct(left=left, right=right)
        except OSError as exc:  # serial.SerialException is an OSError
            self._write_error = f"{type(exc).__name__}: {exc}"
            logger.error("safety: drive_direct(left=%d, right=%d) failed: %s", left, right,
                         self._write_error)
        except Exception as exc:  # a stop must never leave the machine half-way
            self._write_error = f"{type(exc).__name__}: {exc}"
            logger.exception("safety: drive_direct(left=%d, right=%d) raised", left, right)
        else:
            self._wheels = (left, right)

    def _write_checked(self, left: int, right: int) -> bool:
        """Write outside a transition; a failed write latches a fault, as in :meth:`_fire`."""
        self._write_error = None
        self._write(left, right)
        error, self._write_error = self._write_error, None
        if error is not None:
            self._fault(f"wheel write failed: {error}")
            return False
        return True

    def _write_command(self, *, left: int, right: int) -> None:
        self._write(left, right)

    def _halt(self, *args: object, **kwargs: object) -> None:
        if self._connected:
            self._write(0, 0)

    def _is_backward(self, *, left: int, right: int) -> bool:
        return left <= 0 and right <= 0

    def _never_connected(self, *args: object, **kwargs: object) -> bool:
        return not self._connected

    def _clear_to_reset(self, *args: object, **kwargs: object) -> bool:
        return not self._reset_blockers(self._clock.now())

    def _bump_pressed(self, *args: object, **kwargs: object) -> bool:
        s = self._sensors
        return s is not None and (s.bump_left or s.bump_right)


def _bump_detail(state: SafetyInputs) -> str:
    sides = [side for side, hit in (("left", state.bump_left), ("right", state.bump_right)) if hit]
    return "bump " + " and ".join(sides)

