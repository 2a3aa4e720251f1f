"""Commands given many images decode them one at a time (issue 41, R7): a 629-byte JPEG whose
header claims 7000×7000 decodes to 147 MB; sixteen of them held at once were 2.6 GB in
``detect`` (and 5 GB in ``palette``)."""

from __future__ import annotations

import os
import struct
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

#: Images given, each decoding to 7000 × 7000 × 3 bytes (147 MB).
N_IMAGES = 16
#: Peak resident memory allowed for ``detect`` over them (bytes): the interpreter and its
#: libraries (≈ 350 MB), one decoded image and the detector's work on it; all sixteen held at
#: once were 2.6 GB.
PEAK_ALLOWED_B = 1200 * 2**20


def _small_jpeg_claiming_7000_square() -> bytes:
    ok, data = cv2.imencode(".jpg", np.full((16, 16, 3), 128, np.uint8))
    assert ok
    b = bytearray(data.tobytes())
    sof = b.find(b"\xff\xc0")
    b[sof + 5:sof + 9] = struct.pack(">HH", 7000, 7000)  # height, width
    return bytes(b)


@pytest.mark.slow
def test_detect_holds_one_decoded_image_at_a_time(tmp_path: Path) -> None:
    data = _small_jpeg_claiming_7000_square()
    names = []
    for k in range(N_IMAGES):
        (tmp_path / f"big{k}.jpg").write_bytes(data)
        names.append(f"big{k}.jpg")
    proc = subprocess.Popen([sys.executable, "-m", "marknav", "detect", *names], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    assert proc.stdout is not None
    stdout = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)  # this child's own peak, not any earlier one's
    proc.returncode = os.waitstatus_to_exitcode(status)
    peak = usage.ru_maxrss * 1024  # KiB on Linux
    assert proc.returncode == 0
    assert stdout.count(": 0 marks") == N_IMAGES
    assert peak < PEAK_ALLOWED_B, f"peak {peak / 2**20:.0f} MB"
