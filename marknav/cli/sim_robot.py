"""``marknav sim-robot``: serve a simulated Create on a pseudo-terminal, in real time.

Prints the pty's device path (one line) and serves until interrupted; any program that can open
a serial port — the marknav driver (``--robot /dev/pts/N``), pycreate2, a terminal — talks to the
simulated robot as to a real one over a USB cable (OI spec: 8N1, no flow control; the baud rate
is ignored by a pty). Ctrl-C or SIGTERM stop it cleanly (exit 130).
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
from types import FrameType

from marknav.core.errors import InputError

log = logging.getLogger(__name__)


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "sim-robot",
        help="serve a simulated Create on a pseudo-terminal",
        description="Serve a byte-level simulated iRobot Create on a raw pseudo-terminal and "
        "print its device path. Open that path like a real robot's serial port.",
    )
    p.add_argument("--pty", action="store_true",
                   help="serve on a pseudo-terminal (the default and only transport)")
    p.add_argument("--model", choices=("create1", "create2"), default="create2",
                   help="robot model (default create2)")
    p.add_argument("--left-scale", type=float, default=1.0, metavar="K",
                   help="left wheel ground speed / commanded speed (wheel mismatch, default 1)")
    p.add_argument("--right-scale", type=float, default=1.0, metavar="K",
                   help="right wheel ground speed / commanded speed (default 1)")
    p.set_defaults(func=run)


def _raise_interrupt(signum: int, frame: FrameType | None) -> None:
    raise KeyboardInterrupt


def run(args: argparse.Namespace) -> int:
    from marknav.core.clock import MonotonicClock
    from marknav.sim.pty import PtyServer
    from marknav.sim.simulated_create import SimulatedCreate

    for name in ("left_scale", "right_scale"):
        value = getattr(args, name)
        if not 0.0 < value <= 2.0:
            raise InputError(f"must be in (0, 2], got {value}", field=f"--{name.replace('_', '-')}")
    sim = SimulatedCreate(model=args.model, clock=MonotonicClock(),
                          left_scale=args.left_scale, right_scale=args.right_scale)
    server = PtyServer(sim)
    previous = signal.signal(signal.SIGTERM, _raise_interrupt)
    try:
        print(server.start(), flush=True)
        while not server.wait(0.5):
            pass
        if server.error is not None:
            print(f"marknav sim-robot: server stopped: {server.error}", file=sys.stderr)
            return 1
        return 0
    finally:
        server.close()
        signal.signal(signal.SIGTERM, previous)
