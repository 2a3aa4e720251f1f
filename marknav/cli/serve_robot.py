"""``marknav serve-robot``: the Create's serial port on the network, as RFC 2217 (telnet COM port),
for ``marknav run --robot rfc2217://ROBOT:2217`` from another computer. The bridge itself (one
client at a time, stop on silence, bounded telnet input) is
:class:`marknav.remote.rfc2217_bridge.Rfc2217Bridge`."""

from __future__ import annotations

import argparse
import contextlib
import signal
import socket
import sys
from types import FrameType

from marknav.core.errors import InputError
from marknav.remote.rfc2217_bridge import Rfc2217Bridge
from marknav.robot import oi
from marknav.robot.packets import Model
from marknav.robot.transport import LINK_ERRORS, SerialPort, open_port

_READ_TIMEOUT_S = 0.01


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "serve-robot",
        help="serve the Create's serial port over the network (RFC 2217)",
        description="Make the robot's serial port (USB or Bluetooth) reachable from another "
        "computer as rfc2217://HOST:PORT, for 'marknav run --robot rfc2217://HOST:PORT'. "
        "One client at a time: a new one takes over when it sends OI Start (128); the wheels "
        "are stopped when the client disconnects or goes silent.",
    )
    where = p.add_mutually_exclusive_group(required=True)
    where.add_argument("--device", metavar="PATH",
                       help="the robot's serial device (/dev/ttyUSB0, /dev/rfcomm0, COM3) or "
                       "a pyserial URL")
    where.add_argument("--sim", action="store_true",
                       help="serve a simulated Create (real time) instead of a device")
    p.add_argument("--model", choices=("create1", "create2"), default="create2",
                   help="robot model (default create2): OI framing, and the simulated robot")
    p.add_argument("--baud", type=int, default=None,
                   help="initial baud rate (default the model's: 57600 create1, 115200 "
                   "create2); the client's own setting replaces it")
    p.add_argument("--host", default="127.0.0.1",
                   help="address to listen on (default 127.0.0.1, this computer only; "
                   "0.0.0.0 for every network interface)")
    p.add_argument("--port", type=int, default=2217, help="TCP port (default 2217; 0 picks one)")
    p.add_argument("--idle-stop", type=float, default=1.0, metavar="SECONDS",
                   help="stop the wheels when the client sends nothing for this long "
                   "(default 1; 0 only on disconnect)")
    p.set_defaults(func=run)


def _raise_interrupt(signum: int, frame: FrameType | None) -> None:
    raise KeyboardInterrupt


def _is_loopback(host: str) -> bool:
    from marknav.remote.mjpeg_server import is_loopback_host

    return is_loopback_host(host)


def run(args: argparse.Namespace) -> int:
    model = Model.parse(args.model)
    if not 0 <= args.idle_stop <= 60:  # also refuses nan
        raise InputError(f"must be in [0, 60], got {args.idle_stop:g}", field="--idle-stop")
    if args.baud is not None and args.baud not in oi.BAUD_CODES:
        raise InputError(f"not a rate the Open Interface has: {args.baud} (one of "
                         f"{', '.join(str(r) for r in sorted(oi.BAUD_CODES))})", field="--baud")
    if not 0 <= args.port <= 65535:
        raise InputError(f"must be in 0..65535, got {args.port}", field="--port")
    baud = args.baud or model.default_baudrate
    if args.sim:
        from marknav.sim import protocol_createsim

        protocol_createsim.register_scheme()
        device = f"createsim://?model={model.value}"
    else:
        device = args.device
    port: SerialPort = open_port(device, baudrate=baud, timeout=_READ_TIMEOUT_S)
    bridge: Rfc2217Bridge | None = None
    previous = signal.signal(signal.SIGTERM, _raise_interrupt)
    try:
        bridge = Rfc2217Bridge(port, model=model, host=args.host, tcp_port=args.port,
                               idle_stop_s=args.idle_stop,
                               name="simulated Create" if args.sim else device)
        what = f"a simulated {model.value}" if args.sim else repr(device)
        print(f"serving robot {what} at {bridge.url}", flush=True)
        if not _is_loopback(args.host):
            print(f"marknav serve-robot: warning: listening on {args.host}, not only this "
                  "computer: anyone on the network can drive the robot (no authentication); "
                  f"from another computer use rfc2217://{socket.gethostname()}:{bridge.tcp_port}",
                  file=sys.stderr, flush=True)
        bridge.start()
        while not bridge.wait(0.5):
            pass
        if bridge.device_error is not None:
            print(f"marknav serve-robot: {bridge.name}: {bridge.device_error}", file=sys.stderr)
            return 1
        return 0
    finally:
        if bridge is not None:
            bridge.close()
        with contextlib.suppress(*LINK_ERRORS):
            port.close()
        signal.signal(signal.SIGTERM, previous)
