"""Serial transport: open any pyserial URL for the Create's Open Interface.

Everything goes through :func:`serial.serial_for_url`, so device paths (``/dev/ttyUSB0``,
``COM3``), ``socket://host:port``, ``rfc2217://host:port`` and the in-process simulator
(``createsim://``, see :mod:`marknav.sim.protocol_createsim`) all work. The OI wants 8N1 with no
flow control (OI spec "Serial Port Settings"): software flow control would eat 0x11/0x13, which
occur in sensor data, so XON/XOFF, RTS/CTS and DSR/DTR are all off. Linux serial devices are
asked for low-latency mode where the driver supports it.

A device path is opened *exclusively* (pyserial's ``exclusive=True``: an advisory ``flock`` on
POSIX): a second marknav — or anything else that asks for the same lock — on the same robot is
refused with "port busy" instead of stealing bytes from the sensor stream, which the first one
would see as garbled frames and a lost link.
"""

from __future__ import annotations

import logging
from typing import Protocol

import serial

from marknav.core.errors import InputError

__all__ = ["LINK_ERRORS", "SerialPort", "open_port", "register_url_schemes"]

log = logging.getLogger(__name__)

#: Exceptions that mean the serial link failed (unplugged cable, closed pty master, dead socket).
LINK_ERRORS: tuple[type[BaseException], ...] = (serial.SerialException, OSError)


class SerialPort(Protocol):
    """The part of ``serial.Serial`` the driver uses."""

    @property
    def in_waiting(self) -> int: ...

    def read(self, size: int = 1) -> bytes: ...

    def write(self, data: bytes, /) -> int | None: ...

    def reset_input_buffer(self) -> None: ...

    def close(self) -> None: ...


def register_url_schemes() -> None:
    """Let ``serial_for_url`` resolve marknav's schemes (``createsim://``). Idempotent."""
    if "marknav.sim" not in serial.protocol_handler_packages:
        serial.protocol_handler_packages.append("marknav.sim")


def open_port(
    url: str, *, baudrate: int, timeout: float | None = 0.015, write_timeout: float | None = 0.5
) -> SerialPort:
    """Open ``url`` (device path or pyserial URL) at ``baudrate``, 8N1, no flow control.

    ``timeout`` bounds each read (the reader thread wakes at least that often);
    ``write_timeout`` turns a stuck link into an exception instead of a hang.
    Raises :class:`~marknav.core.errors.InputError` naming the port when it cannot be opened.
    """
    register_url_schemes()
    if url.lower().startswith("rfc2217://"):
        write_timeout = None  # pyserial's RFC 2217 client raises NotImplementedError for one
    extra: dict[str, bool] = {}
    if is_device_path(url):
        extra["exclusive"] = True
    try:
        port = serial.serial_for_url(
            url,
            baudrate=baudrate,
            bytesize=serial.EIGHTBITS,
            parity=serial.PARITY_NONE,
            stopbits=serial.STOPBITS_ONE,
            xonxoff=False,
            rtscts=False,
            dsrdtr=False,
            timeout=timeout,
            write_timeout=write_timeout,
            **extra,
        )
    except (serial.SerialException, OSError, ValueError, NotImplementedError) as exc:
        if "exclusively lock" in str(exc):
            raise InputError(f"port busy: another program has it open ({exc})",
                             file=url) from exc
        raise InputError(f"cannot open serial port: {exc}", file=url) from exc
    _try_low_latency(port, url)
    log.info("opened %s at %d baud", url, baudrate)
    return port


def is_device_path(url: str) -> bool:
    """A device (``/dev/ttyUSB0``, ``COM3``), not a pyserial URL (``socket://…``)."""
    return "://" not in url


def _try_low_latency(port: object, url: str) -> None:
    """Ask a USB-serial adapter for low latency (FTDI chips otherwise hold received bytes up to
    16 ms, a whole stream period). Devices without the option (ptys, sockets) are left alone."""
    setter = getattr(port, "set_low_latency_mode", None)
    if setter is None:
        return
    try:
        setter(True)
    except (NotImplementedError, ValueError, OSError, TypeError) as exc:
        log.debug("%s: low-latency mode not available (%s)", url, exc)
    else:
        log.info("%s: low-latency mode on", url)
