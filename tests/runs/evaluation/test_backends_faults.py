"""The Dask backend under faults (issue 31, B5): a scheduler address that accepts and never
answers is exit 2 within seconds, with one message and no clean-up traceback.
"""

from __future__ import annotations

import socket
import time
from pathlib import Path

import pytest

from tests.faultkit import (
    SLALOM,
    marknav,
)


def test_a_dask_address_that_never_answers_is_exit_2_within_seconds(tmp_path: Path) -> None:
    """A peer that accepts the connection and says nothing (a wrong port, a stuck scheduler):
    the connect used to wait for ever; a failed client printed a clean-up traceback after the
    exit-2 message."""
    pytest.importorskip("distributed")
    with socket.socket() as listener:
        listener.bind(("127.0.0.1", 0))
        listener.listen(8)
        address = f"tcp://127.0.0.1:{listener.getsockname()[1]}"
        t0 = time.monotonic()
        proc = marknav("evaluate", str(SLALOM), "--runs", "1", "--dask", address, cwd=tmp_path,
                       timeout=60)
        took = time.monotonic() - t0
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr and "Exception" not in proc.stderr, proc.stderr
    assert f"--dask: cannot connect to the Dask scheduler at {address}" in proc.stderr
    lines = proc.stderr.splitlines()
    assert lines[-1].startswith("marknav evaluate: error: --dask")  # the one message, last
    assert all(line.startswith("evaluate slalom: 0/1 runs done") for line in lines[:-1]), lines
    assert took < 30  # 3 s for the scheduler to answer, plus start-up on a loaded machine
