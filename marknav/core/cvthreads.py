"""OpenCV's thread count for work that is one thread's by nature.

A simulated run is lock-step: render a frame, detect its marks, tick the tree, step the
simulated Create — each on small arrays, one after the other. OpenCV's worker threads (on by
default, one per core) split each call's pixels between the cores; at 640×480 the hand-over
costs about what it saves. Measured on the 2-core CI machine (``marknav bench loop``, quiet,
two runs each, interleaved): closed loop 21.2×/21.8× real time with two threads, 21.9×/22.5×
with one, and 16–19 s of CPU per 40 s simulated against 21–22 (one thread leaves the other
core free). Evaluations run each job this way too: parallel runs (``--jobs``, Dask workers)
would otherwise compete for the cores the other runs need (two Dask workers evaluated only
1.42× as fast as one before).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["one_opencv_thread"]


@contextmanager
def one_opencv_thread() -> Iterator[None]:
    """OpenCV on one thread while the block runs, then as before (results are the same
    either way: OpenCV's parallel loops split pixels, not arithmetic). The setting is the
    process's: blocks overlapping in two threads would restore it out of order (runs in one
    process are serialised: ``evaluate_backends._RUN_LOCK``)."""
    import cv2

    before = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        yield
    finally:
        cv2.setNumThreads(before)
