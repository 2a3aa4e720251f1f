"""Frame sources behind one small protocol.

A camera, a video file, a network stream, a folder of images and the simulator's renderer all
deliver :class:`Frame` objects through :class:`FrameSource`, so the detector cannot tell them apart.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

Image = npt.NDArray[np.uint8]


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
