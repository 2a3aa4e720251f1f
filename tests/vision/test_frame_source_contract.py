"""The ``FrameSource`` protocol's contract (marknav.vision.sources.frames), asserted of every
implementation.

Each implementation is one factory in ``SOURCES``, building the source on a ManualClock (its
frames' time stamps come from it; live sources' grabbing threads run on their own). The suite
asserts what the protocol and :class:`Frame` promise: ``read`` returns a :class:`Frame` (a BGR
``uint8`` image, a finite time, an index) or ``None``; indices and times never go backwards, and
a frame read again (same index) is the same frame; a finite source ends with ``None`` and stays
ended; ``close`` is idempotent and a closed source reads ``None``.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
import pytest

from marknav.core.clock import ManualClock
from marknav.planning.kinematics import Pose
from marknav.vision.sources.frames import (
    Frame,
    FrameSource,
    ImageFolderSource,
    LiveCaptureSource,
    StillImageSource,
    VideoFileSource,
)

DATA = Path(__file__).resolve().parents[1] / "data"
SMARTIES = DATA / "smarties.png"
VIDEO_FRAMES = 6


@dataclass
class Case:
    """A source under test: ``length`` frames then ``None`` (None: it never ends while open),
    ``live`` if a thread grabs its frames (a read may find nothing new yet, or frames skipped)."""

    source: FrameSource
    length: int | None
    live: bool = False
    cleanups: list[Callable[[], None]] = field(default_factory=list)
    clock: ManualClock = field(default_factory=ManualClock)  # the one the source was given


def _write_video(path: Path) -> Path:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"MJPG"), 10.0, (64, 48))
    assert writer.isOpened()
    for k in range(VIDEO_FRAMES):
        writer.write(np.full((48, 64, 3), 40 * k, dtype=np.uint8))
    writer.release()
    return path


def still(tmp: Path, clock: ManualClock) -> Case:
    return Case(StillImageSource(str(SMARTIES), clock=clock), length=None)


def folder(tmp: Path, clock: ManualClock) -> Case:
    paths = []
    for k in range(3):
        paths.append(str(tmp / f"{k}.png"))
        cv2.imwrite(paths[-1], np.full((20, 30, 3), 60 * k, dtype=np.uint8))
    return Case(ImageFolderSource(str(tmp), paths, clock=clock), length=3)


def video_file(tmp: Path, clock: ManualClock) -> Case:
    return Case(VideoFileSource(str(_write_video(tmp / "v.avi")), clock=clock),
                length=VIDEO_FRAMES)


def camera(tmp: Path, clock: ManualClock) -> Case:
    # The OpenCV camera source opens whatever cv2.VideoCapture opens; no device here, so a
    # video file stands in for it: grabbed on its thread like a webcam, ending when it ends.
    path = _write_video(tmp / "camera.avi")
    return Case(LiveCaptureSource("camera", str(path), clock=clock, timeout_s=0.2), length=None,
                live=True)


def mjpeg(tmp: Path, clock: ManualClock) -> Case:
    from marknav.remote.mjpeg_server import CameraStreamer, MjpegServer
    from marknav.vision.sources.mjpeg import MjpegHttpSource

    streamer = CameraStreamer(lambda: StillImageSource(str(SMARTIES)), name="still", live=False,
                              fps=30)
    streamer.start(first_frame_timeout_s=3.0)
    server = MjpegServer(streamer, host="127.0.0.1", port=0).start()
    source = MjpegHttpSource(server.stream_url, clock=clock, timeout_s=1.0)
    return Case(source, length=None, live=True, cleanups=[server.close, streamer.close])


def sim_camera(tmp: Path, clock: ManualClock) -> Case:
    from marknav.sim.builtin_camera import SimCamera
    from marknav.sim.world import Conditions, MarkSpec, World
    from marknav.vision.palette import DEFAULT_PALETTE

    world = World(marks=(MarkSpec(x_mm=0.0, y_mm=1500.0, colour="red"),),
                  conditions=Conditions(noise_sigma=0.0))
    return Case(SimCamera(world, DEFAULT_PALETTE, pose_fn=lambda: Pose(0.0, 0.0, math.pi / 2),
                          clock=clock), length=None)


def mujoco_camera(tmp: Path, clock: ManualClock) -> Case:
    from marknav.sim.mujoco import gl

    gl.backend()  # the headless renderer, chosen before anything imports mujoco
    pytest.importorskip("mujoco")
    from marknav.sim.builtin_camera import CameraConfig
    from marknav.sim.mujoco.body import MujocoBody
    from marknav.sim.mujoco.camera import MujocoCamera
    from marknav.sim.world import Conditions, World
    from marknav.vision.palette import DEFAULT_PALETTE

    body = MujocoBody(World(marks=(), conditions=Conditions(noise_sigma=0.0)), DEFAULT_PALETTE,
                      camera=CameraConfig(width=160, height=120), shadows=False)
    return Case(MujocoCamera(body, clock=clock), length=None)


#: Every FrameSource implementation: one line each.
SOURCES: list[object] = [
    pytest.param(still, id="still-image"),
    pytest.param(folder, id="image-folder"),
    pytest.param(video_file, id="video-file"),
    pytest.param(camera, id="opencv-camera-on-a-video-file"),
    pytest.param(mjpeg, id="mjpeg-http"),
    pytest.param(sim_camera, id="simulator-camera"),
    pytest.param(mujoco_camera, id="mujoco-camera"),
]


@pytest.fixture(params=SOURCES)
def case(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Case]:
    factory: Callable[[Path, ManualClock], Case] = request.param
    clock = ManualClock(100.0)
    c = factory(tmp_path, clock)
    c.cleanups.insert(0, c.source.close)
    c.clock = clock
    yield c
    for cleanup in c.cleanups:
        cleanup()


def read_frames(case: Case, n: int) -> list[Frame]:
    """Up to ``n`` reads, the clock moving 50 ms between them; stops at the first ``None``."""
    out = []
    for _ in range(n):
        frame = case.source.read()
        if frame is None:
            break
        out.append(frame)
        case.clock.advance(0.05)
    return out


def assert_is_a_frame(frame: object) -> None:
    assert isinstance(frame, Frame)
    image = frame.image
    assert isinstance(image, np.ndarray) and image.dtype == np.uint8
    assert image.ndim == 3 and image.shape[2] == 3 and image.shape[0] > 0 and image.shape[1] > 0
    assert isinstance(frame.t, float) and math.isfinite(frame.t)
    assert isinstance(frame.index, int)


def test_it_is_a_frame_source_with_a_name(case: Case) -> None:
    assert isinstance(case.source, FrameSource)
    assert isinstance(case.source.name, str) and case.source.name


def test_the_first_read_is_a_frame(case: Case) -> None:
    assert_is_a_frame(case.source.read())


def test_frames_never_go_back_in_index_or_time(case: Case) -> None:
    frames = read_frames(case, 5)
    assert frames
    for frame in frames:
        assert_is_a_frame(frame)
    for before, after in itertools.pairwise(frames):
        assert after.index >= before.index
        assert after.t >= before.t
        if after.index == before.index:  # nothing new: the same frame again
            assert after.t == before.t


def test_time_stamps_come_from_the_sources_clock(case: Case) -> None:
    frame = case.source.read()
    assert frame is not None
    # a live frame may be stamped earlier than the read (its reported capture age), never later
    assert frame.t <= case.clock.now()
    assert frame.t > case.clock.now() - 60.0


def test_a_finite_source_ends_with_none_and_stays_ended(case: Case) -> None:
    if case.length is None:
        frames = read_frames(case, 8)
        # an endless source goes on delivering (a live one: while its producer does)
        assert len(frames) == 8 or (case.live and frames)
        return
    frames = read_frames(case, case.length + 5)
    assert len(frames) == case.length
    assert [f.index for f in frames] == sorted({f.index for f in frames})  # each frame once
    assert case.source.read() is None
    assert case.source.read() is None


def test_close_is_idempotent_and_a_closed_source_reads_none(case: Case) -> None:
    assert case.source.read() is not None
    case.source.close()
    case.source.close()
    assert case.source.read() is None
    assert case.source.read() is None


def test_a_source_closed_before_any_read_reads_none(case: Case) -> None:
    case.source.close()
    assert case.source.read() is None
