"""Frames and the sources that deliver them: stills, image folders, video files, and live
cameras or streams grabbed on a thread (see :mod:`marknav.vision.sources`)."""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import cv2
import numpy as np
import numpy.typing as npt

from marknav.core.clock import Clock, MonotonicClock
from marknav.core.errors import InputError
from marknav.core.inputfile import check_regular_file
from marknav.vision import imagefile

log = logging.getLogger(__name__)

Image = npt.NDArray[np.uint8]

IMAGE_SUFFIXES = frozenset({".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp"})
STREAM_SCHEMES = ("http://", "https://", "rtsp://")
#: How long a live source waits for a new frame before ``read`` returns None.
DEFAULT_TIMEOUT_S = 1.0


@dataclass(frozen=True)
class Frame:
    """One BGR image with the time it was captured (the source's clock, seconds: its best
    estimate, see :class:`GrabbedSource`) and its index."""

    image: Image
    t: float
    index: int


@runtime_checkable
class FrameSource(Protocol):
    """Anything that delivers frames. ``read`` returns ``None`` when no frame is available
    (end of a file, a stream that stopped); it never blocks for longer than its own timeout."""

    name: str

    def read(self) -> Frame | None: ...

    def close(self) -> None: ...


def read_image(path: str) -> Image:
    """Read a BGR image; :class:`InputError` naming the file if it cannot (bounded: see
    :mod:`marknav.vision.imagefile`)."""
    return imagefile.read_image(path)


class StillImageSource:
    """One image as a still camera: every read returns it again, with a new index."""

    def __init__(self, path: str, *, clock: Clock | None = None) -> None:
        self.name = path
        self._image = read_image(path)
        self._clock = clock or MonotonicClock()
        self._index = 0
        self._closed = False

    def read(self) -> Frame | None:
        if self._closed:
            return None
        self._index += 1
        return Frame(self._image, self._clock.now(), self._index)

    def close(self) -> None:
        self._closed = True


class ImageFolderSource:
    """Images in name order, each once; then ``None``."""

    def __init__(self, name: str, paths: list[str], *, clock: Clock | None = None) -> None:
        if not paths:
            raise InputError("no images found", file=name)
        self.name = name
        self._paths = paths
        self._clock = clock or MonotonicClock()
        self._next = 0

    def read(self) -> Frame | None:
        while self._next < len(self._paths):
            path = self._paths[self._next]
            self._next += 1
            try:
                image = imagefile.read_image(path)
            except InputError as exc:
                log.warning("%s: skipping %s", self.name, exc)
                continue
            return Frame(image, self._clock.now(), self._next)
        return None

    def close(self) -> None:
        self._next = len(self._paths)


class VideoFileSource:
    """A video file, frame by frame, then ``None``."""

    def __init__(self, path: str, *, clock: Clock | None = None) -> None:
        self.name = path
        # OpenCV opens by name and blocks for ever in open() on a FIFO with no writer: only a
        # regular file reaches it (checked without blocking, like every file marknav reads).
        check_regular_file(path, what="a video file")
        cap = cv2.VideoCapture(path)
        if not cap.isOpened():
            cap.release()
            raise InputError("cannot open as a video or image", file=path)
        self._cap: cv2.VideoCapture | None = cap
        self._clock = clock or MonotonicClock()
        self._index = 0

    def read(self) -> Frame | None:
        if self._cap is None:
            return None
        ok, image = self._cap.read()
        if not ok or image is None:
            return None
        self._index += 1
        return Frame(np.asarray(image, dtype=np.uint8), self._clock.now(), self._index)

    def close(self) -> None:
        if self._cap is not None:
            self._cap.release()
            self._cap = None


class GrabbedSource:
    """A live source read on a thread that keeps only the newest frame.

    Subclasses implement :meth:`_grab_image` (block at most a bounded time for the next image;
    ``None`` when none came) and :meth:`_release`. ``read`` never waits longer than
    ``timeout_s`` (``0``: the control cycle takes the newest frame if there is one, and goes on).

    A frame's time is its capture time as well as it is known: the arrival time minus the age
    the source reported for it (:attr:`_reported_age_s`, set by :meth:`_grab_image`: an MJPEG
    server's ``X-Capture-Age``) minus ``latency_s``, the delay nobody reports (configured:
    ``camera.latency_s``). OpenCV's ``CAP_PROP_POS_MSEC`` is not used: for V4L2 webcams it is
    the driver's buffer time stamp on a clock OpenCV does not name (monotonic or wall, by
    driver), for streams a position in the stream — neither comparable with this clock.
    """

    def __init__(self, name: str, *, clock: Clock | None = None,
                 timeout_s: float = DEFAULT_TIMEOUT_S, latency_s: float = 0.0) -> None:
        if not (latency_s >= 0.0 and latency_s < float("inf")):
            raise InputError(f"must be ≥ 0 s, got {latency_s!r}", field="camera.latency_s")
        self.name = name
        self.timeout_s = timeout_s
        self.latency_s = float(latency_s)
        #: The age of the image :meth:`_grab_image` just returned, as its source reported it.
        self._reported_age_s: float | None = None
        self._clock = clock or MonotonicClock()
        self._cond = threading.Condition()
        self._latest: Frame | None = None
        self._returned = 0
        self._closing = False
        self._failed_reported = False
        self._thread = threading.Thread(target=self._grab, name=f"camera {name}", daemon=True)

    def _start(self, open_timeout_s: float) -> None:
        """Start grabbing; :class:`InputError` if no frame arrives within ``open_timeout_s``
        (the wait is interruptible: Ctrl-C ends it at once)."""
        self._thread.start()
        deadline = time.monotonic() + open_timeout_s
        with self._cond:
            while self._latest is None and not self._closing:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    break
                self._cond.wait(min(remaining, 0.1))
            got = self._latest is not None
        if not got:
            self.close()
            raise InputError(f"no frame within {open_timeout_s:g} s", file=self.name)

    def _grab_image(self) -> Image | None:  # pragma: no cover - abstract
        raise NotImplementedError

    def _release(self) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def _interrupt(self) -> None:
        """Unblock a :meth:`_grab_image` in progress (close a socket…); default: nothing."""

    def _grab(self) -> None:
        index = 0
        try:
            while True:
                with self._cond:
                    if self._closing:
                        return
                self._reported_age_s = None
                try:
                    image = self._grab_image()
                except Exception as exc:  # a camera failure must not end the thread silently
                    log.debug("camera %s: %s", self.name, exc)
                    image = None
                if image is None:
                    with self._cond:
                        if self._closing:
                            return
                        if not self._failed_reported:
                            log.warning("camera %s: no frame (stream stopped?)", self.name)
                            self._failed_reported = True
                    time.sleep(0.05)
                    continue
                index += 1
                age = (self._reported_age_s or 0.0) + self.latency_s
                frame = Frame(np.asarray(image, dtype=np.uint8), self._clock.now() - age, index)
                with self._cond:
                    self._latest = frame
                    self._failed_reported = False
                    self._cond.notify_all()
        finally:
            self._release()

    def read(self) -> Frame | None:
        with self._cond:
            if self.timeout_s > 0:
                self._cond.wait_for(
                    lambda: self._closing
                    or (self._latest is not None and self._latest.index > self._returned),
                    timeout=self.timeout_s,
                )
            frame = self._latest
            if self._closing or frame is None or frame.index <= self._returned:
                return None
            self._returned = frame.index
            return frame

    def close(self) -> None:
        with self._cond:
            if self._closing:
                return
            self._closing = True
            self._cond.notify_all()
        self._interrupt()
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(timeout=2.0)
        if not self._thread.is_alive() and self._thread.ident is None:
            self._release()  # never started


#: OpenCV (FFmpeg) waits at most this long to open a stream, and for each read.
FFMPEG_OPEN_TIMEOUT_MS = 5000
FFMPEG_READ_TIMEOUT_MS = 2000


def open_capture(target: int | str, name: str, *, timeout_s: float) -> cv2.VideoCapture:
    """``cv2.VideoCapture(target)`` with FFmpeg's open and read timeouts set, opened on a helper
    thread: the caller waits at most ``timeout_s`` and a Ctrl-C ends the wait at once (OpenCV's
    open blocks in C, where Python cannot handle the signal, for up to 30 s). A capture that
    opens after the caller gave up is released by the helper."""
    params = [cv2.CAP_PROP_OPEN_TIMEOUT_MSEC, FFMPEG_OPEN_TIMEOUT_MS,
              cv2.CAP_PROP_READ_TIMEOUT_MSEC, FFMPEG_READ_TIMEOUT_MS]
    box: dict[str, cv2.VideoCapture | bool] = {}
    done = threading.Event()
    lock = threading.Lock()

    def opener() -> None:
        try:
            cap = cv2.VideoCapture(target, cv2.CAP_ANY, params)
        except cv2.error as exc:
            log.debug("camera %s: %s", name, exc)
            cap = cv2.VideoCapture()
        with lock:
            if box.get("abandoned"):
                cap.release()
                return
            box["cap"] = cap
        done.set()

    threading.Thread(target=opener, name=f"open camera {name}", daemon=True).start()
    try:
        deadline = time.monotonic() + timeout_s
        while not done.wait(0.1):
            if time.monotonic() > deadline:
                raise InputError(f"the camera or stream did not open within {timeout_s:g} s",
                                 file=name)
    finally:
        with lock:
            if "cap" not in box:
                box["abandoned"] = True
    cap = box["cap"]
    assert isinstance(cap, cv2.VideoCapture)
    return cap


class LiveCaptureSource(GrabbedSource):
    """A camera device or network stream through OpenCV, grabbed on a thread that keeps the
    newest frame."""

    def __init__(self, name: str, target: int | str, *, clock: Clock | None = None,
                 timeout_s: float = DEFAULT_TIMEOUT_S, open_timeout_s: float = 5.0,
                 latency_s: float = 0.0) -> None:
        super().__init__(name, clock=clock, timeout_s=timeout_s, latency_s=latency_s)
        self._cap = open_capture(target, name,
                                 timeout_s=open_timeout_s + FFMPEG_OPEN_TIMEOUT_MS / 1000)
        if not self._cap.isOpened():
            self._cap.release()
            raise InputError("cannot open the camera or stream", file=name)
        self._start(open_timeout_s)

    def _grab_image(self) -> Image | None:
        ok, image = self._cap.read()
        return np.asarray(image, dtype=np.uint8) if ok and image is not None else None

    def _release(self) -> None:
        self._cap.release()
