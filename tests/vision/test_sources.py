"""Frame sources: still image, folder, glob, video file, bad names (live streams are tested
against marknav serve-camera in tests/remote/test_mjpeg_server.py)."""

from __future__ import annotations

import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from marknav.core.clock import ManualClock
from marknav.core.errors import InputError
from marknav.vision.sources import (
    FrameSource,
    ImageFolderSource,
    StillImageSource,
    VideoFileSource,
    open_source,
)

SMARTIES = Path(__file__).resolve().parents[1] / "data" / "smarties.png"


def test_still_image_is_a_still_camera() -> None:
    clock = ManualClock(5.0)
    src = open_source(str(SMARTIES), clock=clock)
    assert isinstance(src, StillImageSource) and isinstance(src, FrameSource)
    a = src.read()
    clock.advance(0.05)
    b = src.read()
    assert a is not None and b is not None
    assert a.image.shape == (356, 413, 3)
    assert (a.index, b.index) == (1, 2)
    assert (a.t, b.t) == (5.0, 5.05)
    src.close()
    assert src.read() is None


def test_folder_and_glob_give_each_image_once_in_order(tmp_path: Path) -> None:
    for name in ("b.png", "a.png"):
        shutil.copy(SMARTIES, tmp_path / name)
    (tmp_path / "notes.txt").write_text("not an image")
    for spec in (str(tmp_path), str(tmp_path / "*.png")):
        src = open_source(spec)
        assert isinstance(src, ImageFolderSource)
        frames = [src.read(), src.read(), src.read()]
        assert [f.index if f else None for f in frames] == [1, 2, None]


def test_video_file_frames_then_none(tmp_path: Path) -> None:
    path = tmp_path / "clip.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (64, 48))
    for k in range(3):
        writer.write(np.full((48, 64, 3), 60 * k, dtype=np.uint8))
    writer.release()
    src = open_source(str(path))
    assert isinstance(src, VideoFileSource)
    got = [src.read() for _ in range(4)]
    assert [f.index if f else None for f in got] == [1, 2, 3, None]
    assert got[2] is not None and abs(int(got[2].image.mean()) - 120) <= 3
    src.close()
    src.close()  # idempotent


@pytest.mark.parametrize(
    ("spec", "message"),
    [("missing.png", "missing.png: not an image marknav reads"),
     ("nowhere/clip.mp4", "nowhere/clip.mp4: no such file, directory or camera"),
     ("/dev/video97", "/dev/video97: no such camera device")],
)
def test_bad_sources_raise_input_errors_naming_them(tmp_path: Path, spec: str,
                                                    message: str) -> None:
    if spec.endswith(".png"):
        (tmp_path / spec).write_bytes(b"not a png")
        spec = str(tmp_path / spec)
        message = f"{tmp_path}/{message}"
    with pytest.raises(InputError) as exc:
        open_source(spec)
    assert message in str(exc.value)


def test_empty_folder_is_an_input_error(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="no images found"):
        open_source(str(tmp_path))


def test_unreadable_file_as_video_is_an_input_error(tmp_path: Path) -> None:
    bogus = tmp_path / "data.bin"
    bogus.write_bytes(b"\x00" * 64)
    with pytest.raises(InputError, match="cannot open as a video or image"):
        open_source(str(bogus))
