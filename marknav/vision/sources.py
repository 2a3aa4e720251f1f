"""Frame sources behind one small protocol.

A camera, a video file, a network stream, a folder of images and the simulator's renderer all
deliver :class:`Frame` objects through :class:`FrameSource`, so the detector cannot tell them apart.

:func:`open_source` picks the kind from a string, as ``--camera`` and ``serve-camera`` take it:

- ``"0"``, ``"1"`` …, ``/dev/video0`` … — a camera device (OpenCV ``VideoCapture``);
- ``http://``, ``https://``, ``rtsp://`` — a network stream (an MJPEG stream from
  ``marknav serve-camera``, an IP camera);
- a directory, or a glob such as ``shots/*.png`` — its images in name order, each once;
- an image file (png, jpg, bmp, tif, webp) — a still camera: every read gives that image again,
  with a new index;
- any other file — a video, frame by frame.

Live sources (devices and streams) are read on a background thread that keeps only the newest
frame: a reader slower than the camera then sees the present, not a queue of old frames (read at
10 Hz, a 30 fps stream otherwise falls seconds behind). ``read`` returns a frame newer than the
last one it returned, waiting at most ``timeout_s`` for it, else ``None`` — a camera that stops
delivering is reported (logged, and ``None``), never hung on.
"""

from __future__ import annotations

import glob
import logging
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol, runtime_checkable

import cv2
import numpy as np
import numpy.typing as npt

from marknav.clock import Clock, MonotonicClock
from marknav.errors import InputError
from marknav.vision import imagefile

log = logging.getLogger(__name__)

Image = npt.NDArray[np.uint8]

IMAGE_SUFFIXES = frozenset({".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp"})
STREAM_SCHEMES = ("http://", "https://", "rtsp://")
#: How long a live source waits for a new frame before ``read`` returns None.
DEFAULT_TIMEOUT_S = 1.0


@dataclass(frozen=True)
class Frame:
    """One BGR image with the time it was taken (source clock, seconds) and its index."""

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


class LiveCaptureSource:
    """A camera device or network stream, grabbed on a thread that keeps the newest frame."""

    def __init__(self, name: str, target: int | str, *, clock: Clock | None = None,
                 timeout_s: float = DEFAULT_TIMEOUT_S, open_timeout_s: float = 5.0) -> None:
        self.name = name
        self.timeout_s = timeout_s
        self._clock = clock or MonotonicClock()
        self._cap = cv2.VideoCapture(target)
        if not self._cap.isOpened():
            self._cap.release()
            raise InputError("cannot open the camera or stream", file=name)
        self._cond = threading.Condition()
        self._latest: Frame | None = None
        self._returned = 0
        self._closing = False
        self._failed_reported = False
        self._thread = threading.Thread(target=self._grab, name=f"camera {name}", daemon=True)
        self._thread.start()
        with self._cond:
            self._cond.wait_for(lambda: self._latest is not None or self._closing,
                                timeout=open_timeout_s)
            if self._latest is None:
                self.close()
                raise InputError(f"no frame within {open_timeout_s:g} s", file=name)

    def _grab(self) -> None:
        index = 0
        while True:
            with self._cond:
                if self._closing:
                    return
            ok, image = self._cap.read()
            if not ok or image is None:
                with self._cond:
                    if self._closing:
                        return
                    if not self._failed_reported:
                        log.warning("camera %s: no frame (stream stopped?)", self.name)
                        self._failed_reported = True
                time.sleep(0.05)
                continue
            index += 1
            frame = Frame(np.asarray(image, dtype=np.uint8), self._clock.now(), index)
            with self._cond:
                self._latest = frame
                self._failed_reported = False
                self._cond.notify_all()

    def read(self) -> Frame | None:
        with self._cond:
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
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(timeout=2.0)
        self._cap.release()


def open_source(spec: str, *, clock: Clock | None = None,
                timeout_s: float = DEFAULT_TIMEOUT_S) -> FrameSource:
    """Open ``spec`` (see the module docstring); :class:`InputError` naming it if it cannot."""
    spec = spec.strip()
    if not spec:
        raise InputError("empty camera name", field="--camera")
    if spec.isdigit():
        return LiveCaptureSource(spec, int(spec), clock=clock, timeout_s=timeout_s)
    if spec.startswith("/dev/video"):
        if not Path(spec).exists():
            raise InputError("no such camera device", file=spec)
        return LiveCaptureSource(spec, spec, clock=clock, timeout_s=timeout_s)
    if spec.lower().startswith(STREAM_SCHEMES):
        return LiveCaptureSource(spec, spec, clock=clock, timeout_s=timeout_s)
    path = Path(spec)
    if path.is_dir():
        paths = sorted(str(p) for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
        return ImageFolderSource(spec, paths, clock=clock)
    if any(ch in spec for ch in "*?["):
        paths = sorted(p for p in glob.glob(spec) if Path(p).suffix.lower() in IMAGE_SUFFIXES)
        return ImageFolderSource(spec, paths, clock=clock)
    if not path.exists():
        raise InputError("no such file, directory or camera", file=spec)
    if path.suffix.lower() in IMAGE_SUFFIXES:
        return StillImageSource(spec, clock=clock)
    return VideoFileSource(spec, clock=clock)
