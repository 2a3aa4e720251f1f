"""pyserial URL handler for ``createsim://``: the simulated Create as an in-process serial port.

pyserial's :func:`serial.serial_for_url` imports ``<package>.protocol_<scheme>`` for every package
in ``serial.protocol_handler_packages`` and uses its ``Serial`` class;
:func:`marknav.robot.transport.register_url_schemes` (or :func:`register_scheme` here) adds
``marknav.sim`` to that list. URL forms::

    createsim://?model=create2            a new simulated robot on wall-clock (monotonic) time
    createsim://NAME                      the SimulatedCreate registered as NAME (its own clock)
    createsim://?model=create1&left_scale=0.97&seed=3

The port's baud rate reaches the robot (it answers only at its own: 115200 for a Create 2), and
its RTS and DTR lines reach the robot's Baud Rate Change pin where the cable wires one of them
there (``brc_line``, RTS by default): asserting the line pulls BRC low.

A new robot from the URL runs in real time: every read, write and ``in_waiting`` first catches
the simulation up to ``time.monotonic()``. A registered robot (:func:`register`) keeps its
injected clock: the port catches it up to that clock (whoever advances the clock drives the
simulation), so a simulated run stays deterministic.
"""

from __future__ import annotations

import itertools
import threading
import time
import urllib.parse
from typing import Any

import serial
from serial.serialutil import PortNotOpenError, SerialBase, SerialException

from marknav.core.clock import MonotonicClock
from marknav.sim.simulated_create import SimulatedCreate

__all__ = ["Serial", "lookup", "register", "register_scheme", "unregister"]

_REGISTRY: dict[str, SimulatedCreate] = {}
_REGISTRY_LOCK = threading.Lock()
_COUNTER = itertools.count(1)
_POLL_S = 0.002


def register_scheme() -> None:
    """Make ``serial_for_url('createsim://…')`` work in this process. Idempotent."""
    if "marknav.sim" not in serial.protocol_handler_packages:
        serial.protocol_handler_packages.append("marknav.sim")


def register(sim: SimulatedCreate, name: str | None = None) -> str:
    """Make ``sim`` reachable as ``createsim://NAME``; returns that URL."""
    register_scheme()
    with _REGISTRY_LOCK:
        if name is None:
            name = f"sim{next(_COUNTER)}"
        if not name.isidentifier():
            raise ValueError(f"a createsim name must be an identifier, got {name!r}")
        _REGISTRY[name] = sim
    return f"createsim://{name}"


def unregister(name: str) -> None:
    with _REGISTRY_LOCK:
        _REGISTRY.pop(name, None)


def lookup(name: str) -> SimulatedCreate:
    with _REGISTRY_LOCK:
        try:
            return _REGISTRY[name]
        except KeyError:
            raise SerialException(f"no simulated Create registered as {name!r}") from None


_FLOAT_OPTIONS = {"left_scale", "right_scale", "slip_std", "encoder_scale"}


def _sim_from_url(url: str) -> SimulatedCreate:
    parts = urllib.parse.urlsplit(url)
    if parts.scheme.lower() != "createsim":
        raise SerialException(f"expected a createsim:// URL, got {url!r}")
    name = parts.netloc or parts.path.strip("/")
    options = urllib.parse.parse_qs(parts.query, keep_blank_values=True)
    if name:
        if options:
            raise SerialException(f"{url}: options are not allowed with a registered name")
        return lookup(name)
    kwargs: dict[str, Any] = {}
    for key, values in options.items():
        value = values[-1]
        try:
            if key == "model":
                kwargs["model"] = value
            elif key in _FLOAT_OPTIONS:
                kwargs[key] = float(value)
            elif key == "seed":
                kwargs["seed"] = int(value)
            elif key == "brc_line":
                kwargs["brc_line"] = None if value in ("", "none") else value
            else:
                raise SerialException(
                    f"{url}: unknown option {key!r} (model, left_scale, right_scale, slip_std, "
                    "encoder_scale, seed, brc_line)")
        except ValueError as exc:
            raise SerialException(f"{url}: bad value for {key}: {exc}") from None
    try:
        return SimulatedCreate(clock=MonotonicClock(), **kwargs)
    except ValueError as exc:
        raise SerialException(f"{url}: {exc}") from None


class Serial(SerialBase):
    """A pyserial port whose other end is a :class:`SimulatedCreate`."""

    is_open: bool

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self.sim: SimulatedCreate | None = None
        super().__init__(*args, **kwargs)

    def open(self) -> None:
        if self._port is None:
            raise SerialException("Port must be configured before it can be used.")
        if self.is_open:
            raise SerialException("Port is already open.")
        self.sim = _sim_from_url(self.portstr)
        self.is_open = True
        self._reconfigure_port()

    def close(self) -> None:
        self.is_open = False
        if self.sim is not None:
            self.sim.set_line_baudrate(None)
        self.sim = None

    def _reconfigure_port(self, *args: Any, **kwargs: Any) -> None:
        """The port's baud rate goes to the simulated robot, which hears nothing at another
        rate than its own; the other line settings mean nothing to it."""
        if self.sim is not None:
            self.sim.set_line_baudrate(self._baudrate)

    def _live(self) -> SimulatedCreate:
        if not self.is_open or self.sim is None:
            raise PortNotOpenError()
        if self.sim.unplugged:
            raise SerialException("simulated Create unplugged")
        return self.sim

    @property
    def in_waiting(self) -> int:
        sim = self._live()
        sim.sync()
        return sim.in_waiting

    def read(self, size: int = 1) -> bytes:
        sim = self._live()
        deadline = None if self._timeout is None else time.monotonic() + self._timeout
        data = bytearray()
        while len(data) < size:
            sim.sync()
            data += sim.read(size - len(data))
            if len(data) >= size:
                break
            remaining = None if deadline is None else deadline - time.monotonic()
            if remaining is not None and remaining <= 0:
                break
            sim.wait_output(_POLL_S if remaining is None else min(_POLL_S, remaining))
            sim = self._live()
        return bytes(data)

    def write(self, data: bytes) -> int:
        sim = self._live()
        sim.sync()
        return sim.write(bytes(data))

    def flush(self) -> None:
        self._live()

    def reset_input_buffer(self) -> None:
        sim = self._live()
        sim.sync()
        sim.clear_output()

    def reset_output_buffer(self) -> None:
        self._live()

    def _update_break_state(self) -> None:
        pass

    def _update_rts_state(self) -> None:
        """RTS reaches the robot's BRC pin where the cable wires it there (``brc_line``)."""
        self._live().set_modem_line("rts", bool(self._rts_state))

    def _update_dtr_state(self) -> None:
        self._live().set_modem_line("dtr", bool(self._dtr_state))

    @property
    def cts(self) -> bool:
        return True

    @property
    def dsr(self) -> bool:
        return True

    @property
    def ri(self) -> bool:
        return False

    @property
    def cd(self) -> bool:
        return True
