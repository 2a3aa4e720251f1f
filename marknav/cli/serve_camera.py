"""``marknav serve-camera``: stream a camera as MJPEG over HTTP (the paper's split set-up).

On the robot's computer: ``marknav serve-camera --camera 0 --host 0.0.0.0``; on the control
computer: ``marknav run MISSION --camera http://ROBOT:8080/stream.mjpg``. See
:mod:`marknav.remote.mjpeg_server` for the protocol and the threads.

Prints one line when it is serving (``serving camera 'SRC' at URL``), then serves until Ctrl-C or
SIGTERM (exit 130, after every stream was ended and the camera closed). A camera that cannot be
opened, or that delivers no first frame, is bad input (exit 2, naming it).
"""

from __future__ import annotations

import argparse
import logging
import signal
import socket
import sys
from types import FrameType

from marknav.core.errors import InputError

log = logging.getLogger(__name__)


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "serve-camera",
        help="stream a camera as MJPEG over HTTP",
        description="Serve a camera (device index, video file, network URL, image, folder or "
        "glob of images) as an MJPEG stream over HTTP, for 'marknav run --camera "
        "http://HOST:PORT/stream.mjpg' on another computer, OpenCV or a browser. Images, folders "
        "and video files are played in a loop. Paths: / (page), /stream.mjpg, /snapshot.jpg.",
    )
    p.add_argument("--camera", required=True, metavar="SRC",
                   help="the camera: device index (0), /dev/videoN, a video file, an "
                   "http(s)/rtsp URL, an image, a folder or a glob of images")
    p.add_argument("--host", default="127.0.0.1",
                   help="address to listen on (default 127.0.0.1, this computer only; "
                   "0.0.0.0 for every network interface)")
    p.add_argument("--port", type=int, default=8080,
                   help="TCP port (default 8080; 0 picks a free one)")
    p.add_argument("--fps", type=float, default=None,
                   help="frames per second sent: the loop rate of images, folders and video "
                   "files (default 15); an upper limit for a live camera (default: every frame "
                   "it delivers)")
    p.add_argument("--quality", type=int, default=80,
                   help="JPEG quality 1..100 (default 80)")
    p.add_argument("--stall-timeout", type=float, default=5.0, metavar="SECONDS",
                   help="a camera silent this long is reported stalled and client streams end "
                   "(default 5)")
    p.set_defaults(func=run)


#: Highest frame rate served (frames/s): past any USB camera's rate; an MJPEG client then
#: spends its time decoding.
MAX_FPS = 1000.0


def _raise_interrupt(signum: int, frame: FrameType | None) -> None:
    raise KeyboardInterrupt


def _check(args: argparse.Namespace) -> None:
    if not 0 <= args.port <= 65535:
        raise InputError(f"must be in 0..65535, got {args.port}", field="--port")
    if args.fps is not None and not 0 < args.fps <= MAX_FPS:
        raise InputError(f"must be in (0, {MAX_FPS:g}], got {args.fps:g}", field="--fps")
    if args.fps is not None and args.fps * args.stall_timeout < 1:
        # Frames further apart than the stall timeout: every client stream would end between
        # two frames (and 1e-300 fps overflowed the capture thread's wait).
        raise InputError(f"at {args.fps:g} fps a frame comes every {1 / args.fps:.3g} s, "
                         f"longer than --stall-timeout {args.stall_timeout:g} s: give at "
                         f"least {1 / args.stall_timeout:.3g} fps", field="--fps")
    if not 1 <= args.quality <= 100:
        raise InputError(f"must be in 1..100, got {args.quality}", field="--quality")
    if not 0 < args.stall_timeout <= 3600:
        raise InputError(f"must be in (0, 3600], got {args.stall_timeout:g}",
                         field="--stall-timeout")


def run(args: argparse.Namespace) -> int:
    from marknav.remote.mjpeg_server import (
        CameraStreamer,
        MjpegServer,
        is_live_spec,
        is_loopback_host,
    )
    from marknav.vision.sources import open_source

    _check(args)
    spec: str = args.camera
    streamer = CameraStreamer(
        lambda: open_source(spec), name=spec, live=is_live_spec(spec), fps=args.fps,
        quality=args.quality, stall_timeout_s=args.stall_timeout,
        reopen_interval_s=min(2.0, args.stall_timeout))
    server: MjpegServer | None = None
    previous = signal.signal(signal.SIGTERM, _raise_interrupt)
    try:
        first = streamer.start(first_frame_timeout_s=max(5.0, args.stall_timeout))
        server = MjpegServer(streamer, host=args.host, port=args.port)
        print(f"serving camera {spec!r} at {server.stream_url}", flush=True)
        if not is_loopback_host(args.host):
            print(f"marknav serve-camera: warning: listening on {args.host}, not only this "
                  f"computer: anyone on the network can watch the camera (no authentication); "
                  f"from another computer use http://{socket.gethostname()}:{server.port}"
                  "/stream.mjpg", file=sys.stderr, flush=True)
        log.info("first frame %dx%d, %d bytes of JPEG at quality %d", first.width,
                 first.height, len(first.jpeg), args.quality)
        # The server runs on its own thread and this one waits: a signal's KeyboardInterrupt
        # then never lands inside the server's accept step, where socketserver shuts down the
        # connection it was handing to a new thread (a stream cut without its closing boundary,
        # seen under load when SIGTERM came right after a client connected).
        server.start()
        server.wait()
        return 0
    finally:
        if server is not None:
            server.close()
        else:
            streamer.close()
        signal.signal(signal.SIGTERM, previous)
