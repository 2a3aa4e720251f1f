"""Serve a :class:`~marknav.sim.simulated_create.SimulatedCreate` on an OS pseudo-terminal.

Any program that opens the slave device (``/dev/pts/N``) talks to the simulated robot exactly as
to a USB-serial cable: our driver, pycreate2, a terminal program. The pty is put in raw mode
(``tty.setraw``): a cooked pty would treat 0x13 as XOFF and turn 13 into 10, and both bytes occur
in OI data.

The robot hears the line speed the client sets on the slave (a pty pair shares its termios: the
master reads the speed the client chose): at another rate than the robot's own nothing gets
through, as on a real cable. A pty has no modem lines, so no Baud Rate Change pulse reaches the
robot through it.

A server thread moves bytes between the pty master and the simulator and keeps the simulation
caught up with the simulator's clock (real time with a ``MonotonicClock``), waking at least at
every 15 ms stream tick. Closing the master (:meth:`PtyServer.close`) is what an unplugged cable
looks like to the client: its next read fails with ``SerialException``.
"""

from __future__ import annotations

import contextlib
import errno
import logging
import os
import select
import termios
import threading
import tty
from types import TracebackType

from marknav.sim.simulated_create import SimulatedCreate

__all__ = ["PtyServer"]

log = logging.getLogger(__name__)

_MAX_WAIT_S = 0.005
#: termios speed constants -> baud rates the OI uses.
_SPEEDS = {getattr(termios, f"B{b}"): b for b in (
    300, 600, 1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400)}
_MIN_WAIT_S = 0.0005


class PtyServer:
    """Serve ``sim`` on a new pseudo-terminal; :attr:`path` is the device to open.

    Usage::

        with PtyServer(SimulatedCreate(clock=MonotonicClock())) as server:
            driver = CreateDriver(server.path, ...)

    :meth:`start` creates the pty and the thread; :meth:`close` stops both (idempotent).
    """

    def __init__(self, sim: SimulatedCreate) -> None:
        self.sim = sim
        self._master: int | None = None
        self._slave: int | None = None
        self._path: str | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._wake_r: int | None = None
        self._wake_w: int | None = None
        self.bytes_in = 0
        self.bytes_out = 0
        self.dropped_out = 0
        self.error: str | None = None

    @property
    def path(self) -> str:
        """The slave device path (``/dev/pts/N``)."""
        if self._path is None:
            raise RuntimeError("PtyServer not started")
        return self._path

    def start(self) -> str:
        """Create the raw pty and start serving; returns the slave path."""
        if self._thread is not None:
            return self.path
        master, slave = os.openpty()
        tty.setraw(slave)
        tty.setraw(master)
        os.set_blocking(master, False)
        self._master, self._slave = master, slave
        self._path = os.ttyname(slave)
        self._wake_r, self._wake_w = os.pipe()
        self._thread = threading.Thread(target=self._serve, name="createsim-pty", daemon=True)
        self._thread.start()
        log.info("simulated %s on %s", self.sim.model.value, self._path)
        return self._path

    def close(self) -> None:
        """Stop serving and close the pty (the client sees a disconnected device)."""
        self._stop.set()
        if self._wake_w is not None:
            with contextlib.suppress(OSError):
                os.write(self._wake_w, b"x")
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        for name in ("_master", "_slave", "_wake_r", "_wake_w"):
            fd = getattr(self, name)
            if fd is not None:
                with contextlib.suppress(OSError):
                    os.close(fd)
                setattr(self, name, None)

    def __enter__(self) -> PtyServer:
        self.start()
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def wait(self, timeout: float | None = None) -> bool:
        """Block until the server stops (or ``timeout``); True if it stopped."""
        if self._thread is None:
            return True
        self._thread.join(timeout)
        return not self._thread.is_alive()

    def _serve(self) -> None:
        master, wake = self._master, self._wake_r
        assert master is not None and wake is not None
        sim = self.sim
        try:
            while not self._stop.is_set():
                self._line_speed(master)
                sim.sync()
                self._flush_output(master)
                wait = sim.next_tick_time() - sim.clock.now()
                wait = max(_MIN_WAIT_S, min(_MAX_WAIT_S, wait))
                ready, _, _ = select.select([master, wake], [], [], wait)
                if wake in ready:
                    break
                if master in ready:
                    try:
                        data = os.read(master, 4096)
                    except OSError as exc:
                        if exc.errno in (errno.EAGAIN, errno.EWOULDBLOCK, errno.EINTR):
                            continue
                        if exc.errno == errno.EIO:
                            self._stop.wait(_MAX_WAIT_S)  # no slave open: nothing to read
                            continue
                        raise
                    if data:
                        self.bytes_in += len(data)
                        self._line_speed(master)  # set by the client before it wrote these
                        sim.sync()
                        sim.write(data)
        except Exception as exc:  # a server thread must not die silently
            self.error = f"{type(exc).__name__}: {exc}"
            log.exception("pty server stopped")

    def _line_speed(self, master: int) -> None:
        """Tell the robot the baud rate the client set (``None`` if it is not an OI rate)."""
        try:
            speed = termios.tcgetattr(master)[5]
        except (termios.error, OSError):
            return
        self.sim.set_line_baudrate(_SPEEDS.get(speed))

    def _flush_output(self, master: int) -> None:
        data = self.sim.read()
        if not data:
            return
        try:
            n = os.write(master, data)
        except BlockingIOError:
            n = 0
        except OSError as exc:
            if exc.errno != errno.EIO:
                raise
            n = 0
        self.bytes_out += n
        if n < len(data):
            # nobody is reading fast enough: drop the rest, as a UART would overrun
            self.dropped_out += len(data) - n
