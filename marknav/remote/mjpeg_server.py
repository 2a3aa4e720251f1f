"""Serve a camera as an MJPEG stream over HTTP: the camera half of the paper's split set-up.

The paper (§2, experimental set-up) runs the camera on the robot's laptop and the control on a
stronger computer over Wi-Fi. This module is the robot side's camera: frames from any
:class:`~marknav.vision.sources.FrameSource` are JPEG-encoded once and served to every client as
``multipart/x-mixed-replace`` (the "MJPEG over HTTP" that browsers, OpenCV's FFmpeg backend and
IP cameras speak):

    HTTP/1.0 200 OK
    Content-Type: multipart/x-mixed-replace; boundary=marknav-frame

    --marknav-frame\\r\\n
    Content-Type: image/jpeg\\r\\n
    Content-Length: N\\r\\n
    X-Capture-Age: 0.0213\\r\\n       (seconds since the frame was captured, when sent)
    \\r\\n
    <N bytes of JPEG>\\r\\n
    --marknav-frame\\r\\n
    ...
    --marknav-frame--\\r\\n          (when the stream ends: camera stalled or server stopping)

Paths: ``/`` a small HTML page showing the stream, ``/stream.mjpg`` the stream,
``/snapshot.jpg`` the latest frame as one JPEG (503 while the camera delivers nothing).

Latency: a client that reads slower than the stream gets ever older frames, queued in its own
receive buffer (measured on loopback, 30 fps stream read at 10 Hz with ``cv2.VideoCapture``:
2.7 s behind after 4 s; 0.6 s at most with this server's 64 KiB send buffer). A reader that
grabs every frame on its own thread and keeps the latest stays within one frame period.

Threads: one capture thread (:class:`CameraStreamer`) reads the camera, encodes the latest
frame and publishes it under a :class:`threading.Condition`; each HTTP client has its own thread
(``ThreadingHTTPServer``) that waits for the next published frame and writes it. A slow client
only skips frames; it never slows the camera or another client. A client that goes away
(``BrokenPipeError``, ``ConnectionResetError``) ends its own thread quietly.

Sources: a *live* source (device index, ``/dev/video*``, a network URL) is read as fast as it
delivers (reading slower would let the driver's buffer add latency); ``fps`` then only caps how
many frames are encoded and sent. A *finite* source (image, folder, glob, video file) is played
in a loop at ``fps``; a source that ends after a single frame (a still image) is re-sent from its
one JPEG without re-reading or re-encoding. A live source that delivers nothing for
``stall_timeout_s`` is logged as stalled, client streams that waited that long end cleanly, and
the source is reopened every ``reopen_interval_s`` until frames come back.
"""

from __future__ import annotations

import contextlib
import errno
import html
import ipaddress
import logging
import re
import socket
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from marknav.core.errors import InputError
from marknav.vision.sources import Frame, FrameSource

__all__ = [
    "BOUNDARY",
    "CameraStreamer",
    "JpegFrame",
    "MjpegServer",
    "encode_jpeg",
    "is_live_spec",
    "is_loopback_host",
]

log = logging.getLogger(__name__)

#: Each part's header with the frame's age when it is sent (seconds since capture, the
#: source's best estimate): the client subtracts it from the arrival time. An age, not a
#: time stamp: the two computers' clocks need not agree.
CAPTURE_AGE_HEADER = "X-Capture-Age"
#: The multipart boundary (RFC 2046 §5.1.1: 1-70 characters, no trailing space).
BOUNDARY = "marknav-frame"
STREAM_PATH = "/stream.mjpg"
SNAPSHOT_PATH = "/snapshot.jpg"

#: Errors that mean the client has gone away (or stopped reading for longer than the timeout).
_CLIENT_GONE: tuple[type[BaseException], ...] = (
    BrokenPipeError, ConnectionResetError, ConnectionAbortedError, TimeoutError,
)
_IDLE_SLEEP_S = 0.01
#: How long closing the server waits for the streams to end with their closing boundary.
CLOSE_WAIT_S = 3.0
#: Send buffer of a stream connection. A client that reads slower than the stream first fills
#: its own receive buffer, then this one; only then does the server skip frames for it. Small,
#: so that at most a couple of frames wait here (the kernel doubles it).
STREAM_SNDBUF = 64 * 1024

_LIVE_SCHEMES = re.compile(r"^(https?|rtsps?|rtmp|udp|tcp|srt)://", re.IGNORECASE)


def is_live_spec(spec: str) -> bool:
    """Whether a camera spec names a live source (device index, ``/dev/video*``, network URL).

    Everything else (an image, a folder, a glob, a video file) is finite and is served in a loop.
    """
    s = spec.strip()
    return s.isdigit() or s.startswith("/dev/video") or bool(_LIVE_SCHEMES.match(s))


def is_loopback_host(host: str) -> bool:
    """Whether ``host`` (an address or ``localhost``) only reaches this computer."""
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def encode_jpeg(image: npt.NDArray[np.uint8], quality: int) -> bytes:
    """One BGR (or grey) image as JPEG bytes at ``quality`` (1..100), chroma not subsampled.

    Full-resolution chroma (4:4:4) because the marks are told apart by colour: with the usual
    4:2:0 the colour of a mark's rim is averaged with the background's over 2×2 pixels. Measured
    on 31 simulated 640×480 frames at quality 80: 4:2:0 lost 5 of 111 marks and added 8, 4:4:4
    lost 2 and added 1, for 37 KiB instead of 29 KiB a frame.
    """
    params = [int(cv2.IMWRITE_JPEG_QUALITY), int(quality),
              int(cv2.IMWRITE_JPEG_SAMPLING_FACTOR), int(cv2.IMWRITE_JPEG_SAMPLING_FACTOR_444)]
    ok, buf = cv2.imencode(".jpg", image, params)
    if not ok:
        raise ValueError(f"cv2.imencode failed for an image of shape {image.shape}")
    return bytes(buf.tobytes())


@dataclass(frozen=True)
class JpegFrame:
    """One published frame: sequence number (1, 2, ...), JPEG bytes, size, publish time, and
    the source's capture time (``time.monotonic`` seconds; the publish time when unknown)."""

    seq: int
    jpeg: bytes
    width: int
    height: int
    t: float
    captured: float | None = None

    def age_s(self, now: float) -> float:
        """Seconds since the frame was captured, at monotonic time ``now`` (never negative)."""
        return max(0.0, now - (self.captured if self.captured is not None else self.t))


class CameraStreamer:
    """The capture thread: reads a frame source and publishes its latest frame as JPEG.

    Args:
        open_camera: opens the source (called at :meth:`start`, to loop a finite source, and to
            reopen a stalled live one). May raise :class:`InputError`.
        name: the camera spec, for messages.
        live: a live source (see :func:`is_live_spec`); else it is looped.
        fps: frames published per second: the loop rate of a finite source, a cap for a live one
            (``None``: every frame a live source delivers; 15 for a finite one).
        quality: JPEG quality 1..100.
        stall_timeout_s: a live source silent this long is stalled; waiting clients give up.
        reopen_interval_s: how often a stalled source is reopened.
    """

    def __init__(
        self,
        open_camera: Callable[[], FrameSource],
        *,
        name: str,
        live: bool,
        fps: float | None = None,
        quality: int = 80,
        stall_timeout_s: float = 5.0,
        reopen_interval_s: float = 2.0,
    ) -> None:
        if fps is not None and not 0 < fps <= 1000:
            raise ValueError(f"fps must be in (0, 1000], got {fps}")
        if not 1 <= quality <= 100:
            raise ValueError(f"quality must be in 1..100, got {quality}")
        if stall_timeout_s <= 0 or reopen_interval_s <= 0:
            raise ValueError("stall_timeout_s and reopen_interval_s must be > 0")
        self._open_camera = open_camera
        self.name = name
        self.live = live
        self.fps = fps if fps is not None or live else 15.0
        self.quality = quality
        self.stall_timeout_s = stall_timeout_s
        self.reopen_interval_s = reopen_interval_s
        self._source: FrameSource | None = None
        self._cond = threading.Condition()
        self._latest: JpegFrame | None = None
        self._stalled = False
        self._closing = False
        self._thread: threading.Thread | None = None
        self._read_failed = False
        self.frames_read = 0
        self.stalls = 0
        self.encode_s_total = 0.0

    # --- lifecycle ----------------------------------------------------------------------------

    def start(self, *, first_frame_timeout_s: float = 5.0) -> JpegFrame:
        """Open the source, start the capture thread, wait for the first published frame.

        Raises :class:`InputError` naming the camera when it cannot be opened or delivers no
        frame within ``first_frame_timeout_s``.
        """
        if self._thread is not None:
            raise RuntimeError("CameraStreamer already started")
        self._source = self._open_camera()
        self._thread = threading.Thread(target=self._run, name="camera-capture", daemon=True)
        self._thread.start()
        frame = self.wait_next(0, first_frame_timeout_s)
        if frame is None:
            self.close()
            raise InputError(f"camera delivered no frame within {first_frame_timeout_s:g} s",
                             file=self.name)
        return frame

    def close(self) -> None:
        """Stop the capture thread, wake every waiting client, close the source. Idempotent."""
        with self._cond:
            self._closing = True
            self._cond.notify_all()
        thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=2.0)
            if thread.is_alive():
                log.warning("camera %r: capture thread still busy in read(); leaving it",
                            self.name)
        self._close_source()

    def __enter__(self) -> CameraStreamer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- state for clients --------------------------------------------------------------------

    @property
    def closing(self) -> bool:
        with self._cond:
            return self._closing

    @property
    def stalled(self) -> bool:
        """True while a live source has delivered nothing for ``stall_timeout_s``."""
        with self._cond:
            return self._stalled

    def latest(self) -> JpegFrame | None:
        """The latest frame, or None before the first one or while stalled."""
        with self._cond:
            return None if self._stalled else self._latest

    def wait_next(self, after_seq: int, timeout: float) -> JpegFrame | None:
        """Block until a frame newer than ``after_seq`` is published; None after ``timeout``
        seconds, while stalled, or when closing."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while True:
                if self._closing:
                    return None
                if self._latest is not None and self._latest.seq > after_seq and not self._stalled:
                    return self._latest
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    return None
                self._cond.wait(remaining)

    # --- the capture thread -------------------------------------------------------------------

    def _publish(self, jpeg: bytes, width: int, height: int,
                 captured: float | None = None) -> None:
        with self._cond:
            seq = 1 if self._latest is None else self._latest.seq + 1
            self._latest = JpegFrame(seq, jpeg, width, height, time.monotonic(), captured)
            if self._stalled:
                log.warning("camera %r delivers frames again", self.name)
                self._stalled = False
            self._cond.notify_all()

    def _set_stalled(self) -> None:
        with self._cond:
            if self._stalled:
                return
            self._stalled = True
            self.stalls += 1
            self._cond.notify_all()
        log.warning("camera %r delivered no frame for %.1f s: ending client streams, reopening "
                    "it every %.1f s", self.name, self.stall_timeout_s, self.reopen_interval_s)

    def _close_source(self) -> None:
        source, self._source = self._source, None
        if source is not None:
            try:
                source.close()
            except Exception as exc:  # a camera that fails to close must not kill the thread
                log.debug("closing camera %r: %s", self.name, exc)

    def _reopen(self) -> bool:
        self._close_source()
        try:
            self._source = self._open_camera()
        except Exception as exc:
            log.debug("reopening camera %r failed: %s", self.name, exc)
            return False
        return True

    def _read(self) -> Frame | None:
        """One frame from the source; None (logged once per failure streak) if it raised."""
        source = self._source
        if source is None:
            return None
        try:
            frame = source.read()
        except Exception as exc:  # a camera error must not end the capture thread
            if not self._read_failed:
                log.warning("camera %r: read failed: %s: %s", self.name, type(exc).__name__, exc)
            self._read_failed = True
            return None
        self._read_failed = False
        return frame

    def _encode(self, image: npt.NDArray[np.uint8]) -> bytes:
        t0 = time.perf_counter()
        jpeg = encode_jpeg(image, self.quality)
        self.encode_s_total += time.perf_counter() - t0
        return jpeg

    def _run(self) -> None:
        try:
            if self.live:
                self._run_live()
            else:
                self._run_finite()
        except Exception:  # the capture thread must not die silently
            log.exception("camera %r: capture thread failed", self.name)
            self._set_stalled()

    def _sleep_until(self, t: float) -> bool:
        """Sleep until monotonic time ``t``; False if closing."""
        with self._cond:
            while not self._closing:
                remaining = t - time.monotonic()
                if remaining <= 0:
                    return True
                self._cond.wait(remaining)
            return False

    def _run_live(self) -> None:
        period = 0.0 if self.fps is None else 1.0 / self.fps
        last_frame_t = time.monotonic()
        last_publish_t = -float("inf")
        next_reopen_t = 0.0
        while not self.closing:
            frame = self._read()
            now = time.monotonic()
            if frame is None:
                if now - last_frame_t >= self.stall_timeout_s:
                    self._set_stalled()
                    if now >= next_reopen_t:
                        next_reopen_t = now + self.reopen_interval_s
                        self._reopen()
                if not self._sleep_until(now + _IDLE_SLEEP_S):
                    return
                continue
            self.frames_read += 1
            last_frame_t = now
            if now - last_publish_t >= period * 0.999:
                last_publish_t = now
                h, w = frame.image.shape[:2]
                self._publish(self._encode(frame.image), w, h, frame.t)

    def _run_finite(self) -> None:
        assert self.fps is not None
        period = 1.0 / self.fps
        next_t = time.monotonic()
        still: JpegFrame | None = None
        frames_this_pass = 0
        last_jpeg: tuple[bytes, int, int] | None = None
        while not self.closing:
            if still is not None:
                self._publish(still.jpeg, still.width, still.height)
            else:
                frame = self._read()
                if frame is None:
                    if frames_this_pass == 1 and last_jpeg is not None:
                        still = JpegFrame(0, last_jpeg[0], last_jpeg[1], last_jpeg[2], 0.0)
                        log.info("camera %r is a still image: re-sending it at %g fps",
                                 self.name, self.fps)
                        self._close_source()
                        continue
                    if frames_this_pass == 0:
                        # an empty pass: the file went away or cannot be read
                        self._set_stalled()
                        if not self._sleep_until(time.monotonic() + self.reopen_interval_s):
                            return
                    frames_this_pass = 0
                    self._reopen()  # loop: play the source again from its start
                    continue
                frames_this_pass += 1
                self.frames_read += 1
                h, w = frame.image.shape[:2]
                last_jpeg = (self._encode(frame.image), w, h)
                self._publish(*last_jpeg)
            next_t += period
            now = time.monotonic()
            if next_t < now - period:  # fell behind (slow decode): do not burst to catch up
                next_t = now
            if not self._sleep_until(next_t):
                return


_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>marknav camera: {name}</title>
<style>body{{margin:0;background:#222;color:#ddd;font:14px sans-serif}}
img{{display:block;max-width:100%;margin:auto}}p{{text-align:center}}a{{color:#8cf}}
</style></head>
<body><img src="{stream}" alt="camera stream">
<p>marknav camera {name} &middot; <a href="{stream}">{stream}</a> &middot;
<a href="{snapshot}">{snapshot}</a></p></body></html>
"""


class _Handler(BaseHTTPRequestHandler):
    """One HTTP client. ``server`` is a :class:`_HttpServer`."""

    server: _HttpServer
    server_version = "marknav-serve-camera"
    #: Socket timeout: a client that stops reading for this long is dropped.
    timeout = 10.0

    def log_message(self, format: str, *args: Any) -> None:
        log.debug("%s %s", self.address_string(), format % args)

    def do_GET(self) -> None:
        path = self.path.split("?", 1)[0]
        try:
            if path in ("/", "/index.html"):
                self._page()
            elif path == STREAM_PATH:
                self._stream()
            elif path == SNAPSHOT_PATH:
                self._snapshot()
            else:
                self.send_error(HTTPStatus.NOT_FOUND, f"no such path: {path}",
                                f"try {STREAM_PATH}, {SNAPSHOT_PATH} or /")
        except _CLIENT_GONE as exc:
            log.debug("client %s went away: %s", self.address_string(), exc)
            self.close_connection = True

    def _send_body(self, content_type: str, body: bytes) -> None:
        self.send_response(HTTPStatus.OK)
        self.send_header("Content-Type", content_type)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-cache, no-store, must-revalidate")
        self.end_headers()
        self.wfile.write(body)

    def _page(self) -> None:
        name = html.escape(self.server.streamer.name)
        body = _PAGE.format(name=name, stream=STREAM_PATH, snapshot=SNAPSHOT_PATH)
        self._send_body("text/html; charset=utf-8", body.encode("utf-8"))

    def _snapshot(self) -> None:
        streamer = self.server.streamer
        frame = streamer.latest() or streamer.wait_next(0, min(1.0, streamer.stall_timeout_s))
        if frame is None:
            self.send_error(HTTPStatus.SERVICE_UNAVAILABLE, "the camera delivers no frames")
            return
        self._send_body("image/jpeg", frame.jpeg)

    def _stream(self) -> None:
        streamer = self.server.streamer
        first = streamer.latest()
        if first is None:
            first = streamer.wait_next(0, streamer.stall_timeout_s)
        if first is None:
            self.send_error(HTTPStatus.SERVICE_UNAVAILABLE, "the camera delivers no frames")
            return
        with contextlib.suppress(OSError):
            self.connection.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, STREAM_SNDBUF)
        self.send_response(HTTPStatus.OK)
        self.send_header("Content-Type", f"multipart/x-mixed-replace; boundary={BOUNDARY}")
        self.send_header("Cache-Control", "no-cache, no-store, must-revalidate")
        self.send_header("Pragma", "no-cache")
        self.send_header("Connection", "close")
        self.end_headers()
        self.close_connection = True
        self.server.client_started()
        sent = 0
        try:
            frame: JpegFrame | None = first
            while frame is not None:
                age = frame.age_s(time.monotonic())
                head = (f"--{BOUNDARY}\r\nContent-Type: image/jpeg\r\n"
                        f"Content-Length: {len(frame.jpeg)}\r\n"
                        f"{CAPTURE_AGE_HEADER}: {age:.4f}\r\n\r\n").encode("ascii")
                self.wfile.write(head + frame.jpeg + b"\r\n")
                self.wfile.flush()
                sent += 1
                frame = streamer.wait_next(frame.seq, streamer.stall_timeout_s)
            why = "server stopping" if streamer.closing else "camera stalled"
            log.info("client %s: stream ended after %d frames (%s)", self.address_string(),
                     sent, why)
            self.wfile.write(f"--{BOUNDARY}--\r\n".encode("ascii"))
            self.wfile.flush()
        except _CLIENT_GONE as exc:
            log.info("client %s disconnected after %d frames (%s)", self.address_string(), sent,
                     type(exc).__name__)
        finally:
            self.server.client_ended()


class _HttpServer(ThreadingHTTPServer):
    daemon_threads = True
    block_on_close = False

    def __init__(self, address: tuple[str, int], streamer: CameraStreamer) -> None:
        self.streamer = streamer
        self._clients_lock = threading.Lock()
        self.clients = 0
        self.streams_served = 0
        super().__init__(address, _Handler)

    def client_started(self) -> None:
        with self._clients_lock:
            self.clients += 1
            self.streams_served += 1

    def client_ended(self) -> None:
        with self._clients_lock:
            self.clients -= 1

    def handle_error(self, request: Any, client_address: Any) -> None:
        """Log (not print) an unexpected error in one client's thread; the server goes on."""
        log.exception("error while serving %s", client_address)


class _HttpServer6(_HttpServer):
    address_family = socket.AF_INET6


class MjpegServer:
    """The HTTP server in front of a started :class:`CameraStreamer`.

    Binding happens in the constructor (so :attr:`port` is known at once, also for port 0);
    :meth:`serve_forever` runs it on the calling thread, :meth:`start` on a background thread.
    Raises :class:`InputError` when the address cannot be bound.
    """

    def __init__(self, streamer: CameraStreamer, *, host: str = "127.0.0.1",
                 port: int = 8080) -> None:
        if not 0 <= port <= 65535:
            raise InputError(f"must be in 0..65535, got {port}", field="--port")
        self.streamer = streamer
        self.host = host
        cls = _HttpServer6 if ":" in host else _HttpServer
        try:
            self._httpd = cls((host.strip("[]"), port), streamer)
        except OSError as exc:
            why = "address already in use" if exc.errno == errno.EADDRINUSE else str(exc)
            raise InputError(f"cannot listen on {host}:{port}: {why}", field="--port") from None
        self.port: int = int(self._httpd.server_address[1])
        self._thread: threading.Thread | None = None
        self._error: BaseException | None = None

    @property
    def base_url(self) -> str:
        host = f"[{self.host.strip('[]')}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port}"

    @property
    def stream_url(self) -> str:
        return self.base_url + STREAM_PATH

    @property
    def clients(self) -> int:
        """Streams being served right now."""
        return self._httpd.clients

    @property
    def streams_served(self) -> int:
        return self._httpd.streams_served

    def serve_forever(self, poll_interval: float = 0.2) -> None:
        """Serve on the calling thread until :meth:`close` (from another thread). A signal's
        exception raised here can land inside the server's accept step and cut the connection it
        was handing to a new thread: a process that stops on a signal serves with :meth:`start`
        and :meth:`wait` instead (``marknav serve-camera``)."""
        self._httpd.serve_forever(poll_interval)

    def start(self) -> MjpegServer:
        """Serve on a background thread (the command, tests, embedding); :meth:`wait` for it."""

        def serve() -> None:
            try:
                self.serve_forever()
            except BaseException as exc:  # handed to wait(), in the thread that waits
                self._error = exc

        self._error = None
        self._thread = threading.Thread(target=serve, name="mjpeg-http", daemon=True)
        self._thread.start()
        return self

    def wait(self, poll_s: float = 0.5) -> None:
        """Block until the background server (:meth:`start`) stops; an exception that stopped
        it is raised here. Signals interrupt the wait (the join is polled), so Ctrl-C and SIGTERM
        raise here, in the waiting thread, and never inside the server's own accept step."""
        thread = self._thread
        while thread is not None and thread.is_alive():
            thread.join(timeout=poll_s)
        error, self._error = self._error, None
        if error is not None:
            raise error

    def close(self) -> None:
        """Stop accepting, end every stream (the streamer is closed too), free the port."""
        self.streamer.close()
        # Let each stream write its closing boundary: at once on a quiet machine, but a loaded
        # one can keep a client's thread from running for a second or more (with 1 s here, the
        # end-to-end test saw a stream cut without its boundary twice, at load 5-7). Bounded:
        # a client that does not read is dropped by its socket timeout anyway.
        deadline = time.monotonic() + CLOSE_WAIT_S
        while self.clients > 0 and time.monotonic() < deadline:
            time.sleep(0.01)
        if self._thread is not None:
            if self._thread.is_alive():  # (shutdown() would wait for ever on a dead loop)
                self._httpd.shutdown()
                self._thread.join(timeout=2.0)
            self._thread = None
        with contextlib.suppress(OSError):
            self._httpd.server_close()

    def __enter__(self) -> MjpegServer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
