"""Frame sources behind one small protocol.

A camera, a video file, a network stream, a folder of images and the simulator's renderer all
deliver :class:`Frame` objects through :class:`FrameSource`, so the detector cannot tell them apart.

:func:`open_source` picks the kind from a string, as ``--camera`` and ``serve-camera`` take it:

- ``"0"``, ``"1"`` …, ``/dev/video0`` … — a camera device (OpenCV ``VideoCapture``);
- ``http://``, ``https://`` — an MJPEG stream (``marknav serve-camera``, an IP camera), read
  by :mod:`marknav.vision.sources.mjpeg` with bounded socket timeouts (no FFmpeg: a frozen
  server is a stopped stream, never a crash); an HTTP URL that serves something else goes to OpenCV;
- ``rtsp://`` — a network stream through OpenCV/FFmpeg, with open and read timeouts;
- a directory, or a glob such as ``shots/*.png`` — its images in name order, each once;
- an image file (png, jpg, bmp, tif, webp) — a still camera: every read gives that image again,
  with a new index;
- any other file — a video, frame by frame.

Live sources (devices and streams) are read on a background thread that keeps only the newest
frame: a reader slower than the camera then sees the present, not a queue of old frames (read at
10 Hz, a 30 fps stream otherwise falls seconds behind). ``read`` returns a frame newer than the
last one it returned, waiting at most ``timeout_s`` for it, else ``None`` — a camera that stops
delivering is reported (logged, and ``None``), never hung on. The control loop opens its camera
with ``timeout_s=0``: a tick takes the newest frame if there is one and never waits.
"""

from __future__ import annotations

import glob
import stat
from pathlib import Path

from marknav.core.clock import Clock
from marknav.core.errors import InputError
from marknav.core.inputfile import stat_path
from marknav.vision.sources.frames import (
    DEFAULT_TIMEOUT_S,
    FFMPEG_OPEN_TIMEOUT_MS,
    FFMPEG_READ_TIMEOUT_MS,
    IMAGE_SUFFIXES,
    STREAM_SCHEMES,
    Frame,
    FrameSource,
    GrabbedSource,
    Image,
    ImageFolderSource,
    LiveCaptureSource,
    StillImageSource,
    VideoFileSource,
    open_capture,
    read_image,
)
from marknav.vision.sources.mjpeg import open_http_source

__all__ = [
    "DEFAULT_TIMEOUT_S",
    "FFMPEG_OPEN_TIMEOUT_MS",
    "FFMPEG_READ_TIMEOUT_MS",
    "IMAGE_SUFFIXES",
    "STREAM_SCHEMES",
    "Frame",
    "FrameSource",
    "GrabbedSource",
    "Image",
    "ImageFolderSource",
    "LiveCaptureSource",
    "StillImageSource",
    "VideoFileSource",
    "open_capture",
    "open_source",
    "read_image",
]


def open_source(spec: str, *, clock: Clock | None = None,
                timeout_s: float = DEFAULT_TIMEOUT_S, latency_s: float = 0.0) -> FrameSource:
    """Open ``spec`` (see the module docstring); :class:`InputError` naming it if it cannot.
    A live source stamps its frames with their arrival time minus ``latency_s`` (and minus the
    age an MJPEG server reports); files and stills are stamped when read."""
    spec = spec.strip()
    if not spec:
        raise InputError("empty camera name", field="--camera")
    if spec.isdigit():
        return LiveCaptureSource(spec, int(spec), clock=clock, timeout_s=timeout_s,
                                 latency_s=latency_s)
    if spec.startswith("/dev/video"):
        if stat_path(spec, field="--camera") is None:
            raise InputError("no such camera device", file=spec)
        return LiveCaptureSource(spec, spec, clock=clock, timeout_s=timeout_s,
                                 latency_s=latency_s)
    if spec.lower().startswith(("http://", "https://")):
        return open_http_source(spec, clock=clock, timeout_s=timeout_s, latency_s=latency_s)
    if spec.lower().startswith(STREAM_SCHEMES):
        return LiveCaptureSource(spec, spec, clock=clock, timeout_s=timeout_s,
                                 latency_s=latency_s)
    st = stat_path(spec, field="--camera")
    if st is not None and stat.S_ISDIR(st.st_mode):
        paths = sorted(str(p) for p in Path(spec).iterdir()
                       if p.suffix.lower() in IMAGE_SUFFIXES)
        return ImageFolderSource(spec, paths, clock=clock)
    if any(ch in spec for ch in "*?["):
        paths = sorted(p for p in glob.glob(spec) if Path(p).suffix.lower() in IMAGE_SUFFIXES)
        return ImageFolderSource(spec, paths, clock=clock)
    if st is None:
        raise InputError("no such file, directory or camera", file=spec)
    if Path(spec).suffix.lower() in IMAGE_SUFFIXES:
        return StillImageSource(spec, clock=clock)
    return VideoFileSource(spec, clock=clock)
