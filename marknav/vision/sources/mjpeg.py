"""MJPEG over HTTP, read by marknav itself: bounded waits, no FFmpeg.

``--camera http://…`` used to go through OpenCV's FFmpeg backend, which blocks in C (a Ctrl-C
while opening a URL that never answers waited 27 s) and crashed the process when the server
froze mid-stream (``Stream timeout triggered after 8033556303716768768 ms``, then a segfault).
Here the HTTP request and the ``multipart/x-mixed-replace`` stream (the format
``marknav serve-camera`` and IP cameras serve) are read with plain sockets:

- every socket operation has a timeout (:data:`CONNECT_TIMEOUT_S`, :data:`READ_TIMEOUT_S`), so a
  frozen or vanished server is a stream that stopped: ``read`` returns ``None``, the grabber
  reconnects, the run's camera watchdog decides — nothing hangs and nothing crashes;
- the connection is made on the calling thread, where a Ctrl-C interrupts the socket wait at
  once;
- header lines, header counts and frame sizes are bounded, and every JPEG goes through
  :func:`marknav.vision.imagefile.decode_image` (its header-claimed size checked first).

A URL that answers with one ``image/jpeg`` (a snapshot URL) is polled: each grab is a new
request. A URL that serves anything else (or parts without ``Content-Length``) is handed to
OpenCV (:class:`~marknav.vision.sources.LiveCaptureSource`, with FFmpeg timeouts set).

Capture time: a part's ``X-Capture-Age`` header (``marknav serve-camera`` sends the frame's age
in seconds when it writes the part) is subtracted from the arrival time, and so is the
configured ``camera.latency_s`` (then only the network's share); see
:class:`~marknav.vision.sources.GrabbedSource`.
"""

from __future__ import annotations

import contextlib
import http.client
import logging
import re
import socket
import time
from urllib.parse import urlsplit

from marknav.core.clock import Clock
from marknav.core.errors import InputError
from marknav.vision.imagefile import decode_image
from marknav.vision.sources.frames import (
    DEFAULT_TIMEOUT_S,
    FrameSource,
    GrabbedSource,
    Image,
    LiveCaptureSource,
)

__all__ = ["MjpegHttpSource", "open_http_source"]

log = logging.getLogger(__name__)

CONNECT_TIMEOUT_S = 5.0
READ_TIMEOUT_S = 2.0
MAX_LINE = 1024
MAX_HEADERS = 32
MAX_FRAME_BYTES = 16 * 1024 * 1024
_BOUNDARY = re.compile(r'boundary="?([^";]+)"?', re.IGNORECASE)


#: The part header (lower case) in which ``marknav serve-camera`` sends a frame's age.
CAPTURE_AGE_KEY = b"x-capture-age"
#: A reported age beyond this (s) is not believed (a frame that old is useless anyway).
MAX_REPORTED_AGE_S = 10.0


def _age(value: bytes) -> float | None:
    """An ``X-Capture-Age`` value in seconds, or ``None`` if it is not a sane one."""
    try:
        age = float(value.strip())
    except ValueError:
        return None
    return age if 0.0 <= age <= MAX_REPORTED_AGE_S else None


class _NotMjpeg(Exception):
    """The URL serves something this reader does not handle: let OpenCV try."""


class MjpegHttpSource(GrabbedSource):
    """An MJPEG (or single-JPEG snapshot) HTTP URL, grabbed on a thread that keeps the newest
    frame. :class:`InputError` if it cannot be opened or delivers no frame in time."""

    def __init__(self, url: str, *, clock: Clock | None = None,
                 timeout_s: float = DEFAULT_TIMEOUT_S, open_timeout_s: float = 5.0,
                 latency_s: float = 0.0) -> None:
        super().__init__(url, clock=clock, timeout_s=timeout_s, latency_s=latency_s)
        parts = urlsplit(url)
        if parts.scheme.lower() not in ("http", "https") or not parts.hostname:
            raise InputError("not an http:// or https:// URL", file=url)
        self._https = parts.scheme.lower() == "https"
        self._host = parts.hostname
        try:
            self._port = parts.port
        except ValueError:
            raise InputError("bad port in the URL", file=url) from None
        self._path = (parts.path or "/") + (f"?{parts.query}" if parts.query else "")
        self._conn: http.client.HTTPConnection | None = None
        self._resp: http.client.HTTPResponse | None = None
        self._boundary: bytes | None = None  # None: a snapshot URL
        self._pending: Image | None = None
        self._part_age_s: float | None = None  # the last part's X-Capture-Age
        try:
            self._connect()  # on this thread: Ctrl-C ends the wait at once
            self._pending = self._next_image()
        except (OSError, http.client.HTTPException) as exc:
            self._disconnect()
            raise InputError(f"cannot open the stream: {exc}", file=url) from None
        except BaseException:  # not MJPEG, a bad frame, Ctrl-C
            self._disconnect()
            raise
        self._start(open_timeout_s)

    # --- HTTP -----------------------------------------------------------------------------

    def _connect(self) -> None:
        cls = http.client.HTTPSConnection if self._https else http.client.HTTPConnection
        conn = cls(self._host, self._port, timeout=CONNECT_TIMEOUT_S)
        self._conn = conn
        conn.request("GET", self._path, headers={"Accept": "multipart/x-mixed-replace, "
                                                           "image/jpeg"})
        resp = conn.getresponse()
        self._resp = resp
        if conn.sock is not None:
            conn.sock.settimeout(READ_TIMEOUT_S)
        if resp.status != 200:
            raise InputError(f"HTTP {resp.status} {resp.reason}", file=self.name)
        ctype = resp.getheader("Content-Type", "") or ""
        if ctype.lower().startswith("multipart/"):
            m = _BOUNDARY.search(ctype)
            if m is None:
                raise _NotMjpeg(f"multipart without a boundary: {ctype}")
            self._boundary = b"--" + m.group(1).strip().encode("latin-1")
        elif ctype.lower().startswith("image/"):
            self._boundary = None
        else:
            raise _NotMjpeg(f"Content-Type {ctype or 'missing'}")

    def _disconnect(self) -> None:
        conn, self._conn, self._resp = self._conn, None, None
        if conn is not None:
            with contextlib.suppress(OSError):
                if conn.sock is not None:
                    conn.sock.shutdown(socket.SHUT_RDWR)
            conn.close()

    def _readline(self) -> bytes:
        assert self._resp is not None
        line = self._resp.readline(MAX_LINE + 1)
        if not line:
            raise ConnectionError("the stream ended")
        if len(line) > MAX_LINE:
            raise ConnectionError("header line too long")
        return line.rstrip(b"\r\n")

    def _next_image(self) -> Image:
        """The next JPEG of the stream (or the snapshot), decoded."""
        resp = self._resp
        assert resp is not None
        if self._boundary is None:
            declared = resp.getheader("Content-Length")
            cap = MAX_FRAME_BYTES + 1
            body = resp.read(cap if declared is None or not declared.strip().isdigit()
                             else min(int(declared), cap))
            if len(body) > MAX_FRAME_BYTES:
                raise ConnectionError("image larger than 16 MiB")
            self._disconnect()  # a snapshot: the next grab asks again
            return decode_image(body, self.name)
        for _ in range(MAX_HEADERS):
            line = self._readline()
            if line.startswith(self._boundary):
                break
        else:
            raise ConnectionError("no part boundary in the stream")
        if line.startswith(self._boundary + b"--"):
            raise ConnectionError("the stream ended")
        length: int | None = None
        self._part_age_s = None
        for _ in range(MAX_HEADERS + 1):
            line = self._readline()
            if not line:
                break
            key, _, value = line.partition(b":")
            if key.strip().lower() == CAPTURE_AGE_KEY:
                self._part_age_s = _age(value)
            elif key.strip().lower() == b"content-length":
                try:
                    length = int(value.strip())
                except ValueError:
                    raise ConnectionError("bad Content-Length") from None
        else:
            raise ConnectionError("too many part headers")
        if length is None:
            raise _NotMjpeg("MJPEG parts without Content-Length")
        if not 0 < length <= MAX_FRAME_BYTES:
            raise ConnectionError(f"frame of {length} bytes")
        data = resp.read(length)
        if len(data) < length:
            raise ConnectionError("the stream ended inside a frame")
        return decode_image(data, self.name)

    # --- GrabbedSource ----------------------------------------------------------------------

    def _grab_image(self) -> Image | None:
        if self._pending is not None:
            image, self._pending = self._pending, None
            self._reported_age_s = self._part_age_s  # the opening frame, read moments ago
            return image
        try:
            if self._resp is None:
                self._connect()
            image = self._next_image()
            self._reported_age_s = self._part_age_s
            return image
        except (OSError, http.client.HTTPException, InputError, _NotMjpeg) as exc:
            log.debug("camera %s: %s", self.name, exc)
            self._disconnect()
            time.sleep(0.5)  # then reconnect
            return None

    def _interrupt(self) -> None:
        conn = self._conn
        if conn is not None and conn.sock is not None:
            with contextlib.suppress(OSError):
                conn.sock.shutdown(socket.SHUT_RDWR)

    def _release(self) -> None:
        self._disconnect()


def open_http_source(url: str, *, clock: Clock | None = None,
                     timeout_s: float = DEFAULT_TIMEOUT_S,
                     latency_s: float = 0.0) -> FrameSource:
    """An MJPEG or snapshot URL read by :class:`MjpegHttpSource`; anything else by OpenCV."""
    try:
        return MjpegHttpSource(url, clock=clock, timeout_s=timeout_s, latency_s=latency_s)
    except _NotMjpeg as exc:
        log.info("camera %s: %s; reading it through OpenCV", url, exc)
        return LiveCaptureSource(url, url, clock=clock, timeout_s=timeout_s,
                                 latency_s=latency_s)
