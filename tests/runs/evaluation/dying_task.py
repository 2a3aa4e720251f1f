"""A task for the local pool's tests whose worker process dies on some seeds (as a renderer's
library aborting the process would): importable by a spawned worker (it shares sys.path)."""

from __future__ import annotations

import os
import resource
import signal
from pathlib import Path


def task(folder: str, seed: int, max_time_s: float | None) -> tuple[int, int]:
    """Seed 5 always aborts its process; seed 3 aborts it the first time only (a file in
    ``folder`` remembers); the others return (seed, pid)."""
    first = Path(folder) / f"seed-{seed}"
    if seed == 5 or (seed == 3 and not first.exists()):
        first.touch()
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))  # no core file
        os.kill(os.getpid(), signal.SIGABRT)
    return seed, os.getpid()
