"""The Create's serial port on the network, as RFC 2217 (telnet COM port): the bridge behind
``marknav serve-robot`` (:mod:`marknav.cli.serve_robot`).

The serial half of the paper's split set-up: the Create hangs on the robot laptop's serial port
(USB cable or Bluetooth ``/dev/rfcommN``) and the control computer drives it with
``--robot rfc2217://ROBOT:2217``, which pyserial speaks natively. The protocol work (telnet option
negotiation, RFC 2217 COM-PORT-OPTION sub-negotiation: baud rate, data bits, parity, stop bits,
flow control, purge) is pyserial's :class:`serial.rfc2217.PortManager`; this module moves the
bytes, escapes the telnet IAC byte (255 → 255 255, RFC 854) in robot→client data, and adds what a
robot needs from a serial bridge:

- **One client at a time.** Two programs writing OI commands into one robot interleave bytes. A
  new connection while a client drives the robot *waits*: it may negotiate its line settings
  (kept aside, not applied), but it takes over (the previous client closed, the robot stopped
  first) only when its first OI byte is Start (128) — what every OI program sends first. A
  control computer whose Wi-Fi dropped reconnects at once; a port scan, a stray telnet or 64
  random bytes are closed without touching the running mission (no OI Start within
  ``TAKEOVER_WAIT_S``, or another first byte: takeover refused). At most ``MAX_WAITING``
  connections wait at a time.
- **Stop on silence.** OI spec, "Drive Direct": the robot keeps the last wheel command forever;
  nothing in it stops a command that is never followed by another. The driver's safety layer
  (the command watchdog) cannot help when the network itself is gone. So when the client
  disconnects, or sends nothing for ``idle_stop_s`` (default 1 s; marknav's driver sends a
  wheel command every control cycle while driving), the bridge writes Drive Direct (145) with
  both wheels at 0. Silence is measured from the last byte received, whatever was received: a
  client that stops in the middle of a command is silent too. The bridge tracks the client's
  OI command framing (:func:`marknav.robot.oi.command_length`) so the stop never lands inside
  a half-received command: a half-written command is first completed with zero data bytes.
- **Bounded telnet input.** A telnet sub-option (IAC SB …) longer than ``MAX_SUBOPTION`` bytes
  without its IAC SE, or telnet data pyserial cannot parse, closes the client.
- **Dead peers** are found by TCP keepalive (5 s idle, 2 s interval, 3 probes, where the OS
  allows) as well as by the silence stop.
- Devices without modem lines (a pseudo-terminal) answer CTS/DSR/CD asserted and RI clear, and
  ignore DTR/RTS changes, instead of failing the negotiation.
"""

from __future__ import annotations

import contextlib
import errno
import logging
import math
import socket
import threading
import time
from typing import Any, ClassVar

import serial
import serial.rfc2217

from marknav.core.errors import InputError
from marknav.robot import oi
from marknav.robot.packets import Model
from marknav.robot.transport import LINK_ERRORS

__all__ = ["MAX_SUBOPTION", "MAX_WAITING", "TAKEOVER_WAIT_S", "OIFramer", "Rfc2217Bridge"]

log = logging.getLogger(__name__)

IAC = b"\xff"
_ACCEPT_POLL_S = 0.1
_RECV_POLL_S = 0.05
_MODEM_POLL_S = 1.0
#: A waiting connection must send OI Start (128) within this many seconds to take over.
TAKEOVER_WAIT_S = 5.0
#: Connections that may wait to take over at once (more are closed at once).
MAX_WAITING = 2
#: Longest telnet sub-option accepted (RFC 2217's are at most a few bytes; pyserial buffers them).
MAX_SUBOPTION = 64


class OIFramer:
    """Tracks where OI commands begin and end in a host→robot byte stream.

    ``feed(data)`` consumes bytes; :attr:`at_boundary` is True when no command is half-received.
    Unknown opcodes are skipped one byte at a time, as the robot does.
    """

    def __init__(self, model: Model) -> None:
        self.model = model
        self._pending = bytearray()

    @property
    def at_boundary(self) -> bool:
        return not self._pending

    def feed(self, data: bytes) -> None:
        self._pending += data
        while self._pending:
            try:
                n = oi.command_length(self.model, self._pending)
            except ValueError:
                del self._pending[:1]
                continue
            if n is None or n > len(self._pending):
                return
            del self._pending[:n]

    def completion(self) -> bytes:
        """Zero bytes that complete the half-received command (empty at a boundary)."""
        pad = bytearray()
        while self._pending:
            try:
                n = oi.command_length(self.model, self._pending + pad)
            except ValueError:  # cannot happen after feed(); be safe
                break
            if n is None:
                pad.append(0)
                continue
            pad += bytes(max(0, n - len(self._pending) - len(pad)))
            break
        self._pending.clear()
        return bytes(pad)


class _ModemLines:
    """The serial port as PortManager sees it, tolerant of devices without modem lines."""

    _ASSERTED: ClassVar[dict[str, bool]] = {"cts": True, "dsr": True, "cd": True, "ri": False}

    def __init__(self, port: Any) -> None:
        object.__setattr__(self, "_port", port)

    def __getattr__(self, name: str) -> Any:
        port = object.__getattribute__(self, "_port")
        if name in self._ASSERTED:
            try:
                return getattr(port, name)
            except (OSError, serial.SerialException):
                return self._ASSERTED[name]
        return getattr(port, name)

    def __setattr__(self, name: str, value: Any) -> None:
        port = object.__getattribute__(self, "_port")
        try:
            setattr(port, name, value)
        except (OSError, serial.SerialException) as exc:
            if name not in ("dtr", "rts", "break_condition"):
                raise
            log.debug("serial port has no %s line: %s", name, exc)


class _ShadowPort:
    """The serial port as a *waiting* client's PortManager sees it: the line settings it asks
    for are recorded (:attr:`changes`) and applied to the real port only when it takes over."""

    _SETTINGS = ("baudrate", "bytesize", "parity", "stopbits", "rtscts", "xonxoff")
    changes: dict[str, Any]

    def __init__(self, port: Any) -> None:
        object.__setattr__(self, "changes", {})
        for name in self._SETTINGS:
            object.__setattr__(self, name, getattr(port, name, None))
        for name, value in (("cts", True), ("dsr", True), ("cd", True), ("ri", False),
                            ("rts", True), ("dtr", True), ("break_condition", False)):
            object.__setattr__(self, name, value)

    def __setattr__(self, name: str, value: Any) -> None:
        object.__setattr__(self, name, value)
        if name in self._SETTINGS:
            self.changes[name] = value

    def reset_input_buffer(self) -> None:
        pass

    def reset_output_buffer(self) -> None:
        pass


class _Session:
    """One RFC 2217 client: a network→serial thread and a serial→network thread.

    An *active* session owns the robot; a waiting one (``active=False``) only negotiates telnet
    until its first OI byte, which must be Start (128) for it to take over.
    """

    def __init__(self, bridge: Rfc2217Bridge, conn: socket.socket, peer: str, *,
                 active: bool = True) -> None:
        self.bridge = bridge
        self.conn = conn
        self.peer = peer
        self.framer = OIFramer(bridge.model)
        self._send_lock = threading.Lock()
        self._stop = threading.Event()
        self.active = threading.Event()
        if active:
            self.active.set()
        self.shadow = None if active else _ShadowPort(bridge.port)
        port: Any = _ModemLines(bridge.port) if active else self.shadow
        self.started = time.monotonic()
        self.manager = serial.rfc2217.PortManager(port, self)
        self._threads = [
            threading.Thread(target=self._net_to_serial, name="rfc2217-in", daemon=True),
            threading.Thread(target=self._serial_to_net, name="rfc2217-out", daemon=True),
        ]
        self.ended = threading.Event()

    # PortManager's "connection": thread-safe write to the network
    def write(self, data: bytes) -> None:
        with self._send_lock:
            self.conn.sendall(data)

    def start(self) -> None:
        for t in self._threads:
            t.start()

    def close(self, reason: str) -> None:
        """End the session (idempotent); the robot is stopped by the network thread on its way
        out."""
        if not self._stop.is_set():
            log.info("closing client %s: %s", self.peer, reason)
        self._stop.set()
        with contextlib.suppress(OSError):
            self.conn.shutdown(socket.SHUT_RDWR)
        for t in self._threads:
            if t is not threading.current_thread():
                t.join(timeout=2.0)
        with contextlib.suppress(OSError):
            self.conn.close()

    def _net_to_serial(self) -> None:
        bridge = self.bridge
        last_rx = time.monotonic()
        idle_stopped = False
        why = "client disconnected"
        try:
            while not self._stop.is_set():
                try:
                    data = self.conn.recv(4096)
                except TimeoutError:
                    data = None
                except OSError as exc:
                    why = f"client connection failed: {exc}"
                    break
                now = time.monotonic()
                if data is None:
                    if not self.active.is_set():
                        if now - self.started > TAKEOVER_WAIT_S:
                            why = (f"no OI Start (128) within {TAKEOVER_WAIT_S:g} s while "
                                   f"{bridge.client} drives the robot: takeover refused")
                            break
                        continue
                    idle = bridge.idle_stop_s
                    if idle and not idle_stopped and now - last_rx >= idle:
                        # from the last byte, whatever it was: complete a half command first
                        idle_stopped = True
                        pad = self.framer.completion()
                        if pad:
                            bridge.write_serial(pad)
                        bridge.stop_robot(f"client {self.peer} silent for {idle:g} s")
                    continue
                if not data:
                    break
                last_rx = now
                idle_stopped = False
                try:
                    payload = b"".join(self.manager.filter(data))
                except Exception as exc:  # pyserial's parser on malformed telnet
                    why = f"malformed telnet data ({type(exc).__name__}: {exc})"
                    break
                if len(self.manager.suboption or b"") > MAX_SUBOPTION:
                    why = f"telnet sub-option longer than {MAX_SUBOPTION} bytes"
                    break
                if payload and not self.active.is_set():
                    if payload[0] != oi.Opcode.START:
                        why = (f"first OI byte {payload[0]} is not Start (128) while "
                               f"{bridge.client} drives the robot: takeover refused")
                        break
                    if not bridge.promote(self):
                        why = "bridge stopping"
                        break
                if payload:
                    self.framer.feed(payload)
                    if not bridge.write_serial(payload):
                        why = "serial device failed"
                        break
            else:
                why = "session closed"
        except Exception:
            log.exception("client %s: network thread failed", self.peer)
            why = "internal error"
        finally:
            self._stop.set()
            if self.active.is_set():
                pad = self.framer.completion()
                if pad:
                    bridge.write_serial(pad)
                bridge.stop_robot(f"{why} ({self.peer})")
            else:
                log.warning("closing client %s: %s", self.peer, why)
            with contextlib.suppress(OSError):
                self.conn.shutdown(socket.SHUT_RDWR)
            self.ended.set()

    def _serial_to_net(self) -> None:
        bridge = self.bridge
        next_modem = 0.0
        while not self._stop.is_set() and not self.active.wait(_RECV_POLL_S):
            pass  # a waiting client gets nothing from the robot
        try:
            while not self._stop.is_set():
                data = bridge.read_serial()
                if data is None:
                    break
                if data:
                    bridge.bytes_from_robot += len(data)
                    self.write(data.replace(IAC, IAC + IAC))
                now = time.monotonic()
                if now >= next_modem:
                    next_modem = now + _MODEM_POLL_S
                    self.manager.check_modem_lines()
        except OSError as exc:
            if not self._stop.is_set():
                log.info("client %s: sending failed: %s", self.peer, exc)
        except Exception:
            log.exception("client %s: serial thread failed", self.peer)
        finally:
            self._stop.set()
            with contextlib.suppress(OSError):
                self.conn.shutdown(socket.SHUT_RDWR)


def _keepalive(conn: socket.socket) -> None:
    conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    conn.setsockopt(socket.SOL_SOCKET, socket.SO_KEEPALIVE, 1)
    for name, value in (("TCP_KEEPIDLE", 5), ("TCP_KEEPINTVL", 2), ("TCP_KEEPCNT", 3)):
        option = getattr(socket, name, None)
        if option is not None:
            with contextlib.suppress(OSError):
                conn.setsockopt(socket.IPPROTO_TCP, option, value)


class Rfc2217Bridge:
    """Serve one open serial port (device or ``createsim://``) to RFC 2217 clients.

    Args:
        port: the open serial port (a pyserial object: PortManager sets its line settings).
        model: the robot model, for OI command framing.
        host, tcp_port: where to listen (``tcp_port=0`` picks a free port; see :attr:`tcp_port`).
        idle_stop_s: stop the wheels after this much client silence (``None``/0: only on
            disconnect).
        name: the device, for messages.

    Binds in the constructor (:class:`InputError` if it cannot); :meth:`serve_forever` or
    :meth:`start` serve; :meth:`close` stops the robot, ends the client and frees the port
    (it does not close the serial port, which the caller owns).
    """

    def __init__(self, port: Any, *, model: Model | str = Model.CREATE2,
                 host: str = "127.0.0.1", tcp_port: int = 2217,
                 idle_stop_s: float | None = 1.0, name: str = "") -> None:
        if not 0 <= tcp_port <= 65535:
            raise InputError(f"must be in 0..65535, got {tcp_port}", field="--port")
        if idle_stop_s is not None and not 0 <= idle_stop_s < math.inf:
            raise ValueError(f"idle_stop_s must be a number >= 0, got {idle_stop_s}")
        self.port = port
        self.model = Model.parse(model)
        self.host = host
        self.idle_stop_s = idle_stop_s or None
        self.name = name or str(getattr(port, "portstr", "serial port"))
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        self._listener = socket.socket(family, socket.SOCK_STREAM)
        self._listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self._listener.bind((host.strip("[]"), tcp_port))
            self._listener.listen(2)
        except OSError as exc:
            self._listener.close()
            why = "address already in use" if exc.errno == errno.EADDRINUSE else str(exc)
            raise InputError(f"cannot listen on {host}:{tcp_port}: {why}",
                             field="--port") from None
        self._listener.settimeout(_ACCEPT_POLL_S)
        self.tcp_port: int = int(self._listener.getsockname()[1])
        self._serial_lock = threading.Lock()
        self._stop = threading.Event()
        self._session: _Session | None = None
        self._waiting: list[_Session] = []
        self._take_lock = threading.RLock()
        self._thread: threading.Thread | None = None
        self.device_error: str | None = None
        self.clients_served = 0
        self.bytes_to_robot = 0
        self.bytes_from_robot = 0
        self.stops_sent = 0

    @property
    def url(self) -> str:
        host = f"[{self.host.strip('[]')}]" if ":" in self.host else self.host
        return f"rfc2217://{host}:{self.tcp_port}"

    @property
    def client(self) -> str | None:
        """The connected client's address, or None."""
        session = self._session
        return None if session is None or session.ended.is_set() else session.peer

    # --- serial access (shared by the sessions) ----------------------------------------------

    def write_serial(self, data: bytes) -> bool:
        """Write to the robot; False (and :attr:`device_error` set) if the device failed."""
        try:
            with self._serial_lock:
                self.port.write(data)
        except LINK_ERRORS as exc:
            self._device_failed(f"serial write failed: {exc}")
            return False
        self.bytes_to_robot += len(data)
        return True

    def read_serial(self) -> bytes | None:
        """Bytes from the robot (waits up to the port's short timeout); None if it failed."""
        try:
            return bytes(self.port.read(max(1, self.port.in_waiting)))
        except LINK_ERRORS as exc:
            self._device_failed(f"serial read failed: {exc}")
            return None
        except (TypeError, AttributeError) as exc:  # a port closed under us
            self._device_failed(f"serial port closed: {exc}")
            return None

    def stop_robot(self, reason: str, *, level: int = logging.WARNING) -> None:
        """Write Drive Direct with both wheels at 0 (call it at a command boundary)."""
        if self.device_error is not None:
            return
        if self.write_serial(oi.drive_direct(left=0, right=0)):
            self.stops_sent += 1
            log.log(level, "robot stopped: %s", reason)

    def _device_failed(self, message: str) -> None:
        if self.device_error is None:
            self.device_error = message
            log.error("%s: %s", self.name, message)
        self._stop.set()

    # --- serving ------------------------------------------------------------------------------

    def serve_forever(self) -> None:
        """Accept clients until :meth:`close` or a device failure (see :attr:`device_error`)."""
        try:
            while not self._stop.is_set():
                try:
                    conn, addr = self._listener.accept()
                except TimeoutError:
                    if self.client is None:
                        self._drain_idle()
                    continue
                except OSError:
                    if self._stop.is_set():
                        break
                    raise
                self._take(conn, f"{addr[0]}:{addr[1]}")
        finally:
            self._end_session("bridge stopping")

    def _drain_idle(self) -> None:
        """No client: drop what the robot sends (a client purges on connect anyway) and notice a
        device that went away."""
        try:
            with self._serial_lock:
                self.port.reset_input_buffer()
        except LINK_ERRORS as exc:
            self._device_failed(f"serial device failed: {exc}")

    def _take(self, conn: socket.socket, peer: str) -> None:
        try:
            _keepalive(conn)
            conn.settimeout(_RECV_POLL_S)
        except OSError as exc:
            log.info("client %s: %s", peer, exc)
            conn.close()
            return
        with self._take_lock:
            if self.client is not None:
                self._waiting = [s for s in self._waiting if not s.ended.is_set()]
                if len(self._waiting) >= MAX_WAITING:
                    log.warning("client %s refused: %d connections already wait to take over "
                                "from %s", peer, len(self._waiting), self.client)
                    with contextlib.suppress(OSError):
                        conn.close()
                    return
                log.warning("client %s connected while %s drives the robot: it takes over "
                            "when it sends OI Start (128)", peer, self.client)
                waiting = _Session(self, conn, peer, active=False)
                self._waiting.append(waiting)
                waiting.start()
                return
            self._end_session("a new client")
            with self._serial_lock, contextlib.suppress(*LINK_ERRORS):
                self.port.reset_input_buffer()
            session = _Session(self, conn, peer)
            self._session = session
            self.clients_served += 1
            log.info("client %s connected", peer)
            session.start()

    def promote(self, session: _Session) -> bool:
        """A waiting ``session`` sent OI Start: it takes over (the previous client is closed and
        the robot stopped first; the line settings it negotiated are applied). False if the
        bridge is stopping."""
        with self._take_lock:
            if self._stop.is_set():
                return False
            if self.client is not None:
                log.warning("client %s takes over the robot from %s", session.peer, self.client)
            self._end_session(f"taken over by {session.peer}")
            if session in self._waiting:
                self._waiting.remove(session)
            lines = _ModemLines(self.port)
            changes = session.shadow.changes if session.shadow is not None else {}
            for name, value in changes.items():
                try:
                    setattr(lines, name, value)
                except (serial.SerialException, OSError, ValueError) as exc:
                    log.warning("client %s: cannot set %s=%r: %s", session.peer, name, value,
                                exc)
            session.manager.serial = lines
            with self._serial_lock, contextlib.suppress(*LINK_ERRORS):
                self.port.reset_input_buffer()
            self._session = session
            self.clients_served += 1
            session.active.set()
            return True

    def _end_session(self, reason: str) -> None:
        with self._take_lock:
            session, self._session = self._session, None
        if session is not None:
            session.close(reason)

    def start(self) -> Rfc2217Bridge:
        """Serve on a background thread."""
        self._thread = threading.Thread(target=self.serve_forever, name="rfc2217-bridge",
                                        daemon=True)
        self._thread.start()
        return self

    def wait(self, timeout: float | None = None) -> bool:
        """Block until serving stops (a device failure, or :meth:`close`); True if it stopped."""
        if self._thread is None:
            return self._stop.wait(timeout)
        self._thread.join(timeout)
        return not self._thread.is_alive()

    def close(self) -> None:
        """End the client (the robot is stopped), stop accepting, free the TCP port."""
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=3.0)
        self._end_session("bridge stopping")
        with self._take_lock:
            waiting, self._waiting = self._waiting, []
        for session in waiting:
            session.close("bridge stopping")
        with contextlib.suppress(OSError):
            self._listener.close()

    def __enter__(self) -> Rfc2217Bridge:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
